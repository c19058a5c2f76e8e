"""Untangling: moves for the nodes whose current neighbourhood is invalid (an inverted cell, a non-convex quad).

Why a stage of its own
    The local score of :mod:`._local` ranks a position with ``k`` invalid incident cells at
    ``-3 - k`` whatever the shape of the rest: inside the region of positions with the same number
    of invalid cells it is flat.  A compass search from an invalid position therefore takes no step
    (no neighbour point scores *higher*), halves its radius and stops where it started; a rule that
    takes a move only when it raises the score (smart Laplacian) stops just the same when the
    Laplacian position has as many invalid cells as the current one.  Measured on the distorted
    toothed quad meshes (``benchmarks/quality_matrix.py``): after 10 passes 7 (``optimization``) and
    19 (``smart-laplacian``) input quads were still non-convex, every one of which a single free
    corner could make convex, and the valid positions of that corner form a small convex region
    (often a sliver beside a fixed boundary corner) that the compass points (a quarter of an edge
    away) and the Laplacian position miss.

The kernel
    With the other nodes held, the positions of a node where all its incident cells are valid are
    the intersection of half-planes, one per linear condition: a triangle (x, a, b) needs x left of
    a->b; a quad (x, a, b, c) needs x left of a->c (its corner at x), of a->b (corner a) and of b->c
    (corner c); its corner b does not depend on x (a quad whose corner b is reflex is left out: no
    position of x repairs it).  The input floors' area conditions (:mod:`._floors`) are half-planes
    too (parallel to a->b and to the diagonal a->c); their edge-length conditions are not and are
    left to the exact score.  :func:`kernel_centroid` clips the ring's bounding box by these
    half-planes (Sutherland-Hodgman, vectorized over the nodes: one clip per half-plane index) and
    returns the centroid of what is left, a point strictly inside when the kernel has an area.

:func:`untangle` scores, for the given nodes, the Laplacian position, its halved moves, the
kernel's centroid, the midpoint of the centroid and the Laplacian position (plus any extra
candidates, e.g. the angle position) and the current position, and takes the best by the local score:
fewer inverted cells first, then fewer invalid cells, then the better minimum angle.  Staying is
one of the candidates, so a neighbourhood never gets more invalid cells.
"""

from __future__ import annotations

import numpy as np

from ..topology import Block, Topology
from ._floors import Floors
from ._local import INVALID, laplacian_target

__all__ = ["invalid_nodes", "kernel_centroid", "untangle"]


def invalid_nodes(scores: np.ndarray) -> np.ndarray:
    """Indices of the scores that mean "some incident cell is invalid"."""
    return np.flatnonzero(scores <= INVALID + 0.5)


