"""A node's local score from its incident cells, compiled: the per-node helpers of :mod:`._fastkernels`.

Each mirrors, operation for operation, the numpy code of :class:`._local.BlockGeometry` it replaces
(named in its docstring): ``_node_score`` (one candidate), ``_node_rows`` / ``_node_score_rows`` (a
node's fixed cell data gathered once, then many candidates scored from it), the area range and the
largest moving corner from the same rows, and ``_node_certified`` (a cheap exact test that a score is
above a threshold).  They are compiled into each kernel of :mod:`._fastkernels` that calls them, so the
kernels' disk cache is stamped with this file too (:mod:`._jitcache`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._local import _C30, INVALID, INVERTED_WEIGHT

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
# ``angle_choose`` inlines its one call a node of ``_node_angle`` and ``_node_score`` (issue 12): the
# calls' argument lists (some 60 words) and increfs were 15.8 of its 103 M instructions a pass on 100k
# triangles (1 thread), for some 0.3-0.8 s more CPU of a cold default compile of 12.6 s.
_helper = njit(error_model="numpy", nogil=True)


@_helper
def _node_score(pts, px, py, f, tp, tv, qp, qv, fl):
    """``BlockGeometry.score`` for one node (free index ``f``) at (px, py): ``_rows.score_rows``.

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
    h = buf.shape[0] - 1
    buf[h, 0] = 0.0  # the cell to start the next score with (see _node_score_rows)
    # the node's triangle and cell counts and first rows (floats: exact below 2**53), for _node_score_rows
    buf[h, 1], buf[h, 2], buf[h, 3], buf[h, 4] = tp[f + 1] - tp[f], k, tp[f], qp[f]


@_helper
def _node_score_rows(px, py, buf, fl, cut, lo0, hi0, strict):
    """:func:`_node_score` from the rows :func:`_node_rows` put in ``buf`` for a node (same numbers; the
    node's row counts and first rows are in ``buf``'s last row too: fewer arguments to pass per call).

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
    area (``_rows._row_area``, from the same products as the score) is outside
    [lo0, hi0], as :meth:`BlockGeometry.banded_score` gives, found in the same pass over the cells.

    ``strict``: the quad corners score ``_local.strict_quad`` (the same operations; ``compass`` asks
    for it at its ``strict`` nodes that also have triangles).
    """
    best = np.inf
    bad = 0.0
    floors = fl.shape[0] > 0
    banded = not ((lo0 == -np.inf) & (hi0 == np.inf))  # (a NaN bound: banded, every cell outside)
    cut_invalid = cut >= INVALID - 1.0
    hint = buf.shape[0] - 1
    nt, m, t0, q0 = int(buf[hint, 1]), int(buf[hint, 2]), int(buf[hint, 3]), int(buf[hint, 4])
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
                a = -0.5 * cr  # _rows._row_area exactly (triangles): fx2 = -(x2 - px), fy2 = -(y2 - py)
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
                a2 = (x1 + ux - px) * (y3 - y1) - (y1 + uy - py) * (x3 - x1)  # twice _rows._row_area (quads)
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
    """``BlockGeometry.area_range`` for one node: ``_rows._row_area``, from the rows of
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
