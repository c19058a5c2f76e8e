"""The numba kernels behind :mod:`._fast` (imported only when they are used).

Each per-node helper (``_node_*``) mirrors, operation for operation, the numpy
code it replaces in :mod:`._local` or :mod:`.angle` (named in its docstring);
keep the two in step.  The exported kernels loop over the nodes they are
given (``prange``, compiled serially): a node reads the shared points and
writes only its own outputs, so :func:`._fast._run` runs them on several
threads by splitting the nodes (numba's own parallel layer costs five times
the compile time and oversubscribes busy machines; see ``_fast``).

A node with several candidates (the best of five, the keep test, the compass
search) gathers its incident cells once into a small scratch (``_node_rows``)
and scores each candidate from it (``_node_score_rows``), starting with the cell
that decided the previous candidate and stopping as soon as the candidate cannot
beat the best so far: the same answers (a minimum and an integer count do not
depend on the order of the cells), fewer operations.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ._local import _C30, INVALID, INVERTED_WEIGHT
from ._patchkernels import _screen_below  # noqa: F401 - stage 5's screen, named with the others (warm-up, estimate)

# error_model="numpy": x / 0 gives inf / NaN as in numpy instead of raising; no fastmath, so no
# reassociation or fused multiply-adds and the same rounding as numpy
_OPTS = {"cache": True, "error_model": "numpy", "parallel": False, "nogil": True}
_TWO_PI = 2 * np.pi
# The per-node helpers decorated ``_helper`` are ordinary compiled functions (the same error model),
# called, not inlined by numba: ``inline="always"`` types and lowers a fresh copy at each call site,
# a called helper is typed once per process for every kernel that calls it (a real call per node:
# the optimized kernels keep them as calls).  ``_node_score_rows`` (six call sites in ``angle_choose``, ``compass``, ``score``):
# a cold default run compiled 13.7 s on the quiet 2-core VM inlined, 5.3 s called.  ``_node_rows``
# (two call sites in ``angle_choose``, one in each other kernel), ``_node_angle`` and
# ``_node_certified`` called too (issue 17): the cold default run's compile CPU 7.1 -> 6.0 s (loaded
# VM, medians of 3; ``angle_optimize`` 1.7 -> 1.0 s, the rows' helper now shared), the same results
# and per-pass CPU within the noise (200k triangles, 1 thread: 10 passes 1.09 vs 1.10 s, min of 9).
# They compile once per process and are stored inside each cached kernel that calls them.  The
# tiny helpers stay inlined (``_corner_ok`` called measured no faster to compile).
_helper = njit(error_model="numpy", nogil=True)


def _kernel(fn):
    """``njit`` with on-disk caching, or without it where numba finds no writable cache location
    (read-only install and home directory): the kernels then compile in every process."""
    try:
        return njit(**_OPTS)(fn)
    except RuntimeError:
        return njit(**{**_OPTS, "cache": False})(fn)


@_helper
def _node_score(pts, px, py, f, tp, tv, qp, qv, fl):
    """``BlockGeometry.score`` for one node (free index ``f``) at (px, py): ``_tri_chunk`` / ``_quad_chunk``.

    ``fl``: the input floors (``_floors.Floors``) as a (6, rows) array, or an empty one (no floors).
    """
    best = np.inf
    bad = 0.0
    floors = fl.shape[0] > 0
    for r in range(tp[f], tp[f + 1]):
        i1, i2 = tv[r, 1], tv[r, 2]
        x1, y1, x2, y2 = pts[i1, 0], pts[i1, 1], pts[i2, 0], pts[i2, 1]
        ux, uy = x2 - x1, y2 - y1
        l12 = math.sqrt(ux * ux + uy * uy)
        ex1, ey1 = x1 - px, y1 - py
        fx2, fy2 = px - x2, py - y2
        l1 = math.sqrt(ex1 * ex1 + ey1 * ey1)
        l2 = math.sqrt(fx2 * fx2 + fy2 * fy2)
        v0 = (ex1 * fx2 + ey1 * fy2) / (l1 * l2)
        v1 = (ux * ex1 + uy * ey1) / (l12 * l1)
        v2 = (fx2 * ux + fy2 * uy) / (l2 * l12)
        v = min(v0, v1, v2)
        cr = ex1 * fy2 - ey1 * fx2
        okf = True
        if floors:
            okf = (-cr >= fl[0, r]) & (l1 >= fl[1, r]) & (l2 >= fl[2, r])
        # valid: corner cross product < 0 and np.minimum(v0, v1, v2) finite (a NaN propagates there);
        # bitwise & keeps the test free of branches
        if (cr < 0) & okf & (v0 == v0) & (v1 == v1) & (v2 == v2) & (abs(v) < np.inf):
            best = min(best, v)
        else:
            ex2, ey2 = x2 - px, y2 - py
            bad += 1.0 if 0.5 * (ex1 * ey2 - ey1 * ex2) > 0 else INVERTED_WEIGHT
    for r in range(qp[f], qp[f + 1]):
        i1, i2, i3 = qv[r, 1], qv[r, 2], qv[r, 3]
        x1, y1, x2, y2, x3, y3 = pts[i1, 0], pts[i1, 1], pts[i2, 0], pts[i2, 1], pts[i3, 0], pts[i3, 1]
        ux, uy = x2 - x1, y2 - y1
        vx, vy = x3 - x2, y3 - y2
        l12 = math.sqrt(ux * ux + uy * uy)
        l23 = math.sqrt(vx * vx + vy * vy)
        c2 = vx * -uy - vy * -ux
        cos2 = (vx * -ux + vy * -uy) / (l23 * l12)
        ok2 = (c2 > 0) & (abs(cos2) < np.inf)
        qc2 = abs(cos2) if ok2 else 1.0
        ex1, ey1 = x1 - px, y1 - py
        ex3, ey3 = x3 - px, y3 - py
        l1 = math.sqrt(ex1 * ex1 + ey1 * ey1)
        l3 = math.sqrt(ex3 * ex3 + ey3 * ey3)
        a0 = abs((ex1 * ex3 + ey1 * ey3) / (l1 * l3))
        a1 = abs((ux * ex1 + uy * ey1) / (l12 * l1))
        a3 = abs((ex3 * vx + ey3 * vy) / (l3 * l23))
        cm = max(a0, a1, a3, qc2)
        # valid: the three corner cross products > 0, corner 2 valid, and every |cos| finite
        # (x < inf is False for NaN and inf; np.maximum would propagate either)
        ok = (ex1 * ey3 - ey1 * ex3 > 0) & (uy * ex1 - ux * ey1 > 0) & (ex3 * vy - ey3 * vx > 0) & ok2
        if floors:
            a2 = (x1 + ux - px) * (y3 - y1) - (y1 + uy - py) * (x3 - x1)
            ok = ok & (a2 >= fl[3, r]) & (l1 >= fl[4, r]) & (l3 >= fl[5, r])
        if ok & (a0 < np.inf) & (a1 < np.inf) & (a3 < np.inf):
            best = min(best, -cm)
        else:
            dx, dy = x1 + ux - px, y1 + uy - py
            fx, fy = x3 - x1, y3 - y1
            bad += 1.0 if 0.5 * (dx * fy - dy * fx) > 0 else INVERTED_WEIGHT
    return INVALID - bad if bad > 0 else best


#: ``strict=False`` for :func:`_node_score_rows`: a numpy bool, which numba types ``bool`` like the
#: per-node ``strict`` of ``compass``; a literal ``False`` (or a Python ``False`` global) is typed
#: ``Literal[bool](False)``: a second compiled copy of the helper (0.6-0.7 s of a cold default run)
_NOT_STRICT = np.False_

#: columns of the per-node row scratch of :func:`_node_rows` (one row per incident cell)
_ROW_COLS = 12


@njit(inline="always")
def _max_rows(nodes, tp, qp):
    """The most incident cells of any of ``nodes``: the rows of the scratch :func:`_node_rows` fills."""
    m = 0
    for i in range(nodes.shape[0]):
        f = nodes[i]
        m = max(m, tp[f + 1] - tp[f] + qp[f + 1] - qp[f])
    return m


@_helper
def _node_rows(pts, f, tp, tv, qp, qv, buf):
    """The part of ``_node_score`` that does not depend on the moving node, once per node, into ``buf``.

    Triangle rows first (x1, y1, x2, y2, ux, uy, l12), then quad rows (x1, y1, x3, y3, ux, uy, vx, vy,
    l12, l23, |cos2| or 1, corner 2 valid): the same operations as ``_node_score``, so
    :func:`_node_score_rows` gives the same numbers while a node's candidates skip the gathers and the
    fixed edges' square roots and divisions.
    """
    k = 0
    for r in range(tp[f], tp[f + 1]):
        i1, i2 = tv[r, 1], tv[r, 2]
        x1, y1, x2, y2 = pts[i1, 0], pts[i1, 1], pts[i2, 0], pts[i2, 1]
        ux, uy = x2 - x1, y2 - y1
        buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3] = x1, y1, x2, y2
        buf[k, 4], buf[k, 5], buf[k, 6] = ux, uy, math.sqrt(ux * ux + uy * uy)
        k += 1
    for r in range(qp[f], qp[f + 1]):
        i1, i2, i3 = qv[r, 1], qv[r, 2], qv[r, 3]
        x1, y1, x2, y2, x3, y3 = pts[i1, 0], pts[i1, 1], pts[i2, 0], pts[i2, 1], pts[i3, 0], pts[i3, 1]
        ux, uy = x2 - x1, y2 - y1
        vx, vy = x3 - x2, y3 - y2
        l12 = math.sqrt(ux * ux + uy * uy)
        l23 = math.sqrt(vx * vx + vy * vy)
        c2 = vx * -uy - vy * -ux
        cos2 = (vx * -ux + vy * -uy) / (l23 * l12)
        ok2 = (c2 > 0) & (abs(cos2) < np.inf)
        buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3] = x1, y1, x3, y3
        buf[k, 4], buf[k, 5], buf[k, 6], buf[k, 7] = ux, uy, vx, vy
        buf[k, 8], buf[k, 9] = l12, l23
        buf[k, 10] = abs(cos2) if ok2 else 1.0
        buf[k, 11] = 1.0 if ok2 else 0.0
        k += 1
    buf[buf.shape[0] - 1, 0] = 0.0  # the cell to start the next score with (see _node_score_rows)


@_helper
def _node_score_rows(px, py, f, tp, qp, buf, fl, cut, lo0, hi0, strict):
    """:func:`_node_score` from the rows :func:`_node_rows` put in ``buf`` for node ``f`` (same numbers).

    ``cut``: the caller needs the score only where it is above ``cut``; where it is not, ``-inf`` may
    come back as soon as that is certain (a valid cell with a score <= ``cut``, or, when ``cut`` is
    at least the best invalid score ``INVALID - 1``, an invalid cell), skipping the node's other
    cells.  ``-inf`` scores every cell.  Every score above ``cut`` is exact, so a caller that only
    asks "is this candidate better than ``cut``?" gets the same answers.

    The cells are visited starting with the one that decided the previous call for this node (its
    worst cell, or the one that cut it off; kept in ``buf``'s last row): a minimum and a count of
    invalid cells do not depend on the order, and a nearby candidate is most often cut off by the
    same cell, so most candidates that cannot win stop after one cell.

    ``lo0``, ``hi0``: an area band (``-inf``, ``inf``: none): ``-inf`` where an incident cell's signed
    area (``_tri_area`` / ``_quad_area``, from the same products as the score) is outside
    [lo0, hi0], as :meth:`BlockGeometry.banded_score` gives, found in the same pass over the cells.

    ``strict``: the quad corners score ``_local.strict_quad`` (the same operations; ``compass`` asks
    for it at its ``strict`` nodes that also have triangles).
    """
    best = np.inf
    bad = 0.0
    floors = fl.shape[0] > 0
    banded = not ((lo0 == -np.inf) & (hi0 == np.inf))  # (a NaN bound: banded, every cell outside)
    cut_invalid = cut >= INVALID - 1.0
    t0, nt = tp[f], tp[f + 1] - tp[f]
    q0 = qp[f]
    m = nt + qp[f + 1] - q0
    hint = buf.shape[0] - 1
    k = int(buf[hint, 0])
    if k >= m:
        k = 0
    worst = k
    worst_bad = -1
    for _ in range(m):
        if k < nt:
            x1, y1, x2, y2 = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
            ux, uy, l12 = buf[k, 4], buf[k, 5], buf[k, 6]
            ex1, ey1 = x1 - px, y1 - py
            fx2, fy2 = px - x2, py - y2
            l1 = math.sqrt(ex1 * ex1 + ey1 * ey1)
            l2 = math.sqrt(fx2 * fx2 + fy2 * fy2)
            v0 = (ex1 * fx2 + ey1 * fy2) / (l1 * l2)
            v1 = (ux * ex1 + uy * ey1) / (l12 * l1)
            v2 = (fx2 * ux + fy2 * uy) / (l2 * l12)
            v = min(v0, v1, v2)
            cr = ex1 * fy2 - ey1 * fx2
            if banded:
                a = -0.5 * cr  # _tri_area exactly: fx2 = -(x2 - px), fy2 = -(y2 - py)
                if not ((a >= lo0) & (a <= hi0)):
                    buf[hint, 0] = k
                    return -np.inf
            okf = True
            if floors:
                r = t0 + k
                okf = (-cr >= fl[0, r]) & (l1 >= fl[1, r]) & (l2 >= fl[2, r])
            valid = (cr < 0) & okf & (v0 == v0) & (v1 == v1) & (v2 == v2) & (abs(v) < np.inf)
            if not valid:
                ex2, ey2 = x2 - px, y2 - py
                w = 1.0 if 0.5 * (ex1 * ey2 - ey1 * ex2) > 0 else INVERTED_WEIGHT
        else:
            x1, y1, x3, y3 = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
            ux, uy, vx, vy = buf[k, 4], buf[k, 5], buf[k, 6], buf[k, 7]
            l12, l23, qc2, ok2 = buf[k, 8], buf[k, 9], buf[k, 10], buf[k, 11] > 0
            ex1, ey1 = x1 - px, y1 - py
            ex3, ey3 = x3 - px, y3 - py
            l1 = math.sqrt(ex1 * ex1 + ey1 * ey1)
            l3 = math.sqrt(ex3 * ex3 + ey3 * ey3)
            a0 = abs((ex1 * ex3 + ey1 * ey3) / (l1 * l3))
            a1 = abs((ux * ex1 + uy * ey1) / (l12 * l1))
            a3 = abs((ex3 * vx + ey3 * vy) / (l3 * l23))
            cm = max(a0, a1, a3, qc2)
            ok = (ex1 * ey3 - ey1 * ex3 > 0) & (uy * ex1 - ux * ey1 > 0) & (ex3 * vy - ey3 * vx > 0) & ok2
            if floors or banded:
                a2 = (x1 + ux - px) * (y3 - y1) - (y1 + uy - py) * (x3 - x1)  # twice _quad_area
                if banded:
                    a = 0.5 * a2
                    if not ((a >= lo0) & (a <= hi0)):
                        buf[hint, 0] = k
                        return -np.inf
                if floors:
                    r = q0 + k - nt
                    ok = ok & (a2 >= fl[3, r]) & (l1 >= fl[4, r]) & (l3 >= fl[5, r])
            valid = ok & (a0 < np.inf) & (a1 < np.inf) & (a3 < np.inf)
            v = -cm
            if strict and valid:  # _local.strict_quad
                c = -v
                if c <= _C30:
                    v = -(_C30 * c + 0.5 * math.sqrt(max(1.0 - c * c, 0.0)))
                else:
                    v = _C30 - 1.0 - c
            if not valid:
                dx, dy = x1 + ux - px, y1 + uy - py
                fx, fy = x3 - x1, y3 - y1
                w = 1.0 if 0.5 * (dx * fy - dy * fx) > 0 else INVERTED_WEIGHT
        if valid:
            if v < best:
                best = v
                worst = k
            if best <= cut:  # the score is at most best (an invalid cell only lowers it further)
                buf[hint, 0] = k
                return -np.inf
        else:
            if cut_invalid:
                buf[hint, 0] = k
                return -np.inf
            bad += w
            if worst_bad < 0:
                worst_bad = k
        k += 1
        if k == m:
            k = 0
    buf[hint, 0] = worst_bad if bad > 0 else worst
    return INVALID - bad if bad > 0 else best


@njit(inline="always")
def _node_area_range_rows(px, py, f, tp, qp, buf):
    """``BlockGeometry.area_range`` for one node: ``_tri_area`` / ``_quad_area``, from the rows of
    :func:`_node_rows`."""
    lo = np.inf
    hi = -np.inf
    nt = tp[f + 1] - tp[f]
    for k in range(nt):
        ex1, ey1 = buf[k, 0] - px, buf[k, 1] - py
        ex2, ey2 = buf[k, 2] - px, buf[k, 3] - py
        a = 0.5 * (ex1 * ey2 - ey1 * ex2)
        lo = min(lo, a)
        hi = max(hi, a)
    for k in range(nt, nt + qp[f + 1] - qp[f]):
        x1, y1 = buf[k, 0], buf[k, 1]
        ux, uy = buf[k, 4], buf[k, 5]
        dx, dy = x1 + ux - px, y1 + uy - py
        fx, fy = buf[k, 2] - x1, buf[k, 3] - y1
        a = 0.5 * (dx * fy - dy * fx)
        lo = min(lo, a)
        hi = max(hi, a)
    return lo, hi


@njit(inline="always")
def _node_largest_rows(px, py, f, tp, qp, buf):
    """``BlockGeometry.largest`` for one node: ``-cos`` of the largest corner its position moves (every
    corner of its triangles; corners 0, 1 and 3 of its quads), from the rows of :func:`_node_rows`, the
    same operations as the score's; NaN where one is NaN, as numpy's maximum)."""
    m = -np.inf
    nan = False
    nt = tp[f + 1] - tp[f]
    for k in range(nt):
        x1, y1, x2, y2 = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
        ux, uy, l12 = buf[k, 4], buf[k, 5], buf[k, 6]
        ex1, ey1 = x1 - px, y1 - py
        fx2, fy2 = px - x2, py - y2
        l1 = math.sqrt(ex1 * ex1 + ey1 * ey1)
        l2 = math.sqrt(fx2 * fx2 + fy2 * fy2)
        for v in ((ex1 * fx2 + ey1 * fy2) / (l1 * l2), (ux * ex1 + uy * ey1) / (l12 * l1),
                  (fx2 * ux + fy2 * uy) / (l2 * l12)):
            nan |= v != v
            m = max(m, v)
    for k in range(nt, nt + qp[f + 1] - qp[f]):
        x1, y1, x3, y3 = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
        ux, uy, vx, vy = buf[k, 4], buf[k, 5], buf[k, 6], buf[k, 7]
        l12, l23 = buf[k, 8], buf[k, 9]
        ex1, ey1 = x1 - px, y1 - py
        ex3, ey3 = x3 - px, y3 - py
        l1 = math.sqrt(ex1 * ex1 + ey1 * ey1)
        l3 = math.sqrt(ex3 * ex3 + ey3 * ey3)
        for v in (-((ex1 * ex3 + ey1 * ey3) / (l1 * l3)), (ux * ex1 + uy * ey1) / (l12 * l1),
                  -((ex3 * vx + ey3 * vy) / (l3 * l23))):
            nan |= v != v
            m = max(m, v)
    return np.nan if nan else m


@_kernel
def score(pts, X, nodes, tp, tv, qp, qv, fl):
    K, n = X.shape[0], X.shape[1]
    out = np.empty((K, n))
    buf = np.empty((_max_rows(nodes, tp, qp) + 1, _ROW_COLS))
    for i in prange(n):
        f = nodes[i]
        _node_rows(pts, f, tp, tv, qp, qv, buf)
        for k in range(K):
            out[k, i] = _node_score_rows(X[k, i, 0], X[k, i, 1], f, tp, qp, buf, fl, -np.inf, -np.inf, np.inf, _NOT_STRICT)
    return out


@_kernel
def _cell_area_range(pts, tri, quad):
    """(smallest, largest) signed area of all cells, ``topology.signed_areas``' operations (NaN, NaN
    when one is NaN, as ``areas.min()`` / ``max()``); (inf, -inf) for no cells.  Not split per node."""
    lo, hi, nan = np.inf, -np.inf, False
    for c in range(tri.shape[0]):
        i0, i1, i2 = tri[c, 0], tri[c, 1], tri[c, 2]
        x0, y0 = pts[i0, 0], pts[i0, 1]
        a = 0.5 * ((pts[i1, 0] - x0) * (pts[i2, 1] - y0) - (pts[i1, 1] - y0) * (pts[i2, 0] - x0))
        nan |= a != a
        lo, hi = min(lo, a), max(hi, a)
    for c in range(quad.shape[0]):
        i0, i1, i2, i3 = quad[c, 0], quad[c, 1], quad[c, 2], quad[c, 3]
        a = 0.5 * ((pts[i2, 0] - pts[i0, 0]) * (pts[i3, 1] - pts[i1, 1]) - (pts[i2, 1] - pts[i0, 1]) * (pts[i3, 0] - pts[i1, 0]))
        nan |= a != a
        lo, hi = min(lo, a), max(hi, a)
    return (np.nan, np.nan) if nan else (lo, hi)


@njit(inline="always")
def _max_spokes(nodes, sp):
    """The most spokes of any of ``nodes``: the rows of the scratch :func:`_node_angle` fills."""
    m = 0
    for i in range(nodes.shape[0]):
        f = nodes[i]
        m = max(m, sp[f + 1] - sp[f])
    return m


@_helper
def _node_angle(pts, f, free, sp, ring, sa, sb, frac, sap, ub):
    """``angle_target`` / ``_angle_sums`` for one node: the mean of its rotated spoke positions.

    Every spoke's unit vector towards ``b`` (and its length) first, into the scratch ``ub``; a spoke
    whose ``a`` edge is another spoke's ``b`` edge reversed (``sap``, :func:`._fastcalls._spoke_partner`,
    that spoke's place among the node's spokes: every edge of a triangle fan) takes minus that unit
    vector instead of a square root and two divisions of its own: bit for bit the same numbers (``pa - pj`` is exactly ``-(pj - pa)``, the
    same squares give the same length; a zero difference divides as before, for the sign of the zero).
    """
    cx, cy = pts[free[f], 0], pts[free[f], 1]
    s0 = sp[f]
    for s in range(s0, sp[f + 1]):
        j, b = ring[s], sb[s]
        bx, by = pts[b, 0] - pts[j, 0], pts[b, 1] - pts[j, 1]
        lb = math.sqrt(bx * bx + by * by)
        k = s - s0
        ub[k, 0], ub[k, 1], ub[k, 2] = bx / lb, by / lb, lb
    sx = 0.0
    sy = 0.0
    for s in range(s0, sp[f + 1]):
        j, a = ring[s], sa[s]
        jx, jy = pts[j, 0], pts[j, 1]
        ax, ay = pts[a, 0] - jx, pts[a, 1] - jy
        q = sap[s]  # (relative to the node's first spoke)
        if q >= 0:
            ax = -ub[q, 0] if ax != 0.0 else ax / ub[q, 2]
            ay = -ub[q, 1] if ay != 0.0 else ay / ub[q, 2]
        else:
            la = math.sqrt(ax * ax + ay * ay)
            ax /= la
            ay /= la
        k = s - s0
        bx, by = ub[k, 0], ub[k, 1]
        tx, ty = by - ay, ax - bx
        if frac[s] != 0.5:
            theta = math.atan2(ax * by - ay * bx, ax * bx + ay * by)
            if theta <= 0:
                theta += _TWO_PI
            phi = frac[s] * theta
            cs, sn = math.cos(phi), math.sin(phi)
            tx = cs * ax - sn * ay
            ty = sn * ax + cs * ay
        dx, dy = cx - jx, cy - jy
        sc = math.sqrt(dx * dx + dy * dy)
        sc /= math.sqrt(tx * tx + ty * ty)
        tx *= sc
        ty *= sc
        if math.isfinite(tx) and math.isfinite(ty):
            sx += tx + jx
            sy += ty + jy
        else:  # a degenerate spoke keeps the current position
            sx += cx
            sy += cy
    c = float(sp[f + 1] - s0)
    return sx / c, sy / c


@njit(inline="always")
def _node_ring_mean(pts, f, free, rp, nbr, lengths):
    """``laplacian_target`` (the neighbours' centroid) or, with ``lengths``, ``local_scale`` for one node."""
    cx, cy = pts[free[f], 0], pts[free[f], 1]
    sx = 0.0
    sy = 0.0
    for r in range(rp[f], rp[f + 1]):
        j = nbr[r]
        if lengths:
            dx, dy = pts[j, 0] - cx, pts[j, 1] - cy
            sx += math.sqrt(dx * dx + dy * dy)
        else:
            sx += pts[j, 0]
            sy += pts[j, 1]
    c = float(rp[f + 1] - rp[f])
    return sx / c, sy / c


@_kernel
def angle_target(pts, nodes, free, sp, ring, sa, sb, frac, sap):
    n = nodes.shape[0]
    out = np.empty((n, 2))
    ub = np.empty((_max_spokes(nodes, sp), 3))
    for i in prange(n):
        out[i, 0], out[i, 1] = _node_angle(pts, nodes[i], free, sp, ring, sa, sb, frac, sap, ub)
    return out


@_kernel
def ring_mean(pts, nodes, free, rp, nbr, lengths):
    n = nodes.shape[0]
    out = np.empty((n, 2))
    for i in prange(n):
        out[i, 0], out[i, 1] = _node_ring_mean(pts, nodes[i], free, rp, nbr, lengths)
    return out


@njit(inline="always")
def _corner_ok(d, q, cc):
    """A corner whose |cosine| is ``|d| / sqrt(q)`` (``d``: the dot product, ``q``: the product of the two
    squared lengths) certainly has a cosine below ``c`` (``cc = c * c * (1 - 1e-9)``; ``signed``: only
    ``d`` > 0 counts) however its cosine is rounded: no square root, no division."""
    return (q > 1e-300) & (q < np.inf) & (d * d <= cc * q)


@_helper
def _node_certified(pts, px, py, f, tp, tv, qp, qv, c):
    """True when ``_node_score`` at (px, py) is certainly valid and above ``-c`` (``c`` > 0; no floors):
    every incident cell passes ``_node_score``'s validity tests (the same expressions, so the same
    answers) and every corner's ``-cos`` (triangles) or ``-|cos|`` (quads) is above ``-c`` by a relative
    margin of about 5e-10, far beyond the rounding of the score's square roots and divisions.  False
    says nothing (the caller then scores the node exactly)."""
    cc = c * c * (1.0 - 1e-9)
    for r in range(tp[f], tp[f + 1]):
        i1, i2 = tv[r, 1], tv[r, 2]
        x1, y1, x2, y2 = pts[i1, 0], pts[i1, 1], pts[i2, 0], pts[i2, 1]
        ux, uy = x2 - x1, y2 - y1
        ex1, ey1 = x1 - px, y1 - py
        fx2, fy2 = px - x2, py - y2
        if not (ex1 * fy2 - ey1 * fx2 < 0):
            return False
        s1, s2, s12 = ex1 * ex1 + ey1 * ey1, fx2 * fx2 + fy2 * fy2, ux * ux + uy * uy
        # the cosines are -(e1.f2), -(u.e1), -(f2.u) over the lengths: a negative one is below c already
        d0, d1, d2 = -(ex1 * fx2 + ey1 * fy2), -(ux * ex1 + uy * ey1), -(fx2 * ux + fy2 * uy)
        if not (_corner_ok(max(d0, 0.0), s1 * s2, cc) & _corner_ok(max(d1, 0.0), s12 * s1, cc)
                & _corner_ok(max(d2, 0.0), s2 * s12, cc)):
            return False
    for r in range(qp[f], qp[f + 1]):
        i1, i2, i3 = qv[r, 1], qv[r, 2], qv[r, 3]
        x1, y1, x2, y2, x3, y3 = pts[i1, 0], pts[i1, 1], pts[i2, 0], pts[i2, 1], pts[i3, 0], pts[i3, 1]
        ux, uy = x2 - x1, y2 - y1
        vx, vy = x3 - x2, y3 - y2
        ex1, ey1 = x1 - px, y1 - py
        ex3, ey3 = x3 - px, y3 - py
        if not ((vx * -uy - vy * -ux > 0) & (ex1 * ey3 - ey1 * ex3 > 0) & (uy * ex1 - ux * ey1 > 0)
                & (ex3 * vy - ey3 * vx > 0)):
            return False
        s1, s3, s12, s23 = ex1 * ex1 + ey1 * ey1, ex3 * ex3 + ey3 * ey3, ux * ux + uy * uy, vx * vx + vy * vy
        if not (_corner_ok(ex1 * ex3 + ey1 * ey3, s1 * s3, cc) & _corner_ok(ux * ex1 + uy * ey1, s12 * s1, cc)
                & _corner_ok(ex3 * vx + ey3 * vy, s3 * s23, cc) & _corner_ok(vx * ux + vy * uy, s23 * s12, cc)):
            return False
    return True


@_kernel
def angle_choose(pts, nodes, free, sp, ring, sa, sb, frac, sap, rp, nbr, tp, tv, qp, qv, good, fl, keep, nearest, certify):
    """Stages 1 and 2 of the robust ``angle`` update (``angle.step``), fused per node.

    ``good`` is the per-node acceptance threshold; where ``keep`` (empty: nowhere) the angle position
    must also be no worse than staying, nor open its widest moving corner beyond staying's or 90 deg
    (:func:`_node_largest_rows`).  ``nearest``: stage 2 takes the candidate nearest the angle
    position among those scoring at least ``good`` (not where ``keep``), else the best.  Returns the
    chosen positions, their scores, whether the angle position was invalid and ``lazy``: where
    ``certify`` (per node, a score above ``good``; empty: nowhere; only without floors) says that a score
    at least that high leaves the node out of stage 4 anyway, a node not in ``keep`` whose angle position
    :func:`_node_certified` scores above it takes it without the exact score (``inf`` instead; the caller
    scores it only when the choice of the worst nodes could depend on it).
    """
    n = nodes.shape[0]
    new = np.empty((n, 2))
    best = np.empty(n)
    refused = np.zeros(n, np.bool_)
    lazy = np.zeros(n, np.bool_)
    buf = np.empty((_max_rows(nodes, tp, qp) + 1, _ROW_COLS))  # the node's fixed cell data (speed only)
    ub = np.empty((_max_spokes(nodes, sp), 3))  # the node's spoke unit vectors (_node_angle)
    for i in prange(n):
        f = nodes[i]
        ax, ay = _node_angle(pts, f, free, sp, ring, sa, sb, frac, sap, ub)
        kp = keep.shape[0] > 0 and keep[i]
        if (not kp and certify.shape[0] > 0 and fl.shape[0] == 0 and certify[i] < 0 and certify[i] > good[i]
                and _node_certified(pts, ax, ay, f, tp, tv, qp, qv, -certify[i])):
            new[i, 0], new[i, 1], best[i], lazy[i] = ax, ay, np.inf, True
            continue
        if kp:  # staying is scored too: gather the cells once, score A from them (the same number)
            _node_rows(pts, f, tp, tv, qp, qv, buf)
            s_a = _node_score_rows(ax, ay, f, tp, qp, buf, fl, -np.inf, -np.inf, np.inf, _NOT_STRICT)
        else:
            s_a = _node_score(pts, ax, ay, f, tp, tv, qp, qv, fl)
        refused[i] = s_a <= INVALID + 0.5
        cx, cy = pts[free[f], 0], pts[free[f], 1]
        take = s_a >= good[i]
        if not take and not kp:  # more candidates to score: gather the cells once
            _node_rows(pts, f, tp, tv, qp, qv, buf)
        if take and kp:
            take = s_a >= _node_score_rows(cx, cy, f, tp, qp, buf, fl, s_a, -np.inf, np.inf, _NOT_STRICT)
            if take:  # nor may its largest moving corner open beyond staying's (or a right angle)
                m_a = _node_largest_rows(ax, ay, f, tp, qp, buf)
                take = (m_a <= _node_largest_rows(cx, cy, f, tp, qp, buf)) | (m_a <= 0.0)
        if take:
            new[i, 0], new[i, 1], best[i] = ax, ay, s_a
            continue
        # candidates in the numpy order: A, L, (A + L) / 2, (A + C) / 2, C; the first best wins
        lx, ly = _node_ring_mean(pts, f, free, rp, nbr, False)
        bx, by, bs = ax, ay, s_a
        stuck = s_a <= INVALID + 0.5
        near_ok = nearest and not kp
        nx = ny = ns = 0.0
        nd = np.inf
        for k in range(4):
            if k == 0:
                px, py = lx, ly
            elif k == 1:
                px, py = 0.5 * (ax + lx), 0.5 * (ay + ly)
            elif k == 2:
                px, py = 0.5 * (ax + cx), 0.5 * (ay + cy)
            else:
                px, py = cx, cy
            # exact where it beats bs or, with near_ok, where it is good enough (a cut below good[i])
            cut = min(bs, good[i] - 1e-9) if near_ok else bs
            sk = _node_score_rows(px, py, f, tp, qp, buf, fl, cut, -np.inf, np.inf, _NOT_STRICT)
            if k < 3:
                stuck = stuck & (sk <= INVALID + 0.5)
            elif stuck:
                stuck = sk > INVALID + 0.5  # staying is valid
            if sk > bs:
                bx, by, bs = px, py, sk
            if near_ok and sk >= good[i]:
                dx, dy = px - ax, py - ay
                d2 = dx * dx + dy * dy
                if d2 < nd:  # np.argmin: the first nearest
                    nx, ny, ns, nd = px, py, sk, d2
        if nd < np.inf:
            bx, by, bs = nx, ny, ns
        if stuck:  # stage 3, ``first_valid``: the Laplacian move, halved until valid (else staying)
            dx, dy = lx - cx, ly - cy
            fr = 1.0
            for _ in range(7):
                px, py = cx + fr * dx, cy + fr * dy
                sk = _node_score_rows(px, py, f, tp, qp, buf, fl, INVALID + 0.5, -np.inf, np.inf, _NOT_STRICT)  # exact where valid
                if sk > INVALID + 0.5:
                    bx, by, bs = px, py, sk
                    break
                fr *= 0.5
        new[i, 0], new[i, 1], best[i] = bx, by, bs
    return new, best, refused, lazy


@njit(inline="always")
def _node_compass(px, py, f, tp, qp, buf, fl, r, iterations, band, directions, alo, ahi, strict, s_start):
    """``optimize``'s compass search for one node from (px, py), its cells in ``buf`` (:func:`_node_rows`),
    starting radius ``r``: (x, y, score).  ``s_start``: the score at (px, py) if the caller has it (the
    very number ``_node_score_rows`` gives), else NaN."""
    s0 = s_start
    if s0 != s0:
        s0 = _node_score_rows(px, py, f, tp, qp, buf, fl, -np.inf, -np.inf, np.inf, strict)
    lo0, hi0 = -np.inf, np.inf  # no band
    if band >= 0:
        lr, hr = _node_area_range_rows(px, py, f, tp, qp, buf)
        lo0 = max(band * lr, min(alo, lr))
        hi0 = min(hr / band, max(ahi, hr))
    for _ in range(iterations):
        bx = by = 0.0
        bs = -np.inf
        for c in range(directions.shape[0]):
            qx, qy = px + directions[c, 0] * r, py + directions[c, 1] * r
            # only a candidate above max(bs, s0) can change the outcome (the first best, moved to
            # only if it beats s0), so the others may be cut off early; a cell outside the area
            # band gives -inf at once (the outcome depends only on the candidates above s0, and
            # those are exact and within the band either way)
            sc = _node_score_rows(qx, qy, f, tp, qp, buf, fl, max(bs, s0), lo0, hi0, strict)
            if c == 0 or sc > bs:  # np.argmax: the first best
                bx, by, bs = qx, qy, sc
        if bs > s0:
            px, py, s0 = bx, by, bs
        else:
            r = 0.5 * r
    return px, py, s0


@_kernel
def compass(pts, x, nodes, tp, tv, qp, qv, scale, iterations, radius, band, directions, fl, alo, ahi, strict):
    """``optimize``: compass search per node, optionally within an area band (``band`` < 0: none)
    and the area limits ``alo``, ``ahi`` (-inf, inf: none); ``strict`` (per node, empty: none): the
    nodes that score their quad corners with ``_local.strict_quad`` where they also have triangles."""
    n = nodes.shape[0]
    out = np.empty((n, 2))
    s_out = np.empty(n)
    buf = np.empty((_max_rows(nodes, tp, qp) + 1, _ROW_COLS))
    for i in prange(n):
        f = nodes[i]
        _node_rows(pts, f, tp, tv, qp, qv, buf)
        st = strict.shape[0] > 0 and strict[i] and tp[f + 1] > tp[f]
        out[i, 0], out[i, 1], s_out[i] = _node_compass(x[i, 0], x[i, 1], f, tp, qp, buf, fl, radius * scale[i],
                                                       iterations, band, directions, alo, ahi, st, np.nan)
    return out, s_out


@_kernel
def angle_optimize(pts, x, nodes, free, rp, nbr, tp, tv, qp, qv, best, iterations, radius, band, directions, fl,
                   alo, ahi, strict, resume_iterations, resume_radius, resume_above):
    """Stage 4 of the robust ``angle`` update (``angle.step``) for its worst nodes, fused per node: the
    local scale (``local_scale``), the resume test of a quad-only node (staying scores above ``best``,
    its stage 1-2 score, and at least ``resume_above``: ``resume_iterations`` steps from there from
    ``resume_radius``; ``resume_iterations`` 0: never) and else the compass search from ``x`` (the
    stage 1-2 choice), ``iterations`` steps from ``radius``, ``strict`` as in :func:`compass`; ``best`` must
    be the exact score of ``x`` (the search starts from it, and from ``s_c`` when it resumes, unless the
    node is strict).  The same numbers as ``local_scale``, ``score`` and two ``compass`` calls."""
    n = nodes.shape[0]
    out = np.empty((n, 2))
    s_out = np.empty(n)
    buf = np.empty((_max_rows(nodes, tp, qp) + 1, _ROW_COLS))
    for i in prange(n):
        f = nodes[i]
        _node_rows(pts, f, tp, tv, qp, qv, buf)
        scale, _ = _node_ring_mean(pts, f, free, rp, nbr, True)
        px, py, its, r = x[i, 0], x[i, 1], iterations, radius * scale
        st = strict.shape[0] > 0 and strict[i] and tp[f + 1] > tp[f]
        # the search starts from the stage 1-2 choice, whose (non-strict) score is best[i]
        s_start = np.nan if st else best[i]
        if resume_iterations > 0 and tp[f + 1] == tp[f]:  # quads only
            cx, cy = pts[free[f], 0], pts[free[f], 1]
            s_c = _node_score_rows(cx, cy, f, tp, qp, buf, fl, -np.inf, -np.inf, np.inf, _NOT_STRICT)
            if (s_c > best[i]) & (s_c >= resume_above):
                px, py, its, r, s_start = cx, cy, resume_iterations, resume_radius * scale, s_c
        out[i, 0], out[i, 1], s_out[i] = _node_compass(px, py, f, tp, qp, buf, fl, r, its, band, directions,
                                                       alo, ahi, st, s_start)
    return out, s_out