def _halfplanes(
    points: np.ndarray, topo: Topology, blk: Block, subset: np.ndarray, floors: Floors | None, toward=None
):
    """Per node of ``subset`` (block-local indices) the half-planes ``n . x >= c`` of its kernel.

    With ``toward`` ((n, 2) points, a first kernel centroid), each edge-length floor (x at least r
    from a ring node p: the outside of a disc, not convex) becomes the half-plane beyond the disc's
    tangent facing ``toward``.  Returns (nx, ny, c) as (n, H) arrays, padded with ``0 . x >= -1``
    (always true).
    """
    n = subset.shape[0]
    a0 = blk.nodes.start
    remap = np.full(blk.size, -1, np.int64)
    remap[subset] = np.arange(n)
    owner, px, py, qx, qy, lim = [], [], [], [], [], []  # line p -> q, x must be left of it by lim (cross)
    downer, dcx, dcy, drad = [], [], [], []  # discs x must stay out of (edge floors)
    with_discs = toward is not None and floors is not None and floors.active

    def disc(rel, centre, radius):
        keep = (rel >= 0) & (radius > 0)
        downer.append(rel[keep])
        dcx.append(centre[keep, 0]), dcy.append(centre[keep, 1]), drad.append(radius[keep])

    def add(rel, p, q, floor=None):
        keep = rel >= 0
        owner.append(rel[keep])
        px.append(p[keep, 0]), py.append(p[keep, 1]), qx.append(q[keep, 0]), qy.append(q[keep, 1])
        lim.append(np.zeros(int(keep.sum())) if floor is None else floor[keep])

    if blk.tris.stop > blk.tris.start:
        rows = np.arange(blk.tris.start, blk.tris.stop)
        rel = remap[topo.tri_loc[rows] - a0]
        sel = rel >= 0
        rows, rel = rows[sel], rel[sel]
        v = topo.tri_verts[rows]
        pa, pb = points[v[:, 1]], points[v[:, 2]]
        fa = floors.t_area2[rows] if floors is not None and floors.active else None
        add(rel, pa, pb, fa)  # twice the area is cross(b - a, x - a)
        if with_discs:
            disc(rel, pa, floors.t_e1[rows])
            disc(rel, pb, floors.t_e2[rows])
    if blk.quads.stop > blk.quads.start:
        rows = np.arange(blk.quads.start, blk.quads.stop)
        rel = remap[topo.quad_loc[rows] - a0]
        sel = rel >= 0
        rows, rel = rows[sel], rel[sel]
        v = topo.quad_verts[rows]
        pa, pb, pc = points[v[:, 1]], points[v[:, 2]], points[v[:, 3]]
        # corner b (fixed by the others) must be convex, else no position of x repairs this quad
        ok_b = (pc[:, 0] - pb[:, 0]) * (pa[:, 1] - pb[:, 1]) - (pc[:, 1] - pb[:, 1]) * (pa[:, 0] - pb[:, 0]) > 0
        # twice the area: (b - x) x (c - a) = cross(c - a, x - a) + cross(b - a, c - a), so the area
        # floor fa is cross(c - a, x - a) >= fa - cross(b - a, c - a): a line parallel to a -> c
        d, e = pc - pa, pb - pa
        off = -(e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0])
        if floors is not None and floors.active:
            off = off + floors.q_area2[rows]
        # a quad whose corner b is reflex keeps only a positive area (an inverted cell weighs more)
        add(np.where(ok_b, -1, rel), pa, pc, off)
        rel = np.where(ok_b, rel, -1)
        add(rel, pa, pb)
        add(rel, pb, pc)
        add(rel, pa, pc, np.maximum(off, 0.0))
        if with_discs:
            disc(rel, pa, floors.q_e1[rows])
            disc(rel, pc, floors.q_e3[rows])
    owner = np.concatenate(owner) if owner else np.zeros(0, np.int64)
    px, py, qx, qy, lim = (np.concatenate(a) if a else np.zeros(0) for a in (px, py, qx, qy, lim))
    # cross(q - p, x - p) >= lim  <=>  (-(qy - py), qx - px) . x >= lim + (-(qy - py)) px + (qx - px) py
    nx, ny = -(qy - py), qx - px
    c = lim + nx * px + ny * py
    if with_discs and downer:
        do = np.concatenate(downer)
        cx, cy, rad = np.concatenate(dcx), np.concatenate(dcy), np.concatenate(drad)
        ux, uy = toward[do, 0] - cx, toward[do, 1] - cy
        ln = np.hypot(ux, uy)
        good = ln > 0
        ux, uy = np.where(good, ux / np.where(good, ln, 1), 0.0), np.where(good, uy / np.where(good, ln, 1), 0.0)
        # u . x >= u . centre + radius (a little beyond, so that the floor holds after rounding)
        owner = np.concatenate([owner, do])
        nx, ny = np.concatenate([nx, ux]), np.concatenate([ny, uy])
        c = np.concatenate([c, np.where(good, ux * cx + uy * cy + rad * (1 + 1e-9), -1.0)])
    order = np.argsort(owner, kind="stable")
    owner, nx, ny, c = owner[order], nx[order], ny[order], c[order]
    counts = np.bincount(owner, minlength=n)
    H = int(counts.max()) if n and owner.size else 0
    col = np.arange(owner.shape[0]) - np.repeat(np.cumsum(counts) - counts, counts)
    NX, NY, C = np.zeros((n, H)), np.zeros((n, H)), np.full((n, H), -1.0)
    NX[owner, col], NY[owner, col], C[owner, col] = nx, ny, c
    return NX, NY, C


def _clip(P: np.ndarray, cnt: np.ndarray, nx: np.ndarray, ny: np.ndarray, c: np.ndarray):
    """Clip the convex polygons ``P`` (n, M, 2; the first ``cnt`` vertices of each) by ``n . x >= c``."""
    n, M = P.shape[0], P.shape[1]
    idx = np.arange(M)
    live = idx[None, :] < cnt[:, None]
    nxt = np.where(idx[None, :] + 1 < cnt[:, None], idx[None, :] + 1, 0)
    rows = np.arange(n)[:, None]
    Q = P[rows, nxt]
    vi = P[..., 0] * nx[:, None] + P[..., 1] * ny[:, None] - c[:, None]
    vj = vi[rows, nxt]
    ini, inj = (vi >= 0) & live, (vj >= 0) & live
    cross = (ini != inj) & live
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(cross, vi / (vi - vj), 0.0)
    inter = P + t[..., None] * (Q - P)
    emit = ini.astype(np.int64) + cross
    off = np.cumsum(emit, axis=1) - emit
    out = np.zeros((n, M + 1, 2))
    r, k = np.nonzero(ini)
    out[r, off[r, k]] = P[r, k]
    r, k = np.nonzero(cross)
    out[r, off[r, k] + ini[r, k]] = inter[r, k]
    return out, emit.sum(axis=1)


