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
_WOLFE_TOL = 1e-12  # the min-norm point is found when no row is below it along itself by this x the largest |row|^2
_CHUNK = 1 << 15  # cells per chunk of the numpy screen (its temporaries stay in the caches)
_EPS_MIN = 1e-4  # radians: the active-set tolerance halves down to this, then the ascent stops


def _csr(topo: Topology):
    """(offsets, cell ids) of the cells of every node (tri ids first, quads after nt); cached."""
    key = ("patch-node-cells",)
    hit = topo._cache.get(key)
    if hit is None:
        nt = topo.n_tri
        nodes = np.concatenate([topo.tri.ravel(), topo.quad.ravel()]).astype(np.intp)
        ids = np.concatenate([np.repeat(np.arange(nt), 3), nt + np.repeat(np.arange(topo.n_quad), 4)])
        order = np.argsort(nodes, kind="stable")
        offs = np.zeros(topo.n_points + 1, np.intp)
        np.cumsum(np.bincount(nodes, minlength=topo.n_points), out=offs[1:])
        hit = topo._cache[key] = (offs, ids[order])
    return hit


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
    """Per cell (m, k), the smallest corner quality in radians (quads: ``min(a, pi - a)``); -1 if invalid.

    Corner c: the angle from u = p_{c+1} - p_c to w = p_{c-1} - p_c, ``arctan2(u x w, u . w)``.
    """
    m, k = cells.shape
    pts = np.asarray(points, dtype=np.float64)
    z = np.ascontiguousarray(pts[:, :2]).view(np.complex128).ravel()
    c = cells.T.astype(np.intp)
    zc = [z[c[i]] for i in range(k)]
    cr, dot = np.empty((k, m)), np.empty((k, m))
    for i in range(k):
        u, w = zc[(i + 1) % k] - zc[i], zc[i - 1] - zc[i]
        ux, uy, wx, wy = u.real, u.imag, w.real, w.imag
        np.subtract(ux * wy, uy * wx, out=cr[i])
        np.add(ux * wx, uy * wy, out=dot[i])
    th = np.arctan2(cr, dot)
    if k == 4:
        th = np.minimum(th, np.pi - th)
    return np.where((cr > 0).all(axis=0), th.min(axis=0), -1.0)


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
    # the edges e_c = p_{c+1} - p_c once (the corner's u is e_c, its w is -e_{c-1} exactly), so that
    # cross = uy ex - ux ey and |dot| = |ux ex + uy ey| with e = e_{c-1}: the same bits as from u and w
    z = np.ascontiguousarray(points[:, :2], dtype=np.float64).view(np.complex128).ravel()
    hit = np.zeros(m, bool)
    for s0 in range(0, m, _CHUNK):
        c = cells[s0:s0 + _CHUNK].T.astype(np.intp)
        zc = [z[c[i]] for i in range(k)]
        e = [zc[(i + 1) % k] - zc[i] for i in range(k)]
        ex, ey = [x.real.copy() for x in e], [x.imag.copy() for x in e]
        h = hit[s0:s0 + _CHUNK]
        for i in range(k):
            cr = ey[i] * ex[i - 1]
            cr -= ex[i] * ey[i - 1]
            dot = ex[i] * ex[i - 1]
            dot += ey[i] * ey[i - 1]
            np.abs(dot, out=dot)
            dot *= t
            dot += 1e-300
            h |= cr < dot
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


