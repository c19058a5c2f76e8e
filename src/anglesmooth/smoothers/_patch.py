"""Patch moves: the free nodes around the mesh's worst cells move together (issue 12).

The trap
    A per-node rule can be stuck where several nodes must move at once.  Paper-style mixed mesh,
    seed 0: the worst triangle (18.7 deg after 10 default passes) belongs to a valence-3 node inside
    a sliver triangle with two fixed boundary corners; that node alone can reach at most half of the
    sliver's smallest angle, and the sliver's third corner cannot open the sliver without closing
    its other cells (a 160 deg quad corner), and so on one ring further out.

The move
    After the per-class loop of a pass, the ``cells`` worst cells whose quality (triangle corners:
    the angle; quad corners: ``min(angle, 180 - angle)``) is below ``below`` degrees each give a
    patch: their free corners and the free nodes within ``rings`` edge rings of them (nodes of
    anisotropic input cells, which have input floors, and nodes whose input cells were all well
    shaped, ``floors.keep``, could be left out: ``BLOCK_FLOORED``, ``BLOCK_KEEP``, both off, see
    below).  The patch's nodes move together by an ascent of the
    patch's minimum corner quality over every cell incident to them: the direction is the
    min-norm element of the convex hull of the gradients of the corners within ``eps`` of the
    minimum (Freitag's steepest ascent of a max-min, here in 2 x nodes dimensions, its min-norm
    problem solved by Frank-Wolfe steps), the step the longest of 8 halvings that raises the
    minimum with every cell valid (positive area, convex quads) and every cell area inside the
    band of :func:`._local.optimize`, every input floor of the moving nodes' incidence rows kept
    (:mod:`._floors`), (at least ``area_band`` of the smallest, at most ``1 /
    area_band`` of the largest start area of the patch, and within the mesh's area range
    ``area_limits``, unless already outside).  A patch that shares a cell with an earlier
    (worse) one is skipped, so every patch's score is exact.  The patch's minimum never decreases.
    Pure numpy on a few dozen nodes after the pass, so the same for the numpy and compiled kernels;
    only the screen that finds the cells below ``below`` (:func:`_maybe_below`, a superset; the exact
    quality of the cells it keeps decides) is compiled where the mesh runs on the compiled kernels.

Measured (issue 12; paper-style meshes, 10 default passes, seeds 0 / 1 / 2, minimum angle)
    The prototype, run only after the 10 passes (5 rounds of the 8 worst cells): paper-style mixed
    18.73 / 25.06 / 23.51 -> 20.75 / 29.40 / 29.31 with one ring, 20.71 / 29.59 / 29.35 with two;
    seed 0 with three or five rings 20.73 / 20.72, and without area band or limits the same 20.72:
    the sliver's patch ends balanced (four cells at 20.72 deg), a local max-min optimum of that
    topology.  Leaving out nodes with an input floor (the paper-style meshes' input slivers are
    anisotropic, so the trapped node was one of them): no gain at all (22.54 mean); with the floors
    kept exactly instead (areas then from corner cross products, Frank-Wolfe ties by argmin): mixed
    20.29 / 28.21 / 28.12 (mean 25.54), triangles 26.13 / 28.46 / 25.47 (26.69, was 24.83); as
    committed (shoelace areas and a round-off-proof tie rule, so that the reference agrees): mixed
    20.29 / 28.56 / 26.97 (25.27), triangles 26.78 / 28.06 / 25.52 (26.79), with 30 ascent steps a pass;
    the default is 15 (``angle.step``'s ``patch_iterations``): mixed 20.47 / 27.69 / 27.87 (25.34),
    triangles 27.29 / 29.22 / 25.59 (27.37), at 0.6x the time.  See ``angle.py``.
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology
from ._floors import Floors
from . import _fast

__all__ = ["patch_moves"]

#: Leave out of the patches the nodes of well-shaped input cells / of anisotropic input cells (floored):
#: measured off (see the module docstring; the floors are kept exactly instead).
BLOCK_KEEP = False
BLOCK_FLOORED = False
_GAIN = 1e-10  # radians
_TIE = 1e-9
_GAP = 0.0  # relative Frank-Wolfe gap at which the min-norm search stops (1e-3: paper-style mixed 25.54 -> 24.83 deg)
_EPS_MIN = 1e-4  # radians: the active-set tolerance halves down to this, then the ascent stops


def _csr(topo: Topology, nodes: np.ndarray) -> np.ndarray:
    """Ids of the cells of the free ``nodes`` (triangles, then quads from nt; a shared cell repeated).

    The incidence rows of a free node are one slice of ``topo.tri_loc`` / ``topo.quad_loc`` (found by
    binary search), and ``topo.tri_cell`` / ``topo.quad_cell`` give their cells: no node -> cell table
    of the whole mesh (at 1M triangles it took 0.4 s and 30 MB kept, 70 MB while sorted).
    """
    loc = _loc_of(topo)[nodes]
    out = []
    for table, cell, shift in ((topo.tri_loc, topo.tri_cell, 0), (topo.quad_loc, topo.quad_cell, topo.n_tri)):
        lc = loc.astype(table.dtype)  # the needles in the table's own type (no conversion of the table)
        lo = np.searchsorted(table, lc, "left")
        n = np.searchsorted(table, lc, "right") - lo
        rows = np.repeat(lo - (np.cumsum(n) - n), n) + np.arange(int(n.sum()))
        out.append(cell[rows].astype(np.intp) + shift)
    return np.concatenate(out)


def _loc_of(topo: Topology) -> np.ndarray:
    """(N,) position of every free node in ``topo.free_nodes`` (garbage at fixed nodes); cached."""
    key = ("patch-loc-of",)
    hit = topo._cache.get(key)
    if hit is None:
        hit = np.zeros(topo.n_points, np.intp)
        hit[topo.free_nodes] = np.arange(topo.n_free)
        topo._cache[key] = hit
    return hit


def cell_quality(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Per cell (m, k), the smallest corner quality in radians (quads: ``min(a, pi - a)``); -1 if invalid."""
    p = points[cells]
    u = np.roll(p, -1, axis=1) - p
    w = np.roll(p, 1, axis=1) - p
    cr = u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]
    th = np.arctan2(cr, u[..., 0] * w[..., 0] + u[..., 1] * w[..., 1])
    if cells.shape[1] == 4:
        th = np.minimum(th, np.pi - th)
    return np.where((cr > 0).all(axis=1), th.min(axis=1), -1.0)


