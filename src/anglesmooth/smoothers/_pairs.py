"""Pair moves: the two free corners of a flattened quad move together.

The trap
    A quad flattened onto the boundary (two fixed corners F1, F2 on the boundary, two free corners
    q, r just inside; angles like 7, 12, 168, 173 deg) cannot be repaired one node at a time by a
    method that only takes moves that raise the local quality: lifting q alone raises the corners at
    F2 and q but turns the corner at r further towards 180 deg, so every single move of either free
    corner lowers the local minimum.  Measured on the distorted toothed quad meshes
    (``benchmarks/quality_matrix.py``): ``optimization`` left these quads at 10-17 deg (their input
    angles) where Laplacian, which does not care, lifts them.

The move
    For such a quad (exactly two free corners, adjacent; local quality below ``below``), q and r
    are translated *together* by one vector, found by the same compass search as
    :func:`._local.optimize` (8 directions, radius halved when no direction improves), maximizing
    the minimum corner quality over every cell incident to q or r (the same score as the per-node
    one: ``-cos`` for triangle corners, ``-|cos|`` for quad corners, an invalid cell -- inverted,
    degenerate, non-convex, or below an input floor -- ranking below every valid position).  Pairs
    whose cells overlap are not moved in the same pass (the pair of the worse quad wins),
    so each pair's score is exact.  A move is taken only if it raises the pair's score: the mesh's
    minimum angle over these cells never decreases.
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology
from ._floors import Floors
from ._local import INVALID, INVERTED_WEIGHT

__all__ = ["pair_moves"]

_COMPASS = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)


def _quad_quality(points: np.ndarray, quad: np.ndarray) -> np.ndarray:
    """Per quad, the minimum over its corners of ``-|cos|`` (-inf where a corner is not convex)."""
    p = points[quad]  # (m, 4, 2)
    e_next = np.roll(p, -1, axis=1) - p
    e_prev = np.roll(p, 1, axis=1) - p
    cr = e_next[..., 0] * e_prev[..., 1] - e_next[..., 1] * e_prev[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = (e_next * e_prev).sum(-1) / (np.linalg.norm(e_next, axis=-1) * np.linalg.norm(e_prev, axis=-1))
    q = np.where((cr > 0) & np.isfinite(cos), -np.abs(cos), -np.inf)
    return q.min(axis=1)


def _pairs(points: np.ndarray, topo: Topology, below: float):
    """(q, r) free-node pairs of the poor quads with exactly two free corners, adjacent; worst quad first."""
    quad = topo.quad
    if not quad.shape[0]:
        return np.zeros((0, 2), np.int64)
    free = ~topo.fixed[quad]  # (m, 4)
    two = free.sum(axis=1) == 2
    qual = _quad_quality(points, quad)
    poor = two & (qual < -np.cos(np.radians(below)))
    rows = np.flatnonzero(poor)
    if not rows.size:
        return np.zeros((0, 2), np.int64)
    rows = rows[np.argsort(qual[rows], kind="stable")]  # the worst first: they win shared cells
    f = free[rows]
    # adjacent free corners: k and k + 1 (mod 4) both free
    adj = f & np.roll(f, -1, axis=1)
    ok = adj.any(axis=1)
    rows, k = rows[ok], np.argmax(adj[ok], axis=1)
    return np.stack([quad[rows, k], quad[rows, (k + 1) % 4]], axis=1)


def _rows_of(loc_table: np.ndarray, locs: np.ndarray, group: np.ndarray):
    """(group, incidence row) of every incidence row of the free nodes ``locs`` (group ``group``)."""
    lo = np.searchsorted(loc_table, locs, side="left")
    hi = np.searchsorted(loc_table, locs, side="right")
    cnt = hi - lo
    owner = np.repeat(group, cnt)
    rows = np.repeat(lo - (np.cumsum(cnt) - cnt), cnt) + np.arange(int(cnt.sum()))
    return owner, rows


def _components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected components of the graph (n vertices, edges u-v): the smallest vertex of each."""
    label = np.arange(n, dtype=np.int64)
    while True:
        new = label.copy()
        np.minimum.at(new, label[u], label[v])
        np.minimum.at(new, label[v], label[u])
        new = new[new]
        while not np.array_equal(new[new], new):
            new = new[new]
        if np.array_equal(new, label):
            return label
        label = new


