"""Vectorized per-block kernels shared by all smoothers.

A *block* is a set of free nodes that share no cell (one colour class), so
while its nodes move every incident cell has exactly one moving node and the
quality of each node's cells can be evaluated exactly and independently.

Local score
    For a node at a candidate position, the score is the minimum over the
    corners of its incident cells of ``-cos(angle)`` for triangle corners and
    ``-|cos(angle)|`` for quad corners: monotone in the angle for triangles (the
    best score is the best minimum angle; the largest angle of a triangle is
    bounded by its smallest) and in ``min(angle, 180 - angle)`` for quads, whose
    large angles are not bounded by their small ones (measured on paper-style
    tri-quad meshes, a min-angle-only score leaves quad angles of 179 deg).
    No ``acos`` is needed.  A cell
    whose corner has a cross product <= 0 (inverted, degenerate, or a
    non-convex quad) is *invalid*; a position with ``k`` invalid incident
    cells scores ``-3 - k``, below every valid position, and fewer invalid cells
    score higher (which is what lets guarded smoothing untangle a little and
    never tangle more).
"""

from __future__ import annotations

import numpy as np

from ..topology import Block, Topology

INVALID = -3.0


def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1])


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1]


class BlockGeometry:
    """The fixed part of a block's incident cells, gathered once per block update.

    Parameters
    ----------
    points : (N, 2) current coordinates (the block's own nodes are ignored)
    topo, blk : the topology and one of its blocks
    subset : optional int array of block-local node indices to restrict to
    """

    def __init__(self, points: np.ndarray, topo: Topology, blk: Block, subset: np.ndarray | None = None):
        a = blk.nodes.start
        n = blk.size
        t_rel = topo.tri_loc[blk.tris] - a
        t_v = topo.tri_verts[blk.tris]
        q_rel = topo.quad_loc[blk.quads] - a
        q_v = topo.quad_verts[blk.quads]
        if subset is not None:
            remap = np.full(n, -1, np.int64)
            remap[subset] = np.arange(subset.shape[0])
            keep = remap[t_rel] >= 0
            t_rel, t_v = remap[t_rel[keep]], t_v[keep]
            keep = remap[q_rel] >= 0
            q_rel, q_v = remap[q_rel[keep]], q_v[keep]
            n = subset.shape[0]
            self.t_starts, self.t_has = _starts(t_rel, n)
            self.q_starts, self.q_has = _starts(q_rel, n)
        else:
            self.t_starts, self.t_has = blk.tri_starts, blk.tri_has
            self.q_starts, self.q_has = blk.quad_starts, blk.quad_has
        self.n = n
        self.t_rel, self.q_rel = t_rel, q_rel
        # triangles (p0 moving, p1, p2 fixed)
        self.t_p1 = points[t_v[:, 1]]
        self.t_p2 = points[t_v[:, 2]]
        e12 = self.t_p2 - self.t_p1
        self.t_e12 = e12
        self.t_l12 = _norm(e12)
        # quads (p0 moving; p1, p2, p3 fixed); corner 2 does not depend on p0
        self.q_p1 = points[q_v[:, 1]]
        self.q_p3 = points[q_v[:, 3]]
        p2 = points[q_v[:, 2]]
        self.q_e12 = p2 - self.q_p1
        self.q_e23 = self.q_p3 - p2
        self.q_l12 = _norm(self.q_e12)
        self.q_l23 = _norm(self.q_e23)
        c2 = _cross(self.q_e23, -self.q_e12)
        with np.errstate(divide="ignore", invalid="ignore"):
            cos2 = _dot(self.q_e23, -self.q_e12) / (self.q_l23 * self.q_l12)
        self.q_ok2 = (c2 > 0) & np.isfinite(cos2)
        self.q_cos2 = np.where(self.q_ok2, np.abs(cos2), 1.0)

    def score(self, X: np.ndarray) -> np.ndarray:
        """Local score of every node at candidate positions ``X`` (..., n, 2) -> (..., n)."""
        lead = X.shape[:-2]
        best = np.full(lead + (self.n,), np.inf)
        bad = np.zeros(lead + (self.n,))
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.t_rel.shape[0]:
                p0 = X[..., self.t_rel, :]
                e1 = self.t_p1 - p0
                e2 = self.t_p2 - p0
                l1, l2 = _norm(e1), _norm(e2)
                c = _cross(e1, e2)
                cmax = np.maximum(
                    _dot(e1, e2) / (l1 * l2),
                    np.maximum(-_dot(self.t_e12, e1) / (self.t_l12 * l1), _dot(e2, self.t_e12) / (l2 * self.t_l12)),
                )
                ok = (c > 0) & np.isfinite(cmax)
                self._reduce(best, bad, np.where(ok, -cmax, np.inf), ~ok, self.t_rel, self.t_starts, self.t_has)
            if self.q_rel.shape[0]:
                p0 = X[..., self.q_rel, :]
                e1 = self.q_p1 - p0
                e3 = self.q_p3 - p0
                l1, l3 = _norm(e1), _norm(e3)
                c0 = _cross(e1, e3)
                c1 = _cross(self.q_e12, -e1)
                c3 = _cross(e3, self.q_e23)
                cmax = np.maximum(
                    np.maximum(np.abs(_dot(e1, e3) / (l1 * l3)), np.abs(_dot(self.q_e12, e1) / (self.q_l12 * l1))),
                    np.maximum(np.abs(_dot(e3, self.q_e23) / (l3 * self.q_l23)), self.q_cos2),
                )
                ok = (c0 > 0) & (c1 > 0) & (c3 > 0) & self.q_ok2 & np.isfinite(cmax)
                self._reduce(best, bad, np.where(ok, -cmax, np.inf), ~ok, self.q_rel, self.q_starts, self.q_has)
        return np.where(bad > 0, INVALID - bad, best)

    def area_range(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Smallest and largest signed area of each node's incident cells at positions ``X`` (..., n, 2)."""
        lead = X.shape[:-2]
        lo = np.full(lead + (self.n,), np.inf)
        hi = np.full(lead + (self.n,), -np.inf)
        for rel, starts, has, area in self._areas(X):
            if starts.shape[0]:
                lo[..., has] = np.minimum(lo[..., has], np.minimum.reduceat(area, starts, axis=-1))
                hi[..., has] = np.maximum(hi[..., has], np.maximum.reduceat(area, starts, axis=-1))
        return lo, hi

    def _areas(self, X):
        if self.t_rel.shape[0]:
            p0 = X[..., self.t_rel, :]
            yield self.t_rel, self.t_starts, self.t_has, 0.5 * _cross(self.t_p1 - p0, self.t_p2 - p0)
        if self.q_rel.shape[0]:
            p0 = X[..., self.q_rel, :]
            p2 = self.q_p1 + self.q_e12
            yield self.q_rel, self.q_starts, self.q_has, 0.5 * _cross(p2 - p0, self.q_p3 - self.q_p1)

    def _reduce(self, best, bad, vals, invalid, rel, starts, has):
        if not starts.shape[0]:
            return
        best[..., has] = np.minimum(best[..., has], np.minimum.reduceat(vals, starts, axis=-1))
        bad[..., has] += np.add.reduceat(invalid.astype(np.float64), starts, axis=-1)


def _starts(rel: np.ndarray, n: int):
    starts = np.searchsorted(rel, np.arange(n))
    has = np.bincount(rel, minlength=n) > 0
    return starts[has], has


# --------------------------------------------------------------------------
# targets


def laplacian_target(points: np.ndarray, topo: Topology, blk: Block) -> np.ndarray:
    """Centroid of the edge neighbours of each block node, (n, 2)."""
    a = blk.nodes.start
    rel = topo.ring_loc[blk.ring] - a
    nb = points[topo.ring_nbr[blk.ring]]
    n = blk.size
    out = np.empty((n, 2))
    out[:, 0] = np.bincount(rel, weights=nb[:, 0], minlength=n)
    out[:, 1] = np.bincount(rel, weights=nb[:, 1], minlength=n)
    return out / blk.ring_count[:, None]


def angle_target(points: np.ndarray, topo: Topology, blk: Block) -> np.ndarray:
    """Zhou & Shimada's angle-based position of each block node, (n, 2).

    For every spoke (ring node j, with a and b the nodes beside the spoke when
    turning counter-clockwise about j) the node is put on the ray from j that
    splits the counter-clockwise angle a-j-b in the ratio ``frac : 1 - frac``,
    at its current distance from j; the result is the mean over all spokes.
    Equal splits use the exact bisector ``rot90(u_a - u_b)`` (no trigonometry);
    only unequal splits (quad beside triangle) use atan2/cos/sin.
    """
    a0 = blk.nodes.start
    sl = blk.spokes
    rel = topo.spoke_loc[sl] - a0
    centre = points[topo.free_nodes[topo.spoke_loc[sl]]]
    pj = points[topo.spoke_ring[sl]]
    ua = points[topo.spoke_a[sl]] - pj
    ub = points[topo.spoke_b[sl]] - pj
    with np.errstate(divide="ignore", invalid="ignore"):
        ua /= _norm(ua)[:, None]
        ub /= _norm(ub)[:, None]
        t = np.empty_like(ua)
        t[:, 0] = ub[:, 1] - ua[:, 1]
        t[:, 1] = ua[:, 0] - ub[:, 0]
        frac = topo.spoke_frac[sl]
        uneq = frac != 0.5
        if uneq.any():
            u, v = ua[uneq], ub[uneq]
            theta = np.arctan2(_cross(u, v), _dot(u, v))
            theta = np.where(theta <= 0, theta + 2 * np.pi, theta)
            phi = frac[uneq] * theta
            cs, sn = np.cos(phi), np.sin(phi)
            t[uneq, 0] = cs * u[:, 0] - sn * u[:, 1]
            t[uneq, 1] = sn * u[:, 0] + cs * u[:, 1]
        d = centre - pj
        t *= (_norm(d) / _norm(t))[:, None]
    # a degenerate spoke (zero-length ring edge) keeps its current position
    good = np.isfinite(t).all(axis=1)
    cand = np.where(good[:, None], pj + t, centre)
    n = blk.size
    out = np.empty((n, 2))
    out[:, 0] = np.bincount(rel, weights=cand[:, 0], minlength=n)
    out[:, 1] = np.bincount(rel, weights=cand[:, 1], minlength=n)
    return out / blk.spoke_count[:, None]


def local_scale(points: np.ndarray, topo: Topology, blk: Block) -> np.ndarray:
    """Mean length of the edges at each block node, (n,)."""
    a = blk.nodes.start
    rel = topo.ring_loc[blk.ring] - a
    c = points[topo.free_nodes[topo.ring_loc[blk.ring]]]
    ln = _norm(points[topo.ring_nbr[blk.ring]] - c)
    return np.bincount(rel, weights=ln, minlength=blk.size) / blk.ring_count


# --------------------------------------------------------------------------
# selection and local optimization


def pick_best(geom: BlockGeometry, cands: np.ndarray):
    """Choose, per node, the candidate with the best score (first one on ties).

    ``cands`` is (K, n, 2); returns (positions (n, 2), index (n,), score (n,)).
    """
    s = geom.score(cands)
    k = np.argmax(s, axis=0)
    idx = np.arange(cands.shape[1])
    return cands[k, idx], k, s[k, idx]


def first_valid(geom: BlockGeometry, current: np.ndarray, target: np.ndarray, halvings: int = 6):
    """Guard: the target, or the move halved until no incident cell becomes invalid.

    A node whose every shortened move is invalid stays (unless its current
    position is itself invalid and a move reduces the number of invalid cells).
    Returns (positions, rejected mask: True where the full move was refused).
    """
    fr = 0.5 ** np.arange(halvings + 1)
    cands = current[None] + fr[:, None, None] * (target - current)[None]
    cands = np.concatenate([cands, current[None]])
    s = geom.score(cands)
    valid = s > INVALID - 0.5
    # first valid fraction; where none is valid, the best (staying is a candidate,
    # so an already invalid neighbourhood never gets more invalid cells)
    k = np.where(valid.any(axis=0), np.argmax(valid, axis=0), np.argmax(s, axis=0))
    idx = np.arange(current.shape[0])
    return cands[k, idx], k != 0


def optimize(
    geom: BlockGeometry,
    x: np.ndarray,
    scale: np.ndarray,
    iterations: int = 3,
    radius: float = 0.25,
    area_band: float | None = None,
):
    """Local max-min-angle optimization by compass (pattern) search, vectorized over nodes.

    Each iteration tries the 8 points at distance ``r`` in the compass
    directions and moves to the best one if it raises the local score;
    otherwise ``r`` is halved.  ``r`` starts at ``radius * scale`` (scale: mean
    incident edge length).  Pattern search copes with the kinks of the
    non-smooth max-min objective where a (finite-difference) steepest ascent
    stalls: measured on the paper's triangle meshes, 10 passes reach a mean
    minimum angle of 25.0 deg against 18.5 deg for gradient ascent with a line
    search at a similar cost.

    With ``area_band`` (0 < band < 1), a step is only taken if the node's
    smallest incident cell keeps at least ``band`` times, and its largest at
    most ``1/band`` times, the area they had at the start: the angle alone
    would happily shrink a cell to a sliver of good shape.  Returns
    (positions, scores).
    """
    s0 = geom.score(x)
    if area_band is not None:
        lo0, hi0 = geom.area_range(x)
        lo0, hi0 = area_band * lo0, hi0 / area_band
    r = radius * scale
    idx = np.arange(x.shape[0])
    for _ in range(iterations):
        cands = x[None] + _COMPASS[:, None, :] * r[None, :, None]
        sc = geom.score(cands)
        if area_band is not None:
            lo, hi = geom.area_range(cands)
            sc = np.where((lo >= lo0) & (hi <= hi0), sc, -np.inf)
        k = np.argmax(sc, axis=0)
        sk = sc[k, idx]
        better = sk > s0
        x = np.where(better[:, None], cands[k, idx], x)
        s0 = np.where(better, sk, s0)
        r = np.where(better, r, 0.5 * r)
    return x, s0


_COMPASS = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)


def invalid_cells(points: np.ndarray, topo: Topology) -> np.ndarray:
    """Mask (n_tri + n_quad,) of cells with a corner cross product <= 0 (inverted, degenerate, non-convex)."""
    out = np.zeros(topo.n_tri + topo.n_quad, bool)
    if topo.n_tri:
        p = points[topo.tri]
        out[: topo.n_tri] = ~(_cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) > 0)
    if topo.n_quad:
        p = points[topo.quad]
        nxt = np.roll(p, -1, axis=1) - p
        prv = np.roll(p, 1, axis=1) - p
        out[topo.n_tri :] = ~(_cross(nxt, prv) > 0).all(axis=1)
    return out