def _maybe_below(points: np.ndarray, cells: np.ndarray, below: float, fast: bool = False) -> np.ndarray:
    """Ids (ascending) of a superset of the cells whose :func:`cell_quality` is below ``below`` degrees.

    A corner of angle a in (0, 180) has min(a, 180 - a) < b exactly when its cross product is below
    tan(b) times the absolute dot product; the test is padded so that round-off never drops a cell
    (the exact quality then decides), and an invalid corner (cross <= 0) always counts.  Sqrt- and
    arctan-free, on a few columns at a time.
    """
    m, k = cells.shape
    if m == 0 or below <= 0.0:
        return np.zeros(0, np.intp)
    if below >= 89.0:  # (almost) every cell: no screen
        return np.arange(m)
    t = np.tan(np.radians(below)) * (1.0 + 1e-6)
    if fast:  # the same test, compiled (``fast``: the mesh runs on the compiled kernels)
        from ._patchkernels import maybe_below

        return np.flatnonzero(maybe_below(np.ascontiguousarray(points[:, :2]), cells, t))
    x, y = points[:, 0], points[:, 1]
    hit = np.zeros(m, bool)
    for c in range(k):
        a, b, d = cells[:, c], cells[:, (c + 1) % k], cells[:, (c - 1) % k]
        ux, uy = x[b] - x[a], y[b] - y[a]
        wx, wy = x[d] - x[a], y[d] - y[a]
        cr = ux * wy - uy * wx
        dot = np.abs(ux * wx + uy * wy)
        dot *= t
        dot += 1e-300
        hit |= cr < dot
    return np.flatnonzero(hit)