def _score(P, cells, owner, moving, shift, n_pairs, fl):
    """Pair scores with the pairs' nodes shifted: P (N, 2), cells (m, k) incidence rows' nodes,
    ``moving`` (m, k) bool, ``shift`` (K, n_pairs, 2) -> (K, n_pairs)."""
    K = shift.shape[0]
    k = cells.shape[1]
    X = P[cells][None] + np.where(moving[None, ..., None], shift[:, owner][:, :, None, :], 0.0)  # (K, m, k, 2)
    e_next = np.roll(X, -1, axis=2) - X
    e_prev = np.roll(X, 1, axis=2) - X
    cr = e_next[..., 0] * e_prev[..., 1] - e_next[..., 1] * e_prev[..., 0]
    ln, lp = np.linalg.norm(e_next, axis=-1), np.linalg.norm(e_prev, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = (e_next * e_prev).sum(-1) / (ln * lp)
    val = -np.abs(cos) if k == 4 else cos * -1.0
    ok = ((cr > 0) & np.isfinite(cos)).all(axis=2)
    if k == 4:
        area2 = (X[:, :, 2, 0] - X[:, :, 0, 0]) * (X[:, :, 3, 1] - X[:, :, 1, 1]) - (
            X[:, :, 2, 1] - X[:, :, 0, 1]
        ) * (X[:, :, 3, 0] - X[:, :, 1, 0])
    else:
        area2 = cr[:, :, 0]
    if fl is not None:
        fa, f1, fk = fl
        ok &= (area2 >= fa) & (ln[:, :, 0] >= f1) & (lp[:, :, 0] >= fk)
    q = np.where(ok, val.min(axis=2), np.inf)
    best = np.full((K, n_pairs), np.inf)
    bad = np.zeros((K, n_pairs))
    idx = np.broadcast_to(owner, q.shape)
    kk = np.broadcast_to(np.arange(K)[:, None], q.shape)
    np.minimum.at(best, (kk, idx), q)
    w = np.where(area2 > 0, 1.0, INVERTED_WEIGHT) * ~ok
    np.add.at(bad, (kk, idx), w)
    return best, bad


def pair_moves(
    points: np.ndarray,
    topo: Topology,
    floors: Floors | None = None,
    below: float = 45.0,
    iterations: int = 10,
    radius: float = 0.25,
) -> np.ndarray:
    """The points with the free corners of the poor flattened quads moved (see the module docstring)."""
    pairs = _pairs(points, topo, below)
    if not pairs.shape[0]:
        return points
    # groups: the connected free corners of chains of flattened quads (a corner shared by two of
    # them must move with both), in the order of their worst quad
    nodes, inv = np.unique(pairs.ravel(), return_inverse=True)
    inv = inv.reshape(-1, 2)
    lab = _components(nodes.shape[0], inv[:, 0], inv[:, 1])
    first = np.full(nodes.shape[0], pairs.shape[0], np.int64)
    np.minimum.at(first, lab[inv[:, 0]], np.arange(pairs.shape[0]))  # rank of each group: its worst pair
    roots = np.unique(lab)
    roots = roots[np.argsort(first[roots], kind="stable")]
    gid = np.empty(nodes.shape[0], np.int64)
    gid[roots] = np.arange(roots.shape[0])
    group = gid[lab]  # per node of ``nodes``
    n_groups = roots.shape[0]
    loc = np.empty(topo.n_points, np.int64)
    loc[topo.free_nodes] = np.arange(topo.n_free)
    order = np.argsort(loc[nodes], kind="stable")
    locs_sorted, grp_sorted = loc[nodes][order], group[order]
    rows_by_kind = []
    claim = np.full(topo.n_tri + topo.n_quad, n_groups, np.int64)
    for gi, (loc_table, verts, base) in enumerate(
        ((topo.tri_loc, topo.tri_verts, topo.tri), (topo.quad_loc, topo.quad_verts, topo.quad))
    ):
        owner, rows = _rows_of(loc_table, locs_sorted, grp_sorted)
        # cell identity: its sorted node tuple among the mesh's cells of that kind
        key = np.sort(verts[rows], axis=1)
        _, inv_k = np.unique(np.concatenate([np.sort(base, axis=1), key]), axis=0, return_inverse=True)
        ids = inv_k.ravel()[base.shape[0] :] + (0 if gi == 0 else topo.n_tri)
        np.minimum.at(claim, ids, owner)
        rows_by_kind.append((owner, rows, ids))
    # independent groups: no cell shared with a group of a worse quad
    lost = np.zeros(n_groups, bool)
    for owner, _, ids in rows_by_kind:
        lost[owner[claim[ids] != owner]] = True
    keep = np.flatnonzero(~lost)
    remap = np.full(n_groups, -1, np.int64)
    remap[keep] = np.arange(keep.size)
    n = keep.size
    node_group = np.full(topo.n_points, -1, np.int64)
    node_group[nodes] = remap[group]
    use = []
    for (owner, rows, _), verts, names in zip(
        rows_by_kind, (topo.tri_verts, topo.quad_verts), (("t_area2", "t_e1", "t_e2"), ("q_area2", "q_e1", "q_e3"))
    ):
        sel = remap[owner] >= 0
        o, r = remap[owner[sel]], rows[sel]
        if not o.size:
            continue
        cells = verts[r]
        moving = node_group[cells] == o[:, None]
        fl = None
        if floors is not None and floors.active:
            fl = tuple(getattr(floors, nm)[r] for nm in names)
        use.append((cells, o, moving, fl))
    P = np.asarray(points, dtype=np.float64)

    def score(shift):
        best = np.full((shift.shape[0], n), np.inf)
        bad = np.zeros((shift.shape[0], n))
        for cells, o, moving, fl in use:
            b, c = _score(P, cells, o, moving, shift, n, fl)
            best = np.minimum(best, b)
            bad += c
        return np.where(bad > 0, INVALID - bad, best)

    # radius: a quarter of the mean free edge of the group's pairs
    pg = remap[group[inv[:, 0]]]
    ok = pg >= 0
    e = P[pairs[ok, 0]] - P[pairs[ok, 1]]
    r = radius * np.bincount(pg[ok], np.hypot(e[:, 0], e[:, 1]), n) / np.maximum(np.bincount(pg[ok], minlength=n), 1)
    d = np.zeros((n, 2))
    s0 = score(d[None])[0]
    idx = np.arange(n)
    for _ in range(iterations):
        cands = d[None] + _COMPASS[:, None, :] * r[None, :, None]
        sc = score(cands)
        k = np.argmax(sc, axis=0)
        sk = sc[k, idx]
        better = sk > s0
        d = np.where(better[:, None], cands[k, idx], d)
        s0 = np.where(better, sk, s0)
        r = np.where(better, r, 0.5 * r)
    out = P.copy()
    moved = nodes[remap[group] >= 0]
    out[moved] += d[node_group[moved]]
    return out