class _Patch:
    """One patch: its moving nodes and the corners of every cell incident to them, as local indices.

    The local nodes are the ``n`` moving nodes (slots 0..n-1, the order of ``nodes``) then the other
    corners of the patch's cells (their positions ``ext`` never change), so that every evaluation is
    a gather from one (K, n + m, 2) array.  The corners are the triangles' corners 0, 1, 2 then the
    quads' 0..3 (corner 0 of triangle i is corner i: its cross product is twice the triangle's area,
    the same operations as :func:`_area2`); an input floor row (a moving node's rotated cell) is the
    corner at that node: its area is the corner's cross product (triangles) or the quad's (the
    diagonal formula gives the same bits in every rotation), its edges the corner's u and w.
    """

    def __init__(self, points, topo, nodes, cell_ids, floors=None):
        nt = topo.n_tri
        self.nodes = nodes
        n = nodes.shape[0]
        tri = topo.tri[cell_ids[cell_ids < nt]]
        quad = topo.quad[cell_ids[cell_ids >= nt] - nt]
        allv = np.concatenate([tri.ravel(), quad.ravel()]).astype(np.intp)
        ext = np.setdiff1d(allv, nodes)
        local = np.concatenate([nodes, ext])
        order = np.argsort(local, kind="stable")
        ranked = local[order]

        def slot(a):
            return order[np.searchsorted(ranked, a)]

        cv, cn, cp = [], [], []
        for cells in (tri, quad):
            k = cells.shape[1]
            for m in range(k):
                cv.append(cells[:, m])
                cn.append(cells[:, (m + 1) % k])
                cp.append(cells[:, m - 1])
        self.lv, self.ln, self.lp = (slot(np.concatenate(a).astype(np.intp)) for a in (cv, cn, cp))
        self.l3 = np.stack([self.lp, self.ln, self.lv], axis=1)
        self.n, self.ntri, self.nq = n, tri.shape[0], quad.shape[0]
        self.quad = np.arange(self.lv.shape[0]) >= 3 * self.ntri
        self.any_quad = bool(self.nq)
        self.lq = slot(quad.astype(np.intp)) if self.nq else None
        self.ext = np.asarray(points, np.float64)[ext]
        # the input floors of the moving nodes' incidence rows (node first, ccw): twice the area and
        # the two edges at the node may not go below them (see _floors.input_floors)
        self.floor = None
        if floors is not None and floors.active:
            L = local.shape[0]
            key = (self.lv * L + self.ln) * L + self.lp
            korder = np.argsort(key, kind="stable")
            fc, fq, fa, f1, f2 = [], [], [], [], []
            locs = _loc_of(topo)[nodes]
            for table, verts, ta, t1, t2 in ((topo.tri_loc, topo.tri_verts, floors.t_area2, floors.t_e1, floors.t_e2),
                                             (topo.quad_loc, topo.quad_verts, floors.q_area2, floors.q_e1, floors.q_e3)):
                # the needles in the table's own type: otherwise numpy converts the whole table on every call
                lc = locs.astype(table.dtype)
                lo, hi = np.searchsorted(table, lc, "left"), np.searchsorted(table, lc, "right")
                rows = np.concatenate([np.arange(a, b) for a, b in zip(lo.tolist(), hi.tolist())]
                                      + [np.zeros(0, np.intp)])
                rows = rows[ta[rows] > 0]
                if rows.size:
                    vv = slot(verts[rows].astype(np.intp))
                    want = (vv[:, 0] * L + vv[:, 1]) * L + vv[:, -1]
                    c = korder[np.searchsorted(key, want, sorter=korder)]
                    fc.append(c)
                    fq.append(c >= 3 * self.ntri)
                    fa.append(ta[rows]), f1.append(t1[rows]), f2.append(t2[rows])
            if fc:
                fc, fq = np.concatenate(fc), np.concatenate(fq)
                # a quad corner's cell: the quads' corner m of quad j is 3 ntri + m nq + j
                qc = (fc - 3 * self.ntri) % max(self.nq, 1)
                self.floor = (fc, fq, np.where(fq, qc, 0), np.concatenate(fa), np.concatenate(f1), np.concatenate(f2))

    def positions(self, X):
        """(K, n + m, 2) local positions: the moving nodes at X (K, n, 2), the others where they are."""
        Y = np.empty((X.shape[0], X.shape[1] + self.ext.shape[0], 2))
        Y[:, : self.n] = X
        Y[:, self.n:] = self.ext
        return Y

    def corners(self, Y):
        """(quality, angle, cross product, u, w) of every corner (K, C) at local positions Y."""
        v = Y[:, self.lv]
        u = Y[:, self.ln] - v
        w = Y[:, self.lp] - v
        cr = u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]
        th = np.arctan2(cr, u[..., 0] * w[..., 0] + u[..., 1] * w[..., 1])
        q = np.where(self.quad, np.minimum(th, np.pi - th), th) if self.any_quad else th
        return q, th, cr, u, w

    def score(self, Y, lo, hi):
        """(K,) the minimum corner quality at Y, -inf where a cell is invalid or a limit broken; and the corners."""
        q, th, cr, u, w = cs = self.corners(Y)
        tri2 = cr[:, : self.ntri]
        ok = (cr > 0).all(axis=1)
        if self.any_quad:
            q2 = _area2(Y[:, self.lq])
            a = np.concatenate([0.5 * tri2, 0.5 * q2], axis=1)
        else:
            a = 0.5 * tri2
        ok &= (a.min(axis=1) >= lo) & (a.max(axis=1) <= hi)
        if self.floor is not None:
            fc, fq, qc, fa, f1, f2 = self.floor
            a2 = cr[:, fc]
            if self.any_quad:
                a2 = np.where(fq, q2[:, qc], a2)
            e1 = np.hypot(u[:, fc, 0], u[:, fc, 1])
            e2 = np.hypot(w[:, fc, 0], w[:, fc, 1])
            ok &= ((a2 >= fa) & (e1 >= f1) & (e2 >= f2)).all(axis=1)
        return np.where(ok, q.min(axis=1), -np.inf), cs

    def gradients(self, sel, th, u, w):
        """(c, n, 2): gradient of the quality of the corners ``sel`` (indices; at angles th, edges u,
        w) with respect to the moving nodes."""
        a = sel.shape[0]
        g = np.empty((a, 3, 2))  # d angle / d previous, next, vertex
        g[:, 0, 0] = -w[:, 1]
        g[:, 0, 1] = w[:, 0]
        g[:, 1, 0] = u[:, 1]
        g[:, 1, 1] = -u[:, 0]
        g[:, 0] /= (w * w).sum(1)[:, None]
        g[:, 1] /= (u * u).sum(1)[:, None]
        if self.any_quad:
            g[:, :2] *= np.where(self.quad[sel] & (th > np.pi / 2), -1.0, 1.0)[:, None, None]
        np.add(g[:, 0], g[:, 1], out=g[:, 2])
        np.negative(g[:, 2], out=g[:, 2])
        G = np.zeros((a, self.ext.shape[0] + self.n, 2))  # slots n..: the non-moving nodes (dropped)
        # a corner's three nodes are distinct: one value per entry, as np.add.at would sum it
        G[np.arange(a)[:, None], self.l3[sel]] = g
        return G[:, : self.n]