def _blocked(topo: Topology, floors: Floors | None) -> np.ndarray:
    """(N,) bool: nodes a patch may not move (fixed, floored or well-shaped input); cached per floors."""
    key = ("patch-blocked", id(floors))
    hit = topo._cache.get(key)
    if hit is None or hit[0] is not floors:
        out = np.asarray(topo.fixed, bool).copy()
        if floors is not None:
            fn = topo.free_nodes
            if BLOCK_KEEP:
                out[fn[floors.keep]] = True
            if floors.active and BLOCK_FLOORED:
                for loc, area in ((topo.tri_loc, floors.t_area2), (topo.quad_loc, floors.q_area2)):
                    out[fn[np.unique(loc[area > 0])]] = True
        hit = topo._cache[key] = (floors, out)
    return hit[1]


def _area2(c):
    """Twice the signed area of cells with corners c (..., k, 2): triangles by an edge cross product,
    quads by their diagonals (the reference's formulas)."""
    if c.shape[-2] == 3:
        return (c[..., 1, 0] - c[..., 0, 0]) * (c[..., 2, 1] - c[..., 0, 1]) - (c[..., 1, 1] - c[..., 0, 1]) * (
            c[..., 2, 0] - c[..., 0, 0])
    return (c[..., 2, 0] - c[..., 0, 0]) * (c[..., 3, 1] - c[..., 1, 1]) - (c[..., 2, 1] - c[..., 0, 1]) * (
        c[..., 3, 0] - c[..., 1, 0])


def _slots(nodes: np.ndarray):
    """A function giving, for an array of node ids, each one's position in ``nodes`` (unique), -1 if absent."""
    order = np.argsort(nodes, kind="stable")
    ranked = nodes[order]

    def slot(a):
        a = np.asarray(a)
        pos = np.minimum(np.searchsorted(ranked, a), max(ranked.shape[0] - 1, 0))
        return np.where(ranked[pos] == a, order[pos], -1) if ranked.size else np.full(a.shape, -1)

    return slot


