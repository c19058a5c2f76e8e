"""The ascent of stage 5's patches (:mod:`._patch`): the patch's nodes move by a steepest ascent of
its minimum corner quality.

One patch (:class:`_Patch`) holds its moving nodes and the corners of every cell incident to them as
local indices; :func:`_ascend` is the ascent of one patch, :func:`ascend_all` that of every patch of
a pass at once (they share no cell, so none sees another's nodes move): the same operations, bit
for bit, with one evaluation of all the patches' trial steps per ascent step instead of one per
patch (:class:`._patchbatch._Batch`).  The direction is the min-norm point of the hull of the active corners' gradients
(:func:`._minnorm._min_norm`: Wolfe's algorithm, exact, warm-started from the previous step's corral).
Pure numpy on a few dozen nodes, the same for the numpy and the compiled kernels.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from ..topology import Topology
from ._minnorm import _wolfe
from ._patchbatch import _Batch

__all__ = ["ascend_all"]

_GAIN = 1e-10  # radians: a step must raise the minimum by this (round-off never decides a step)
_EPS_MIN = 1e-4  # radians: the active-set tolerance halves down to this, then the ascent stops
_HALVINGS = 0.5 ** np.arange(8)
_FIRST = 4  # trial steps scored first (the rest only if a patch takes none of them)


def _loc_of(topo: Topology) -> np.ndarray:
    """(N,) position of every free node in ``topo.free_nodes`` (garbage at fixed nodes); cached."""
    key = ("patch-loc-of",)
    hit = topo._cache.get(key)
    if hit is None:
        hit = np.zeros(topo.n_points, np.intp)
        hit[topo.free_nodes] = np.arange(topo.n_free)
        topo._cache[key] = hit
    return hit


def _area2(c):
    """Twice the signed area of cells with corners c (..., k, 2): triangles by an edge cross product,
    quads by their diagonals (the reference's formulas)."""
    if c.shape[-2] == 3:
        return (c[..., 1, 0] - c[..., 0, 0]) * (c[..., 2, 1] - c[..., 0, 1]) - (c[..., 1, 1] - c[..., 0, 1]) * (
            c[..., 2, 0] - c[..., 0, 0])
    return (c[..., 2, 0] - c[..., 0, 0]) * (c[..., 3, 1] - c[..., 1, 1]) - (c[..., 2, 1] - c[..., 0, 1]) * (
        c[..., 3, 0] - c[..., 1, 0])


def _setdiff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.setdiff1d(a, b)`` (the sorted unique values of ``a`` not in ``b``) by a binary search in the
    sorted ``b``: no lookup table over the range of the node ids, which ``np.isin`` may build (a third of
    a patch's set-up on 100k triangles)."""
    u = np.unique(a)
    if not b.size:
        return u
    sb = np.sort(b)
    return u[sb[np.minimum(sb.searchsorted(u), sb.shape[0] - 1)] != u]


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

    def __init__(self, points, topo, nodes, cell_ids, floors=None, size_scale=None):
        nt = topo.n_tri
        self.nodes = nodes
        n = nodes.shape[0]
        tri = topo.tri[cell_ids[cell_ids < nt]]
        quad = topo.quad[cell_ids[cell_ids >= nt] - nt]
        allv = np.concatenate([tri.ravel(), quad.ravel()]).astype(np.intp)
        ext = _setdiff(allv, nodes)
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
        nt3 = self.ntri
        self.lt = np.stack([self.lv[:nt3], self.lv[nt3:2 * nt3], self.lv[2 * nt3:3 * nt3]], axis=1)
        self.S = size_scale  # radians per unit area of the cells' size term (None: angles only)
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
                lo = table.searchsorted(lc, "left")
                cnt = table.searchsorted(lc, "right") - lo
                rows = np.repeat(lo - (np.cumsum(cnt) - cnt), cnt) + np.arange(int(cnt.sum()))  # the slices lo:hi
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
        amin = a.min(axis=1)
        ok &= (amin >= lo) & (a.max(axis=1) <= hi)
        if self.floor is not None:
            fc, fq, qc, fa, f1, f2 = self.floor
            a2 = cr[:, fc]
            if self.any_quad:
                a2 = np.where(fq, q2[:, qc], a2)
            e1 = np.hypot(u[:, fc, 0], u[:, fc, 1])
            e2 = np.hypot(w[:, fc, 0], w[:, fc, 1])
            ok &= ((a2 >= fa) & (e1 >= f1) & (e2 >= f2)).all(axis=1)
        f = q.min(axis=1) if self.S is None else np.minimum(q.min(axis=1), self.S * amin)
        return np.where(ok, f, -np.inf), cs, a

    def gradients(self, sel, th, u, w):
        """(c, n, 2): gradient of the quality of the corners ``sel`` (indices; at angles th, edges u,
        w) with respect to the moving nodes."""
        return self.gradient_rows(sel, _corner_gradients(self.quad[sel] if self.any_quad else None, th, u, w)
                                  ).reshape(sel.shape[0], self.n, 2)

    def _cols6(self) -> np.ndarray:
        """(C, 6): where a corner's 6 gradient entries go among the columns of :meth:`gradient_rows`' rows:
        its slots' (x, y), the non-moving slots' to 2 spare columns (topology only, cached)."""
        c = self.__dict__.get("_col6")
        if c is None:
            slot = np.minimum(self.l3, self.n)
            c = self._col6 = (2 * slot[:, :, None] + np.arange(2)).reshape(-1, 6)
        return c

    def gradient_rows(self, sel, g6):
        """(c, 2 n) C-contiguous: the corners ``sel``'s gradients ``g6`` (c, 6; :func:`_corner_gradients`)
        as rows over the moving nodes' (x, y)."""
        G = np.zeros((sel.shape[0], 2 * self.n + 2))
        # a corner's three nodes are distinct: one value per moving entry, as np.add.at would sum it
        G[_rows(sel.shape[0]), self._cols6()[sel]] = g6
        return np.ascontiguousarray(G[:, : 2 * self.n])

    def _area_tables(self):
        """Per kind (triangles, quads): (the cells' local slots rolled by -1 and by +1, the columns of
        their x entries in :meth:`gradient_rows`' layout), topology only, cached."""
        t = self.__dict__.get("_atab")
        if t is None:
            t = self._atab = [None if v is None else (np.roll(v, -1, axis=1), np.roll(v, 1, axis=1), 2 * np.minimum(v, self.n))
                              for v in (self.lt, self.lq)]
        return t

    def area_rows(self, sel, Y, G):
        """Into the rows G (c, 2 n + 2; zeros): the gradient of ``S`` x the area of the cells ``sel``
        (ascending indices in area order: triangles, then quads) at local positions Y (n + m, 2) with
        respect to the moving nodes' (x, y) (the 2 spare columns take the other corners').  Corner i of
        a polygon moves its area by (y_{i+1} - y_{i-1}, x_{i-1} - x_{i+1}) / 2 (the shoelace formula)."""
        k = int(sel.searchsorted(self.ntri))
        for tab, s, R in zip(self._area_tables(), (sel[:k], sel[k:] - self.ntri), (G[:k], G[k:])):
            if tab is None or not s.size:
                continue
            nx, pv, col = Y.take(tab[0].take(s, axis=0), axis=0), Y.take(tab[1].take(s, axis=0), axis=0), tab[2].take(s, axis=0)
            r = _rows(s.shape[0])
            # a cell's corners are distinct: one value per moving entry
            R[r, col] = (0.5 * self.S) * (nx[..., 1] - pv[..., 1])
            R[r, col + 1] = (0.5 * self.S) * (pv[..., 0] - nx[..., 0])

    def area_gradients(self, sel, Y):
        """(c, n, 2): gradient of ``S`` x the area of the cells ``sel`` (indices in area order: triangles,
        then quads) at local positions Y (n + m, 2) with respect to the moving nodes (:meth:`area_rows`)."""
        G = np.zeros((sel.shape[0], 2 * self.n + 2))
        self.area_rows(sel, Y, G)
        return G[:, : 2 * self.n].reshape(sel.shape[0], self.n, 2)


_AR = np.arange(256)[:, None]  # row indices of a gradient matrix (grown by _rows)


def _rows(a: int) -> np.ndarray:
    """(a, 1) row indices 0..a-1 (a view of one cached array)."""
    global _AR
    if a > _AR.shape[0]:
        _AR = np.arange(2 * a)[:, None]
    return _AR[:a]


def _corner_gradients(quad, th, u, w) -> np.ndarray:
    """(c, 6) gradient of the quality of corners at angles th (c,), edges u, w (c, 2): d / d the
    previous corner (x, y), the next, the vertex (the corner's angle: (-w_y, w_x) / |w|^2, (u_y, -u_x)
    / |u|^2, minus their sum; a quad corner above 90 deg (``quad``: which are quad corners, or None)
    the opposite: its quality is 180 deg - angle).  Elementwise: every corner's values are those of
    that corner alone."""
    ux, uy, wx, wy = (u[0], u[1], w[0], w[1]) if isinstance(u, (tuple, list)) else (u[:, 0], u[:, 1], w[:, 0], w[:, 1])
    g = np.empty((th.shape[0], 6))
    sw, su = wx * wx + wy * wy, ux * ux + uy * uy  # (the two-term sums (w * w).sum(1), in that order)
    np.divide(-wy, sw, out=g[:, 0])
    np.divide(wx, sw, out=g[:, 1])
    np.divide(uy, su, out=g[:, 2])
    np.divide(-ux, su, out=g[:, 3])
    if quad is not None:
        g[:, :4] *= np.where(quad & (th > np.pi / 2), -1.0, 1.0)[:, None]
    np.add(g[:, 0:2], g[:, 2:4], out=g[:, 4:6])
    np.negative(g[:, 4:6], out=g[:, 4:6])
    return g


def _limits(patch: _Patch, Y, area_band, area_limits):
    """The area band (lo, hi) of a patch at its start positions Y (1, n + m, 2)."""
    ar = 0.5 * patch.corners(Y)[2][0, : patch.ntri]
    if patch.any_quad:
        ar = np.concatenate([ar, 0.5 * _area2(Y[0, patch.lq])])
    lo0, hi0 = float(ar.min()), float(ar.max())
    lo, hi = -np.inf, np.inf
    if area_band is not None:
        lo, hi = area_band * lo0, hi0 / area_band
        if area_limits is not None:
            lo, hi = max(lo, min(area_limits[0], lo0)), min(hi, max(area_limits[1], hi0))
    return lo, hi


def _ascend(patch: _Patch, X, iterations, eps, area_band, area_limits):
    """The patch's nodes after ``iterations`` ascent steps (see :mod:`._patch`), one patch alone."""
    return ascend_all([patch], [X], iterations, eps, area_band, area_limits)[0], None


def _direction(patch: _Patch, st: dict):
    """The ascent direction of one patch at its current corners (``st``: its state in :func:`ascend_all`,
    ``g6`` its corners' gradients): (d, |d|), reused while the active set stays the same."""
    q = st["q"]
    C = q.shape[0]
    if patch.S is not None:  # the corners, then the cells' size terms (one index space: C + cell)
        q = np.concatenate((q, patch.S * st["a"]))
    active = (q <= np.minimum.reduce(q) + st["eps"]).nonzero()[0]
    last = st["last"]
    key = active.tolist()
    if last is None or key != last:
        nc = bisect.bisect_left(key, C)  # (active.searchsorted(C))
        ac, cl = active[:nc], active[nc:] - C
        # the corners' rows then the size terms' in one array (gradient_rows and area_gradients' values)
        G = np.zeros((active.shape[0], 2 * patch.n + 2))
        G[_rows(nc), patch._cols6().take(ac, axis=0)] = st["g6"].take(ac, axis=0)
        if cl.size:
            patch.area_rows(cl, st["Y"], G[nc:])
        G = np.ascontiguousarray(G[:, : 2 * patch.n])
        # the previous corral's rows that are still active, at their places in the active set (a few rows:
        # Python lists)
        where = {c: i for i, c in enumerate(key)}
        start = [where[c] for c in st["corral"] if c in where]
        # (ascend_all ignores floating-point errors: a singular corral system gives NaN, handled there)
        d, S = (G[0].copy(), [0]) if G.shape[0] == 1 else _wolfe(G, G.shape[0], start)
        st["corral"] = [key[i] for i in S]
        st["d"], st["nd"] = d, math.sqrt(float(d @ d))
        st["last"] = key
    return st["d"], st["nd"]


def _trial_planes(Ycur, batch, patches, out, moving, sl):
    """The trial positions of the steps ``sl`` as node-major x and y planes (all local nodes, K): every
    patch at its current positions ``Ycur`` (all local nodes, 2), the moving ones' nodes at
    x + step d (``moving``: patch -> (steps, unit direction (n, 2)))."""
    K = len(range(*sl.indices(_HALVINGS.shape[0])))
    XT, ZT = np.repeat(Ycur[:, 0:1], K, axis=1), np.repeat(Ycur[:, 1:2], K, axis=1)
    for i, (steps, dn) in moving.items():
        o, n, s = batch.off[i], patches[i].n, steps[sl][None, :]
        XT[o:o + n] = out[i][:, 0:1] + dn[:, 0:1] * s
        ZT[o:o + n] = out[i][:, 1:2] + dn[:, 1:2] * s
    return XT, ZT


def ascend_all(patches, Xs, iterations, eps, area_band, area_limits):
    """``[_ascend(p, X, ...)[0] for p, X in zip(patches, Xs)]``, bit for bit, the patches in lockstep:
    per ascent step one direction per live patch, then one :meth:`_Batch.score` of every trial step
    of every patch (a patch that stopped, or takes no step this time, keeps its positions).
    Floating-point errors are ignored (NaN and infinities are handled where they arise)."""
    with np.errstate(all="ignore"):
        return _ascend_all(patches, Xs, iterations, eps, area_band, area_limits)


def _ascend_all(patches, Xs, iterations, eps, area_band, area_limits):
    out = [np.asarray(X) for X in Xs]
    states = {}
    for i, (p, X) in enumerate(zip(patches, out)):
        Y = p.positions(X[None])
        lo, hi = _limits(p, Y, area_band, area_limits)
        f, (q, th, cr, u, w), a = p.score(Y, lo, hi)
        f0 = float(f[0])
        if np.isfinite(f0):
            h = float(np.mean(np.sqrt((u[0] * u[0]).sum(1))))
            states[i] = dict(lo=lo, hi=hi, f0=f0, h=h, t=0.1 * h, eps=eps, q=q[0], th=th[0], u=u[0], w=w[0],
                             last=None, corral=[], a=a[0], Y=Y[0],
                             g6=_corner_gradients(p.quad if p.any_quad else None, th[0], u[0], w[0]))
    if not states:
        return out
    batch = _Batch(patches)
    Ycur = np.concatenate([p.positions(X[None])[0] for p, X in zip(patches, out)])
    lo = np.array([states[i]["lo"] if i in states else -np.inf for i in range(len(patches))])
    hi = np.array([states[i]["hi"] if i in states else np.inf for i in range(len(patches))])
    for _ in range(iterations):
        moving = {}
        for i in list(states):
            st = states[i]
            d, nd = _direction(patches[i], st)
            if nd < 1e-12:
                st["eps"] *= 0.5
                if st["eps"] < _EPS_MIN:
                    del states[i]
                continue
            moving[i] = (st["t"] * _HALVINGS, (d / nd).reshape(-1, 2))
        if not moving:
            if not states:
                break
            continue
        planes = [_trial_planes(Ycur, batch, patches, out, moving, slice(0, _FIRST))]
        # the longest steps first (most patches take one of them: 100k random triangles, 9 in 10), all
        # 8 if a patch took none of those; a step's scores do not depend on the other steps'
        fs, (crs, dots, us, ws, As) = batch.score_planes(*planes[0], lo, hi)
        mv = list(moving)
        mva = np.array(mv) if len(mv) < len(patches) else slice(None)  # (every patch: all columns)
        gain = np.array([states[i]["f0"] for i in mv]) + _GAIN
        up = fs[:, mva] > gain
        if not np.logical_or.reduce(up, axis=0).all():
            planes.append(_trial_planes(Ycur, batch, patches, out, moving, slice(_FIRST, None)))
            f2, more = batch.score_planes(*planes[1], lo, hi)
            fs = np.concatenate((fs, f2))
            up = np.concatenate((up, f2[:, mva] > gain))
            crs, dots, As = (np.concatenate((x, y), axis=1) for x, y in zip((crs, dots, As), more[:2] + more[4:]))
            us, ws = (tuple(np.concatenate((x, y), axis=1) for x, y in zip(p, r)) for p, r in zip((us, ws), more[2:4]))
        first, some = up.argmax(axis=0).tolist(), np.logical_or.reduce(up, axis=0).tolist()
        taken = []
        for i, k, has in zip(mv, first, some):
            st = states[i]
            steps = moving[i][0]
            if has:
                taken.append((i, k, steps))
            else:
                st["eps"] *= 0.5
                st["t"] = float(steps[-1])
                if st["eps"] < _EPS_MIN:
                    del states[i]
        if taken:  # the new corners of the patches that moved, in one gather (the same values)
            ks = {k for _, k, _ in taken}
            arrs = (crs, dots) + us + ws  # (cross, dot, ux, uy, wx, wy), (corners, K)
            if len(ks) == 1:  # (usually: every patch took its longest step) one trial step's column
                k = ks.pop()
                if len(taken) == len(patches):
                    cols = slice(None)
                    got = [np.ascontiguousarray(x[:, k]) for x in arrs]
                else:
                    cols = np.concatenate([batch.corner_range(i) for i, _, _ in taken])
                    got = [x[:, k].take(cols) for x in arrs]
            else:
                cols = np.concatenate([batch.corner_range(i) for i, _, _ in taken])
                rows = np.repeat([k for _, k, _ in taken], [batch.crange[i].shape[0] for i, _, _ in taken])
                got = [x[cols, rows] for x in arrs]
            qa, tha = batch.quality(got[0], got[1], cols)
            ga = _corner_gradients(batch.quad[cols] if batch.any_quad else None, tha, got[2:4], got[4:6])
            s0 = 0
            for i, k, steps in taken:
                st = states[i]
                o, n = batch.off[i], patches[i].n
                s1 = s0 + batch.cst_end[i] - batch.cst[i]
                XT, ZT = planes[k // _FIRST]
                out[i] = np.stack((XT[o:o + n, k % _FIRST], ZT[o:o + n, k % _FIRST]), axis=1)
                Ycur[o:o + n] = out[i]
                st["f0"], st["t"] = float(fs[k, i]), min(2.0 * float(steps[k]), 0.5 * st["h"])
                st["q"], st["g6"] = qa[s0:s1], ga[s0:s1]
                if patches[i].S is not None:  # the areas and positions the size terms' gradients need
                    a0 = batch.ast[i]
                    st["a"] = As[a0:a0 + patches[i].ntri + patches[i].nq, k].copy()
                    st["Y"] = Ycur[o:batch.off[i + 1]].copy()
                st["last"] = None
                s0 = s1
        if not states:
            break
    return out