try:  # np.linalg.solve's own kernel without its wrapper (a third of a small solve's time); NaN if singular
    from numpy.linalg._umath_linalg import solve1 as _solve1

    _solve = _solve1
except ImportError:  # pragma: no cover - another numpy layout
    def _solve(A, b):
        try:
            return np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            return np.full(b.shape, np.nan)


def _min_norm(G: np.ndarray, start=()) -> tuple[np.ndarray, list]:
    """The min-norm point of the convex hull of the rows of G (a, d), exactly: Wolfe's algorithm.

    A corral S of rows (affinely independent) holds the current point x = lam @ G[S] (lam > 0,
    sum 1); a major cycle adds the row j that is most negative along x (x . G[j] < x . x, by more
    than :data:`_WOLFE_TOL` times the largest squared row norm: otherwise x is the min-norm point)
    and moves to the affine minimizer of the corral, a minor cycle drops the rows whose weight that
    move would make non-positive (the segment stops where the first one reaches 0).  Everything on
    the Gram matrix M = G G^T; the affine minimizer solves [[M_SS, 1], [1^T, 0]] [mu, nu] = [0, 1].
    Ties by the first index.  ``start``: rows to start from (the corral of the previous ascent step,
    where they are still active), when their affine minimizer is inside their hull; else the
    shortest row.  The min-norm point is unique, so the start only changes the round-off.
    Returns the point and its corral.
    """
    a = G.shape[0]
    if a == 1:
        return G[0].copy(), [0]
    with np.errstate(all="ignore"):  # a singular corral system: NaN, handled below
        return _wolfe(G, a, list(start))


def _wolfe(G, a, S):
    M = G @ G.T
    B = np.ones((a + 1, a + 1))  # M bordered by ones: the corral's affine system is a submatrix
    B[:a, :a] = M
    B[a, a] = 0.0
    rhs = np.zeros(a + 1)
    rhs[-1] = 1.0
    dg = np.diag(M)
    tol = _WOLFE_TOL * float(dg.max())
    mu = None
    if len(S) > 1:
        ix = S + [a]
        mu = _solve(B.take(ix, 0).take(ix, 1), rhs[-len(S) - 1:])[:-1]
    if mu is not None and np.isfinite(mu).all() and (mu > 0.0).all():
        lam = mu
    else:
        S = [int(np.argmin(dg))]
        lam = np.ones(1)
    for _ in range(4 * a + 8):
        g = M.take(S, 1) @ lam
        j = int(np.argmin(g))
        if float(lam @ g[S]) - float(g[j]) <= tol or j in S:
            break
        S.append(j)
        lam = np.append(lam, 0.0)
        for _ in range(len(S)):  # minor cycles: at most one row dropped each
            s = len(S)
            ix = S + [a]
            mu = _solve(B.take(ix, 0).take(ix, 1), rhs[-s - 1:])[:s]
            if not np.isfinite(mu).all():  # singular (round-off): stop where we are
                return lam @ G[S], S
            if (mu > 0.0).all():
                lam = mu
                break
            neg = np.flatnonzero(mu <= 0.0)
            r = lam[neg] / (lam[neg] - mu[neg])
            i = int(neg[np.argmin(r)])
            lam = lam + float(r.min()) * (mu - lam)
            lam[i] = 0.0
            keep = lam > 0.0
            S = [x for x, k in zip(S, keep.tolist()) if k]
            lam = lam[keep]
    return lam @ G[S], S


