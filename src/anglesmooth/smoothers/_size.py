"""A size guard for the angle-only objective of ``optimization``: no incident cell shrinks far below its neighbours.

Why
    The max-min-angle objective is blind to size: measured on the paper-style quad meshes, 10
    passes of ``optimization`` made the smallest quad a well-shaped one (76 deg) of an eighth of its
    input area, area ratio 938 against Laplacian's 53; on the boundary-layer meshes 80 against 33.
    The per-pass area band of :func:`._local.optimize` (each incident cell within [band, 1/band] of
    its area at the start of the pass) compounds over passes.

The rule
    After the compass search, a node whose smallest incident cell ends below ``beta`` times the
    mean area of its incident cells at the start of the pass (and below its smallest one then:
    a cell that was already that small may keep its size) takes, instead, the first of its move
    halved once or twice, or staying, that satisfies this and scores no worse than the start
    (:meth:`score`): the local minimum angle still never decreases.
"""

from __future__ import annotations

import numpy as np

from ..topology import Block, Topology

__all__ = ["incident_areas", "size_guard"]


def incident_areas(points: np.ndarray, topo: Topology, blk: Block, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(smallest, mean) twice-area of the incident cells of each block node at positions ``X`` (..., n, 2)."""
    n = blk.size
    a0 = blk.nodes.start
    lead = X.shape[:-2]
    Xf = X.reshape((-1, n, 2))
    K = Xf.shape[0]
    lo = np.full((K, n), np.inf)
    tot = np.zeros((K, n))
    cnt = np.zeros(n)
    for rows, loc, verts in ((blk.tris, topo.tri_loc, topo.tri_verts), (blk.quads, topo.quad_loc, topo.quad_verts)):
        if rows.stop <= rows.start:
            continue
        rel = loc[rows] - a0
        v = verts[rows]
        x = Xf[:, rel]  # (K, m, 2)
        if v.shape[1] == 3:
            pa, pb = points[v[:, 1]], points[v[:, 2]]
            ar = (pa[:, 0] - x[..., 0]) * (pb[:, 1] - x[..., 1]) - (pa[:, 1] - x[..., 1]) * (pb[:, 0] - x[..., 0])
        else:
            pa, pb, pc = points[v[:, 1]], points[v[:, 2]], points[v[:, 3]]
            ar = (pb[:, 0] - x[..., 0]) * (pc[:, 1] - pa[:, 1]) - (pb[:, 1] - x[..., 1]) * (pc[:, 0] - pa[:, 0])
        for k in range(K):
            np.minimum.at(lo[k], rel, ar[k])
            tot[k] += np.bincount(rel, ar[k], minlength=n)
        cnt += np.bincount(rel, minlength=n)
    mean = tot / np.maximum(cnt, 1)
    return lo.reshape(lead + (n,)), mean.reshape(lead + (n,))


def size_guard(geom, points, topo, blk, start, new, beta: float, gamma: float = 1.0):
    """``new`` positions, with the moves that shrink a cell below the rule's bound shortened (see the module)."""
    lo0, mean0 = incident_areas(points, topo, blk, start)
    bound = np.minimum(beta * mean0, gamma * lo0)
    lo1, _ = incident_areas(points, topo, blk, new)
    bad = np.flatnonzero((lo1 < bound) & (new != start).any(axis=1))
    if not bad.size:
        return new
    fr = np.array([0.5, 0.25])
    st, nw = start[bad], new[bad]
    cands = st[None] + fr[:, None, None] * (nw - st)[None]
    full = np.broadcast_to(start, (2,) + start.shape).copy()
    full[:, bad] = cands
    lo_c, _ = incident_areas(points, topo, blk, full)
    sub = geom.restrict(bad)
    ok = (lo_c[:, bad] >= bound[bad]) & (sub.score(cands) >= sub.score(st))
    out = new.copy()
    k = np.argmax(ok, axis=0)
    hit = ok.any(axis=0)
    out[bad] = np.where(hit[:, None], cands[k, np.arange(bad.size)], st)
    return out