def _centroid(P: np.ndarray, cnt: np.ndarray, box: np.ndarray, nodes_pos: np.ndarray):
    """Centroids of the polygons (shoelace, relative to the first vertex) and where they have an area."""
    n, M = P.shape[0], P.shape[1]
    idx = np.arange(M)
    live = idx[None, :] < cnt[:, None]
    nxt = np.where(idx[None, :] + 1 < cnt[:, None], idx[None, :] + 1, 0)
    R = P - P[:, :1]
    Rn = R[np.arange(n)[:, None], nxt]
    cr = np.where(live, R[..., 0] * Rn[..., 1] - R[..., 1] * Rn[..., 0], 0.0)
    area2 = cr.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cx = ((R[..., 0] + Rn[..., 0]) * cr).sum(axis=1) / (3 * area2)
        cy = ((R[..., 1] + Rn[..., 1]) * cr).sum(axis=1) / (3 * area2)
    ok = (cnt >= 3) & (area2 > 1e-12 * box * box) & np.isfinite(cx) & np.isfinite(cy)
    return np.where(ok[:, None], P[:, 0] + np.stack([cx, cy], axis=1), nodes_pos), ok


def kernel_centroid(
    points: np.ndarray, topo: Topology, blk: Block, subset: np.ndarray, floors: Floors | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Centroid of the kernel (see the module docstring) of each node of ``subset`` (block-local
    indices): ((n, 2) points, (n,) True where the kernel has a positive area).

    With edge-length floors, a second clip replaces each floor's disc by the half-plane beyond its
    tangent facing the first centroid (a convex part of the valid region).
    """
    n = subset.shape[0]
    nodes = topo.free_nodes[blk.nodes][subset]
    here = points[nodes]
    # start: the bounding box of the ring, slightly enlarged (the kernel lies inside the ring)
    ro = topo.ring_offsets
    starts, cnts = ro[nodes], ro[nodes + 1] - ro[nodes]
    owner = np.repeat(np.arange(n), cnts)
    nb = topo.ring_indices[np.repeat(starts - (np.cumsum(cnts) - cnts), cnts) + np.arange(int(cnts.sum()))]
    lo, hi = np.full((n, 2), np.inf), np.full((n, 2), -np.inf)
    np.minimum.at(lo, owner, points[nb])
    np.maximum.at(hi, owner, points[nb])
    pad = 0.05 * (hi - lo).max(axis=1, keepdims=True)
    lo, hi = lo - pad, hi + pad
    box = (hi - lo).max(axis=1)
    P0 = np.stack([lo, np.stack([hi[:, 0], lo[:, 1]], 1), hi, np.stack([lo[:, 0], hi[:, 1]], 1)], axis=1)

    def clip_all(planes):
        P, cnt = P0, np.full(n, 4, np.int64)
        NX, NY, C = planes
        for h in range(NX.shape[1]):
            P, cnt = _clip(P, cnt, NX[:, h], NY[:, h], C[:, h])
        return _centroid(P, cnt, box, here)

    cen, ok = clip_all(_halfplanes(points, topo, blk, subset, floors))
    if floors is not None and floors.active and ok.any():
        c2, ok2 = clip_all(_halfplanes(points, topo, blk, subset, floors, toward=cen))
        cen, ok = np.where(ok2[:, None], c2, cen), ok2 | ok
    return cen, ok


def untangle(
    geom,
    points: np.ndarray,
    topo: Topology,
    blk: Block,
    subset: np.ndarray,
    current: np.ndarray,
    floors: Floors | None = None,
    lap: np.ndarray | None = None,
    extra: tuple[np.ndarray, ...] = (),
) -> tuple[np.ndarray, np.ndarray]:
    """Best untangling move of the block nodes ``subset`` (whose current positions ``current`` are invalid).

    ``geom``: the block's geometry restricted to ``subset``; ``lap``: their Laplacian positions
    (computed if None); ``extra``: more candidates, (n, 2) each.  Candidates: the Laplacian position,
    its moves halved once and twice, the extra ones, the kernel's centroid K, (K + L) / 2, and the
    current position; the best local score wins (the first of equals).  Returns (positions, scores).
    """
    if lap is None:
        lap = laplacian_target(points, topo, blk)[subset]
    d = lap - current
    K, _ = kernel_centroid(points, topo, blk, subset, floors)
    cands = np.stack([lap, current + 0.5 * d, current + 0.25 * d, *extra, K, 0.5 * (K + lap), current])
    s = geom.score(cands)
    k = np.argmax(s, axis=0)
    i = np.arange(subset.shape[0])
    return cands[k, i], s[k, i]