def _ascend(patch: _Patch, X, iterations, eps, area_band, area_limits):
    """The patch's nodes after ``iterations`` ascent steps (see the module docstring)."""
    Y = patch.positions(X[None])
    tri2 = patch.corners(Y)[2][0, : patch.ntri]
    ar = 0.5 * tri2
    if patch.any_quad:
        ar = np.concatenate([ar, 0.5 * _area2(Y[0, patch.lq])])
    lo0, hi0 = float(ar.min()), float(ar.max())
    lo, hi = -np.inf, np.inf
    if area_band is not None:
        lo, hi = area_band * lo0, hi0 / area_band
        if area_limits is not None:
            lo, hi = max(lo, min(area_limits[0], lo0)), min(hi, max(area_limits[1], hi0))

    f, (q, th, cr, u, w) = patch.score(Y, lo, hi)
    f0 = float(f[0])
    if not np.isfinite(f0):
        return X, f0
    q, th, u, w = q[0], th[0], u[0], w[0]
    h = float(np.mean(np.sqrt((u * u).sum(1))))
    t = 0.1 * h
    halvings = 0.5 ** np.arange(8)
    n = patch.n
    last = None  # the active set whose direction (d, nd) is known at the current X
    corral = np.zeros(0, np.intp)  # the corners of the last min-norm point's corral
    for _ in range(iterations):
        active = np.flatnonzero(q <= q.min() + eps)
        if last is None or not np.array_equal(active, last):  # else: the same rows, the same direction
            G = patch.gradients(active, th[active], u[active], w[active]).reshape(active.shape[0], -1)
            at = np.searchsorted(active, corral)
            d, S = _min_norm(G, at[active[np.minimum(at, active.shape[0] - 1)] == corral].tolist())
            corral = active[S]
            nd = float(np.sqrt(d @ d))
            last = active
        if nd < 1e-12:
            eps *= 0.5
            if eps < _EPS_MIN:
                break
            continue
        steps = t * halvings
        Xs = X[None] + steps[:, None, None] * (d / nd).reshape(-1, 2)[None]
        Ys = np.empty((8, Y.shape[1], 2))
        Ys[:, :n] = Xs
        Ys[:, n:] = patch.ext
        fs, (qs, ths, _, us, ws) = patch.score(Ys, lo, hi)
        k = np.flatnonzero(fs > f0 + _GAIN)  # a real gain: round-off never decides a step
        if k.size:
            k = k[0]
            X, f0, t = Xs[k], float(fs[k]), min(2.0 * steps[k], 0.5 * h)
            q, th, u, w = qs[k], ths[k], us[k], ws[k]
            last = None
        else:
            eps *= 0.5
            t = float(steps[-1])
            if eps < _EPS_MIN:
                break
    return X, f0


def _worst_first(qual: np.ndarray, k: int):
    """The indices of ``np.argsort(qual, kind="stable")`` one by one, sorting only the ``k`` (or a few
    more) smallest unless more are asked for: the loop over the candidates stops after a few."""
    if qual.shape[0] > k:
        v = np.partition(qual, k - 1)[k - 1]
        head = np.flatnonzero(qual <= v)  # a prefix of the stable order: every smaller value, every tie
        yield from head[np.argsort(qual[head], kind="stable")].tolist()
        rest = np.flatnonzero(qual > v)
        yield from rest[np.argsort(qual[rest], kind="stable")].tolist()
    else:
        yield from np.argsort(qual, kind="stable").tolist()


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
    offs, cids = _csr(topo)
    used_cells = np.zeros(nt + topo.n_quad, bool)
    out = P.copy()
    done = 0
    for i in _worst_first(qual, 4 * cells + 16):  # at most a few dozen candidates, at most ``cells`` patches
        if done >= cells:
            break
        c = int(cand[i])
        verts = allc[0][c] if c < nt else allc[1][c - nt]
        nodes = verts[~blocked[verts]]
        if not nodes.size:
            continue
        for _ in range(rings):
            nb = np.concatenate([topo.ring_indices[topo.ring_offsets[v]:topo.ring_offsets[v + 1]] for v in nodes])
            nodes = np.union1d(nodes, nb[~blocked[nb]])
        ids = np.unique(np.concatenate([cids[offs[v]:offs[v + 1]] for v in nodes]))
        done += 1
        if used_cells[ids].any():
            continue
        used_cells[ids] = True
        patch = _Patch(out, topo, nodes, ids, floors)
        X, _ = _ascend(patch, out[nodes], iterations, np.radians(eps), area_band, area_limits)
        out[nodes] = X
    return out