class _Patch:
    """One patch: its moving nodes and the corners of every cell incident to them."""

    def __init__(self, points, topo, nodes, cell_ids, floors=None):
        nt = topo.n_tri
        self.nodes = nodes
        tri = topo.tri[cell_ids[cell_ids < nt]]
        quad = topo.quad[cell_ids[cell_ids >= nt] - nt]
        slot = _slots(nodes)
        cv, cn, cp, sq = [], [], [], []
        for cells in (tri, quad):
            k = cells.shape[1]
            for m in range(k):
                cv.append(cells[:, m])
                cn.append(cells[:, (m + 1) % k])
                cp.append(cells[:, m - 1])
                sq.append(np.full(cells.shape[0], k == 4))
        self.cv, self.cn, self.cp = (np.concatenate(a) for a in (cv, cn, cp))
        self.quad = np.concatenate(sq)
        self.P = points
        self.cells = [(c, slot(c))
                      for c in (tri, quad) if c.shape[0]]
        self.s = [slot(a) for a in (self.cv, self.cn, self.cp)]
        # the input floors of the moving nodes' incidence rows (node first, ccw): twice the area and
        # the two edges at the node may not go below them (see _floors.input_floors)
        self.floor_rows = []
        if floors is not None and floors.active:
            locs = _loc_of(topo)[nodes]
            for table, verts, fa, f1, f2 in ((topo.tri_loc, topo.tri_verts, floors.t_area2, floors.t_e1, floors.t_e2),
                                             (topo.quad_loc, topo.quad_verts, floors.q_area2, floors.q_e1, floors.q_e3)):
                # the needles in the table's own type: otherwise numpy converts the whole table on every call
                lc = locs.astype(table.dtype)
                lo, hi = np.searchsorted(table, lc, "left"), np.searchsorted(table, lc, "right")
                rows = np.concatenate([np.arange(a, b) for a, b in zip(lo.tolist(), hi.tolist())]
                                      + [np.zeros(0, np.intp)])
                rows = rows[fa[rows] > 0]
                if rows.size:
                    vv = verts[rows]
                    sl = slot(vv)
                    self.floor_rows.append((vv, sl, fa[rows], f1[rows], f2[rows]))

    def floors_ok(self, X):
        """(K,) bool: every floored row of the moving nodes keeps its floors at positions X (K, n, 2)."""
        ok = np.ones(X.shape[0], bool)
        for vv, sl, fa, f1, f2 in self.floor_rows:
            c = self._cell_xy(X, vv, sl)
            a2 = _area2(c)
            e1 = np.hypot(*(c[..., 1, :] - c[..., 0, :]).transpose(2, 0, 1))
            e2 = np.hypot(*(c[..., -1, :] - c[..., 0, :]).transpose(2, 0, 1))
            ok &= ((a2 >= fa) & (e1 >= f1) & (e2 >= f2)).all(axis=1)
        return ok

    def _xy(self, X, which):
        """Coordinates (K, C, 2) of corner role ``which`` (0: vertex, 1: next, 2: previous)."""
        ids, s = (self.cv, self.cn, self.cp)[which], self.s[which]
        out = np.broadcast_to(self.P[ids], (X.shape[0],) + ids.shape + (2,)).copy()
        m = s >= 0
        out[:, m] = X[:, s[m]]
        return out

    def corners(self, X):
        """(quality (K, C), cross products (K, C), u, w) at the moving nodes' positions X (K, n, 2)."""
        v = self._xy(X, 0)
        u = self._xy(X, 1) - v
        w = self._xy(X, 2) - v
        cr = u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]
        th = np.arctan2(cr, u[..., 0] * w[..., 0] + u[..., 1] * w[..., 1])
        return np.where(self.quad, np.minimum(th, np.pi - th), th), th, cr, u, w

    def _cell_xy(self, X, vv, sl):
        c = np.broadcast_to(self.P[vv], (X.shape[0],) + vv.shape + (2,)).copy()
        m = sl >= 0
        c[:, m] = X[:, sl[m]]
        return c

    def areas(self, X):
        """(K, cells) signed areas (the shoelace of :func:`..topology.signed_areas`) at positions X."""
        out = []
        for vv, sl in self.cells:
            out.append(0.5 * _area2(self._cell_xy(X, vv, sl)))
        return np.concatenate(out, axis=1)

    def gradients(self, sel, th, u, w):
        """(c, n, 2): gradient of the quality of the corners ``sel`` (at angles th, edges u, w) with
        respect to the moving nodes."""
        n = self.nodes.shape[0]
        sgn = np.where(self.quad[sel] & (th > np.pi / 2), -1.0, 1.0)[:, None]
        gp = np.stack([-w[:, 1], w[:, 0]], 1) / (w * w).sum(1)[:, None] * sgn  # d angle / d previous
        gn = np.stack([u[:, 1], -u[:, 0]], 1) / (u * u).sum(1)[:, None] * sgn  # d angle / d next
        G = np.zeros((th.shape[0], n + 1, 2))  # slot n: the non-moving nodes (dropped)
        c = np.arange(th.shape[0])
        for g, s in ((gp, self.s[2][sel]), (gn, self.s[1][sel]), (-(gp + gn), self.s[0][sel])):
            np.add.at(G, (c, np.where(s >= 0, s, n)), g)
        return G[:, :n]


def _min_norm(G: np.ndarray, iterations: int = 50) -> np.ndarray:
    """The min-norm point of the convex hull of the rows of G (a, d), by Frank-Wolfe steps."""
    a = G.shape[0]
    M = G @ G.T
    lam = np.full(a, 1.0 / a)
    for _ in range(iterations):
        g = M @ lam
        if float(lam @ g) - float(g.min()) <= _GAP * float(lam @ g):  # Frank-Wolfe gap: near enough
            break
        j = int(np.flatnonzero(g <= g.min() + _TIE * np.abs(g).max())[0])  # ties: the first, whatever the round-off
        d = -lam
        d[j] += 1.0
        den = float(d @ M @ d)
        if den <= 0.0:
            break
        t = min(1.0, max(0.0, -float(lam @ M @ d) / den))
        if t == 0.0:
            break
        lam = lam + t * d
    return lam @ G


