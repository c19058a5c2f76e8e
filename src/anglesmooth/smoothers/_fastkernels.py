"""The numba kernels behind :mod:`._fast` (imported only when they are used).

Each per-node helper (``_node_*``) mirrors, operation for operation, the numpy
code it replaces in :mod:`._local`, :mod:`._choose` or :mod:`._worst` (named in its docstring);
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

from ._local import INVALID
from ._nodescore import (  # the per-node score helpers (see that module)
    _NOT_STRICT,
    _ROW_COLS,
    _helper,
    _max_rows,
    _node_area_range_rows,
    _node_certified,
    _node_largest_rows,
    _node_rows,
    _node_score,
    _node_score_rows,
)
# stage 5's screen and area range, named with the others (warm-up, estimate)
from ._patchkernels import RANGE_CHUNK  # noqa: F401
from ._patchkernels import _chunk_ranges, _fold_range, _screen_below  # noqa: F401

# error_model="numpy": x / 0 gives inf / NaN as in numpy instead of raising; no fastmath, so no
# reassociation or fused multiply-adds and the same rounding as numpy
_OPTS = {"cache": True, "error_model": "numpy", "parallel": False, "nogil": True}
_TWO_PI = 2 * np.pi


def _kernel(fn):
    """``njit`` with on-disk caching, or without it where numba finds no writable cache location
    (read-only install and home directory): the kernels then compile in every process."""
    try:
        return njit(**_OPTS)(fn)
    except RuntimeError:
        return njit(**{**_OPTS, "cache": False})(fn)


@_kernel
def score(pts, X, nodes, tp, tv, qp, qv, fl):
    K, n = X.shape[0], X.shape[1]
    out = np.empty((K, n))
    buf = np.empty((_max_rows(nodes, tp, qp) + 1, _ROW_COLS))
    for i in prange(n):
        f = nodes[i]
        _node_rows(pts, f, tp, tv, qp, qv, buf)
        for k in range(K):
            out[k, i] = _node_score_rows(X[k, i, 0], X[k, i, 1], buf, fl, -np.inf, -np.inf, np.inf, _NOT_STRICT)
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


#: inlined copies for ``angle_choose`` (their only call site there, once per node): a called helper
#: takes its arrays as some 60 words of arguments and increfs them; inlined, ``angle_choose`` runs
#: without that call overhead (``_node_score`` has no other caller; ``angle_target`` calls ``_node_angle``)
_node_angle_inline = njit(inline="always")(_node_angle.py_func)
_node_score_inline = njit(inline="always")(_node_score.py_func)


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


@_kernel
def angle_choose(pts, nodes, free, sp, ring, sa, sb, frac, sap, rp, nbr, tp, tv, qp, qv, good, fl, flnode, keep, nearest,
                 certify, cap):
    """Stages 1 and 2 of the robust ``angle`` update (``angle.step``; numpy: ``_choose.chooser``), fused per node.

    ``good`` is the per-node acceptance threshold; where ``keep`` (empty: nowhere) the angle position
    must also be no worse than staying, nor open its widest moving corner beyond staying's or 90 deg
    (:func:`_node_largest_rows`).  ``nearest``: stage 2 takes the candidate nearest the angle
    position among those scoring at least ``good`` (not where ``keep``), else the best.  Returns the
    chosen positions, their scores, whether the angle position was invalid and ``lazy``: where
    ``certify`` (per node, a score above ``good``; empty: nowhere; only without floors) says that a score
    at least that high leaves the node out of stage 4 anyway, a node not in ``keep`` whose angle position
    :func:`_node_certified` scores above it takes it without the exact score (``inf`` instead; the caller
    scores it only when the choice of the worst nodes could depend on it).  ``flnode`` (per free node;
    empty: every node): the nodes with a nonzero floor in ``fl``; the others score the angle position
    without reading ``fl`` (a zero floor never fails: the same scores, 24-72 MB a pass less to read
    on 1M triangles).  ``cap`` (``keep_max``; inf: none): where ``keep``, stage 2 takes no candidate but
    staying that opens a moving corner beyond ``max(cap, staying's widest)`` (``-cos``).
    """
    n = nodes.shape[0]
    new = np.empty((n, 2))
    best = np.empty(n)
    refused = np.zeros(n, np.bool_)
    lazy = np.zeros(n, np.bool_)
    buf = np.empty((_max_rows(nodes, tp, qp) + 1, _ROW_COLS))  # the node's fixed cell data (speed only)
    ub = np.empty((_max_spokes(nodes, sp), 3))  # the node's spoke unit vectors (_node_angle)
    nofl = np.zeros((0, 0))
    for i in prange(n):
        f = nodes[i]
        ax, ay = _node_angle_inline(pts, f, free, sp, ring, sa, sb, frac, sap, ub)
        kp = keep.shape[0] > 0 and keep[i]
        if (not kp and certify.shape[0] > 0 and fl.shape[0] == 0 and certify[i] < 0 and certify[i] > good[i]
                and _node_certified(pts, ax, ay, f, tp, tv, qp, qv, -certify[i])):
            new[i, 0], new[i, 1], best[i], lazy[i] = ax, ay, np.inf, True
            continue
        if kp:  # staying is scored too: gather the cells once, score A from them (the same number)
            _node_rows(pts, f, tp, tv, qp, qv, buf)
            s_a = _node_score_rows(ax, ay, buf, fl, -np.inf, -np.inf, np.inf, _NOT_STRICT)
        else:
            s_a = _node_score_inline(pts, ax, ay, f, tp, tv, qp, qv, fl if flnode.shape[0] == 0 or flnode[f] else nofl)
        refused[i] = s_a <= INVALID + 0.5
        cx, cy = pts[free[f], 0], pts[free[f], 1]
        take = s_a >= good[i]
        if not take and not kp:  # more candidates to score: gather the cells once
            _node_rows(pts, f, tp, tv, qp, qv, buf)
        if take and kp:
            take = s_a >= _node_score_rows(cx, cy, buf, fl, s_a, -np.inf, np.inf, _NOT_STRICT)
            if take:  # nor may its largest moving corner open beyond staying's (or a right angle)
                m_a = _node_largest_rows(ax, ay, f, tp, qp, buf)
                take = (m_a <= _node_largest_rows(cx, cy, f, tp, qp, buf)) | (m_a <= 0.0)
        if take:
            new[i, 0], new[i, 1], best[i] = ax, ay, s_a
            continue
        # candidates in the numpy order: A, L, (A + L) / 2, (A + C) / 2, C; the first best wins
        lx, ly = _node_ring_mean(pts, f, free, rp, nbr, False)
        bx, by, bs = ax, ay, s_a
        held = kp and cap < np.inf  # keep_max: candidates that open a corner beyond cap_i are left out
        cap_i = np.inf
        if held:
            l_c = _node_largest_rows(cx, cy, f, tp, qp, buf)
            cap_i = l_c if (l_c != l_c or l_c > cap) else cap  # np.maximum(l_c, cap)
            if not (_node_largest_rows(ax, ay, f, tp, qp, buf) <= cap_i):
                bs = -np.inf
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
            sk = _node_score_rows(px, py, buf, fl, cut, -np.inf, np.inf, _NOT_STRICT)
            if k < 3:
                stuck = stuck & (sk <= INVALID + 0.5)
            elif stuck:
                stuck = sk > INVALID + 0.5  # staying is valid
            if sk > bs and not (held and k < 3 and not (_node_largest_rows(px, py, f, tp, qp, buf) <= cap_i)):
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
                sk = _node_score_rows(px, py, buf, fl, INVALID + 0.5, -np.inf, np.inf, _NOT_STRICT)  # exact where valid
                if sk > INVALID + 0.5:
                    bx, by, bs = px, py, sk
                    break
                fr *= 0.5
        new[i, 0], new[i, 1], best[i] = bx, by, bs
    return new, best, refused, lazy


@njit(inline="always")
def _node_compass(px, py, f, tp, qp, buf, fl, r, iterations, band, directions, alo, ahi, strict, s_start, cap):
    """``optimize``'s compass search for one node from (px, py), its cells in ``buf`` (:func:`_node_rows`),
    starting radius ``r``: (x, y, score).  ``s_start``: the score at (px, py) if the caller has it (the
    very number ``_node_score_rows`` gives), else NaN.  ``cap`` (inf: none; then ``s_start`` must be NaN):
    a position that opens a corner beyond it (:func:`_node_largest_rows`) scores -inf (``_keepmax.Capped``)."""
    s0 = s_start
    if s0 != s0:
        s0 = _node_score_rows(px, py, buf, fl, -np.inf, -np.inf, np.inf, strict)
        if cap < np.inf and not (_node_largest_rows(px, py, f, tp, qp, buf) <= cap):
            s0 = -np.inf
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
            sc = _node_score_rows(qx, qy, buf, fl, max(bs, s0), lo0, hi0, strict)
            # (capped: only a candidate that could win is tested; the others cannot move the node either way)
            if cap < np.inf and sc > max(bs, s0) and not (_node_largest_rows(qx, qy, f, tp, qp, buf) <= cap):
                sc = -np.inf
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
                                                       iterations, band, directions, alo, ahi, st, np.nan, np.inf)
    return out, s_out


@_kernel
def angle_optimize(pts, x, nodes, free, rp, nbr, tp, tv, qp, qv, best, iterations, radius, band, directions, fl,
                   alo, ahi, strict, resume_iterations, resume_radius, resume_above, keep, cap, s_min):
    """Stage 4 of the robust ``angle`` update (``angle.step``; numpy: ``_worst``) for its worst nodes, fused per node: the
    local scale (``local_scale``), the resume test of a quad-only node (staying scores above ``best``,
    its stage 1-2 score, and at least ``resume_above``: ``resume_iterations`` steps from there from
    ``resume_radius``; ``resume_iterations`` 0: never) and else the compass search from ``x`` (the
    stage 1-2 choice), ``iterations`` steps from ``radius``, ``strict`` as in :func:`compass`; ``best`` must
    be the exact score of ``x`` (the search starts from it, and from ``s_c`` when it resumes, unless the
    node is strict).  The same numbers as ``local_scale``, ``score`` and two ``compass`` calls.  ``keep``
    (per node, empty: none) and ``cap`` (inf: none): ``keep_max``, a node of ``keep`` whose result opens a
    moving corner beyond ``cap_i = max(cap, its widest at its current position)`` (``-cos``) searches again
    from the same start with positions beyond ``cap_i`` refused, and keeps ``x`` where even that result is.
    ``s_min`` (-inf: none): ``keep_min``, then, on that result: a strict node with both triangles and quads whose
    (plain) score there is below ``s_min`` keeps ``x`` (``_worst.hold``'s order and numbers)."""
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
            s_c = _node_score_rows(cx, cy, buf, fl, -np.inf, -np.inf, np.inf, _NOT_STRICT)
            if (s_c > best[i]) & (s_c >= resume_above):
                px, py, its, r, s_start = cx, cy, resume_iterations, resume_radius * scale, s_c
        out[i, 0], out[i, 1], s_out[i] = _node_compass(px, py, f, tp, qp, buf, fl, r, its, band, directions,
                                                       alo, ahi, st, s_start, np.inf)
        if keep.shape[0] > 0 and keep[i] and cap < np.inf:  # keep_max
            l_c = _node_largest_rows(pts[free[f], 0], pts[free[f], 1], f, tp, qp, buf)
            cap_i = l_c if (l_c != l_c or l_c > cap) else cap  # np.maximum(l_c, cap)
            if not (_node_largest_rows(out[i, 0], out[i, 1], f, tp, qp, buf) <= cap_i):
                # the search again from the same start, refusing every position beyond cap_i
                qx, qy, qs = _node_compass(px, py, f, tp, qp, buf, fl, r, its, band, directions, alo, ahi, st, np.nan,
                                           cap_i)
                if _node_largest_rows(qx, qy, f, tp, qp, buf) <= cap_i:
                    out[i, 0], out[i, 1], s_out[i] = qx, qy, qs
                else:
                    out[i, 0], out[i, 1], s_out[i] = x[i, 0], x[i, 1], best[i]
        if st and s_min > -np.inf and qp[f + 1] > qp[f]:  # keep_min, on keep_max's result
            if _node_score_rows(out[i, 0], out[i, 1], buf, fl, -np.inf, -np.inf, np.inf, _NOT_STRICT) < s_min:
                out[i, 0], out[i, 1], s_out[i] = x[i, 0], x[i, 1], best[i]
    return out, s_out