def _ascend(patch: _Patch, X, iterations, eps, area_band, area_limits):
    """The patch's nodes after ``iterations`` ascent steps (see the module docstring)."""
    q, th, cr, u, w = patch.corners(X[None])
    ar = patch.areas(X[None])[0]
    lo0, hi0 = float(ar.min()), float(ar.max())
    lo, hi = -np.inf, np.inf
    if area_band is not None:
        lo, hi = area_band * lo0, hi0 / area_band
        if area_limits is not None:
            lo, hi = max(lo, min(area_limits[0], lo0)), min(hi, max(area_limits[1], hi0))

    def score(Xs):
        q, th, cr, u, w = patch.corners(Xs)
        a = patch.areas(Xs)
        ok = (cr > 0).all(axis=1) & (a.min(axis=1) >= lo) & (a.max(axis=1) <= hi) & patch.floors_ok(Xs)
        return np.where(ok, q.min(axis=1), -np.inf)

    f0 = float(score(X[None])[0])
    if not np.isfinite(f0):
        return X, f0
    h = float(np.mean(np.sqrt((u[0] * u[0]).sum(1))))
    t = 0.1 * h
    halvings = 0.5 ** np.arange(8)
    for _ in range(iterations):
        q, th, cr, u, w = patch.corners(X[None])
        q, th = q[0], th[0]
        active = q <= q.min() + eps
        G = patch.gradients(active, th[active], u[0][active], w[0][active]).reshape(int(active.sum()), -1)
        d = _min_norm(G)
        nd = float(np.sqrt(d @ d))
        if nd < 1e-12:
            eps *= 0.5
            if eps < _EPS_MIN:
                break
            continue
        steps = t * halvings
        Xs = X[None] + steps[:, None, None] * (d / nd).reshape(-1, 2)[None]
        fs = score(Xs)
        k = np.flatnonzero(fs > f0 + _GAIN)  # a real gain: round-off never decides a step
        if k.size:
            X, f0, t = Xs[k[0]], float(fs[k[0]]), min(2.0 * steps[k[0]], 0.5 * h)
        else:
            eps *= 0.5
            t = float(steps[-1])
            if eps < _EPS_MIN:
                break
    return X, f0


def patch_moves(
    points: np.ndarray,
    topo: Topology,
    floors: Floors | None = None,
    *,
    below: float = 30.0,
    cells: int = 8,
    rings: int = 2,
    iterations: int = 30,
    eps: float = 2.0,
    area_band: float | None = 0.8,
    area_limits: tuple[float, float] | None = None,
) -> np.ndarray:
    """The points with the patches of the worst cells moved (see the module docstring)."""
    P = np.asarray(points, dtype=np.float64)
    nt = topo.n_tri
    blocked = _blocked(topo, floors)
    allc = [topo.tri, topo.quad]
    # the exact quality (arctan2) only of the cells a cheap test cannot clear (1M triangles: the
    # exact quality of every cell was most of a pass); the same cells, values and order as from all
    fast = _fast.active(topo)
    cand = np.concatenate([_maybe_below(P, topo.tri, below, fast), nt + _maybe_below(P, topo.quad, below, fast)])
    qual = np.concatenate([cell_quality(P, topo.tri[cand[cand < nt]]), cell_quality(P, topo.quad[cand[cand >= nt] - nt])])
    keep = qual < np.radians(below)
    cand, qual = cand[keep], qual[keep]
    if not cand.size:
        return P
    cand = cand[np.argsort(qual, kind="stable")]
    used_cells = np.zeros(nt + topo.n_quad, bool)
    out = P.copy()
    done = 0
    for c in cand:  # at most a few dozen candidates, at most ``cells`` patches
        if done >= cells:
            break
        verts = allc[0][c] if c < nt else allc[1][c - nt]
        nodes = verts[~blocked[verts]]
        if not nodes.size:
            continue
        for _ in range(rings):
            nb = np.concatenate([topo.ring_indices[topo.ring_offsets[v]:topo.ring_offsets[v + 1]] for v in nodes])
            nodes = np.union1d(nodes, nb[~blocked[nb]])
        ids = np.unique(_csr(topo, nodes))
        done += 1
        if used_cells[ids].any():
            continue
        used_cells[ids] = True
        patch = _Patch(out, topo, nodes, ids, floors)
        X, _ = _ascend(patch, out[nodes], iterations, np.radians(eps), area_band, area_limits)
        out[nodes] = X
    return out
