"""The local max-min-angle optimization (compass search) of :func:`optimize`, shared by ``angle``
(stage 4) and ``optimization``: numpy on a :class:`._local.BlockGeometry`, or one compiled loop per
node on a :class:`._fastcalls.FastGeometry` (moved out of :mod:`._local`, which re-exports it).

The numpy search prunes as the compiled one does (:class:`_Pruned`): a candidate whose few most
critical corners already score at or below the node's current score cannot be moved to, so only the
other candidates are scored in full -- the same positions and scores as scoring all eight.
"""

from __future__ import annotations

import numpy as np

from . import _fastcalls
from ._rows import INVALID, _quad_core, _tri_core, finish_scores, score_rows, strict_quad

#: Rows (incident cells) per node and kind scored first at every candidate (:class:`_Pruned`): the
#: node's lowest at the start of the search.  Measured on stage 4 of 100k random triangles (passes
#: 3-5): the share of candidates then left to score in full, 1 row 51 %, 2 rows 26 %, 3 rows 18 %;
#: the search's instructions 2 rows 353 M, 3 rows 331 M, 4 rows more; CPU 3 rows 4-16 % below 2.
PRUNE_ROWS = 3

#: Smallest number of nodes searched with pruning (fewer: every candidate scored in full, fewer numpy
#: calls); the same results either way.
PRUNE_MIN_NODES = 16


def optimize(
    geom,  # a _local.BlockGeometry or a _fastcalls.FastGeometry
    x: np.ndarray,
    scale: np.ndarray,
    iterations: int = 3,
    radius: float = 0.25,
    area_band: float | None = None,
    area_limits: tuple[float, float] | None = None,
    strict: np.ndarray | None = None,
    start_score: np.ndarray | None = None,
    prune: bool = True,
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
    would happily shrink a cell to a sliver of good shape.  ``area_limits``
    (lo, hi), with ``area_band``, also keeps that smallest cell at least at
    ``min(lo, its start area)`` and the largest at most ``max(hi, its start
    area)`` (the default ``angle`` passes the mesh's area range at the start
    of the pass).  ``strict`` (per node, bool): those nodes score their quad corners with
    :func:`strict_quad` where they also have triangles (see ``angle.step``'s ``strict_quads``).
    ``iterations`` and ``radius`` may also be one value per node (numpy kernels only).
    ``start_score``: the score at ``x`` if the caller has it (numpy kernels, without ``strict``: the
    same numbers the search would compute).  ``prune`` False: the numpy search scores every
    candidate in full (the same results; for tests).  Returns (positions, scores).
    """
    if isinstance(geom, _fastcalls.FastGeometry):  # the same search, one compiled loop per node
        return geom.compass(x, scale, iterations, radius, area_band, _COMPASS, area_limits, strict)
    if start_score is None or (strict is not None and np.any(strict)):
        s0 = geom.score(x, strict=strict)
    else:
        s0 = np.array(start_score, dtype=np.float64)
    lo0 = hi0 = None
    if area_band is not None:
        lr, hr = geom.area_range(x)
        lo0, hi0 = area_band * lr, hr / area_band
        if area_limits is not None:
            lo0 = np.maximum(lo0, np.minimum(area_limits[0], lr))
            hi0 = np.minimum(hi0, np.maximum(area_limits[1], hr))
    r = radius * scale

    def stepper(g, x, strict, lo0, hi0):
        if prune:  # (called inside the errstate below)
            return _Pruned(g, x, strict, lo0, hi0, bound=g.n >= PRUNE_MIN_NODES).step
        return lambda x, s0, r: _compass_step(g, x, s0, r, area_band, lo0, hi0, strict)

    if np.ndim(iterations) == 0:
        if not prune:  # (BlockGeometry.score sets numpy's errors itself)
            for _ in range(iterations):
                x, s0, r = _compass_step(geom, x, s0, r, area_band, lo0, hi0, strict)
            return x, s0
        with np.errstate(divide="ignore", invalid="ignore"):
            step = stepper(geom, x, strict, lo0, hi0) if iterations > 0 else None
            for _ in range(iterations):
                x, s0, r = step(x, s0, r)
        return x, s0
    # one number of steps per node: all nodes while every one still steps, then only the ones that do
    # (the geometry restricted once per change of that set; every node's numbers are its own)
    its = np.asarray(iterations)
    x, s0, r = np.array(x, dtype=np.float64), np.array(s0), np.array(r, dtype=np.float64)  # written in place below
    with np.errstate(divide="ignore", invalid="ignore"):
        _varying(its, x, s0, r, geom, stepper, lo0, hi0, strict)
    return x, s0


def _varying(its, x, s0, r, g, stepper, lo0, hi0, strict):
    """:func:`optimize`'s loop with one number of steps per node on geometry ``g`` (``x``, ``s0``, ``r`` written
    in place; ``lo0``, ``hi0``: the area band's bounds, or None)."""
    act = step = None  # the nodes still stepping (None: all), the stepper of their geometry
    for k in range(int(its.max(initial=0))):
        on = its if act is None else its[act]
        if not (on > k).all():
            sub = np.flatnonzero(on > k)
            act = sub if act is None else act[sub]
            g, step = g.restrict(sub), None
            if lo0 is not None:
                lo0, hi0 = lo0[sub], hi0[sub]
            strict = None if strict is None else strict[sub]
        if step is None:
            step = stepper(g, x if act is None else x[act], strict, lo0, hi0)
        if act is None:
            x[...], s0[...], r[...] = step(x, s0, r)
        else:
            x[act], s0[act], r[act] = step(x[act], s0[act], r[act])


def _compass_step(geom, x, s0, r, area_band, lo0, hi0, strict):
    """One step of :func:`optimize`'s compass search: (positions, scores, radii)."""
    cands = x[None] + _COMPASS[:, None, :] * r[None, :, None]
    sc = geom.score(cands, strict=strict) if area_band is None else geom.banded_score(cands, lo0, hi0, strict)
    return _move(x, s0, r, cands, sc)


def _move(x, s0, r, cands, sc):
    """The step to the first best candidate where it beats ``s0``, else the radius halved."""
    k = np.argmax(sc, axis=0)
    idx = np.arange(x.shape[0])
    sk = sc[k, idx]
    better = sk > s0
    x = np.where(better[:, None], cands[k, idx], x)
    s0 = np.where(better, sk, s0)
    r = np.where(better, r, 0.5 * r)
    return x, s0, r


class _Pruned:
    """:func:`_compass_step` on one geometry that scores in full only the candidates that could win.

    A candidate's score is the minimum of its node's rows' (incident cells') values where every row
    is valid, and else an invalid score (below -3) or -inf (outside the area band): the smallest raw
    value (:func:`._rows._tri_core`, :func:`._rows._quad_core`: no validity test) of any of its rows
    is at least the score, or the candidate is invalid.  Where that bound of the :data:`PRUNE_ROWS`
    rows of each kind that were lowest at the start is at or below the node's current score ``s0``,
    itself valid, the candidate cannot be moved to (a step needs a score above ``s0``) and counts as
    -inf: the first best candidate, and whether it beats ``s0``, stay those of the full scores,
    computed for the other candidates with :meth:`._local.BlockGeometry.score`'s operations (bit for
    bit; numpy methods rather than functions, and few calls: most blocks are small).
    """

    def __init__(self, geom, x, strict, lo0, hi0, bound=True):
        self.lo0, self.hi0, self.n = lo0, hi0, geom.n
        self.parts = []  # per kind of row: (quads, first row, row count, packed columns, number of columns)
        self.a = []  # per kind: (quads, its nodes or None: all, critical rows' columns, strict or None)
        self.q_strict = None  # per node: its quad rows score strict_quad (as in BlockGeometry.score)
        if strict is not None and strict.any():
            self.q_strict = strict & (geom._starts("t_rel")[1] > 0)
        for quads, rel in ((False, geom.t_rel), (True, geom.q_rel)):
            if not rel.shape[0]:
                continue
            first, cnt = geom._starts("q_rel" if quads else "t_rel")
            cols, fl = geom.columns(quads)
            packed = _packed(geom, quads, cols, fl)
            self.parts.append((quads, first, cnt, packed, len(cols)))
            if not bound:  # no bounds: every candidate scored (with this class's fewer numpy calls)
                continue
            v = _raw(quads, x[:, 0].take(rel), x[:, 1].take(rel), cols)
            if quads and self.q_strict is not None:
                v = np.where(self.q_strict.take(rel), strict_quad(v), v)
            nodes, crit = _lowest(v, rel, first, cnt)  # (PRUNE_ROWS, nodes)
            g = packed.take(crit.ravel(), axis=0).T.copy().reshape(packed.shape[1], PRUNE_ROWS, 1, -1)
            sr = None if not quads or self.q_strict is None else self.q_strict[nodes][None, None]
            self.a.append((quads, None if nodes.shape[0] == self.n else nodes, tuple(g[: len(cols)]), sr))

    def step(self, x, s0, r):
        """One step: (positions, scores, radii), as :func:`_compass_step` (numpy's errors: the caller's)."""
        n = self.n
        x0, y0 = x[:, 0], x[:, 1]
        cx = x0 + _DX * r  # the candidates (8, n): as cands[..., 0]
        cy = y0 + _DY * r
        ub = None
        for quads, nodes, cols, sr in self.a:  # the bounds from the critical rows
            v = _raw(quads, cx, cy, cols) if nodes is None else _raw(quads, cx[:, nodes], cy[:, nodes], cols)
            if sr is not None:  # (rows, 8, nodes)
                v = np.where(sr, strict_quad(v), v)
            b = v[0]
            for j in range(1, PRUNE_ROWS):
                np.minimum(b, v[j], out=b)
            if nodes is None:
                ub = b if ub is None else np.minimum(ub, b, out=ub)
            else:
                if ub is None:
                    ub = np.empty(cx.shape)
                    ub.fill(np.inf)
                ub[:, nodes] = np.minimum(ub[:, nodes], b)
        if ub is None:
            p = _arange(8 * n)
        else:
            # no bound (NaN) where s0 is invalid: there every candidate is scored
            live = ub <= np.where(s0 > INVALID, s0, np.nan)
            p = np.logical_not(live, out=live).ravel().nonzero()[0]
        sc = np.empty(cx.shape)
        sc.fill(-np.inf)
        if p.shape[0]:
            sc.ravel()[p] = self._scores(cx.ravel().take(p), cy.ravel().take(p), p % n)
        # the first best candidate, moved to where it beats s0 (_move's numbers)
        f = sc.argmax(axis=0)
        f *= n
        f += _arange(n)
        sk = sc.ravel().take(f)
        better = sk > s0
        out = np.empty_like(x)
        out[:, 0] = np.where(better, cx.ravel().take(f), x0)
        out[:, 1] = np.where(better, cy.ravel().take(f), y0)
        return out, np.where(better, sk, s0), np.where(better, r, 0.5 * r)

    def _scores(self, px, py, node):
        """The exact (banded) score of every (position, node) pair: ``BlockGeometry.score``'s numbers, from the
        same scorer over the pairs' rows (:func:`._rows.score_rows`)."""
        m = node.shape[0]
        best = bad = out_band = None
        for quads, first, cnt, packed, ncol in self.parts:
            c = cnt.take(node)
            has = None if len(self.parts) == 1 else c.nonzero()[0]  # one kind: every node has rows
            if has is not None:
                if not has.shape[0]:
                    continue
                c = c.take(has)
            ends = c.cumsum()
            starts = ends - c
            nd = node if has is None else node.take(has)
            rows = (first.take(nd) - starts).repeat(c)
            rows += _arange(rows.shape[0])
            cols = packed.take(rows, axis=0).T.copy()  # (columns, rows), each column contiguous
            pxr = (px if has is None else px.take(has)).repeat(c)
            pyr = (py if has is None else py.take(has)).repeat(c)
            fl = tuple(cols[ncol:]) if cols.shape[0] > ncol else None
            sr = self.q_strict.take(nd).repeat(c) if quads and self.q_strict is not None else None
            band = None if self.lo0 is None else (self.lo0.take(nd), self.hi0.take(nd))
            low, w, out = score_rows(quads, pxr, pyr, tuple(cols[:ncol]), fl, c, starts, sr, band)
            if has is None:
                best = low if best is None else np.minimum(best, low, out=best)
            else:
                if best is None:
                    best = np.empty(m)
                    best.fill(np.inf)
                best[has] = np.minimum(best.take(has), low)
            if w is not None:
                if has is not None:
                    full = np.zeros(m)
                    full[has] = w
                    w = full
                bad = w if bad is None else bad + w
            if out is not None:
                if out_band is None:
                    out_band = np.zeros(m, bool)
                out_band[out.nonzero()[0] if has is None else has[out]] = True
        return finish_scores(best, bad, out_band)


def _packed(geom, quads, cols, fl):
    """A geometry's row columns and floors as one (rows, columns) array (kept with the geometry): one
    gather of a row's whole record instead of one per column (about a third of the instructions)."""
    key = "_packed_q" if quads else "_packed_t"
    hit = geom.__dict__.get(key)
    if hit is None:
        hit = np.empty((cols[0].shape[0], len(cols) + len(fl or ())))
        for j, c in enumerate(cols + (fl or ())):
            hit[:, j] = c
        geom.__dict__[key] = hit
    return hit


def _lowest(v, rel, first, cnt):
    """The nodes with rows (of one kind: ``rel``, each node's rows ``first[i]:first[i] + cnt[i]``)
    and their PRUNE_ROWS lowest rows by ``v`` (NaN counts as +inf), (PRUNE_ROWS, nodes); a node's
    last again where it has fewer."""
    nodes = np.flatnonzero(cnt)
    st = first.take(nodes)
    o = None
    if st.shape[0] > 1 and not (st[1:] > st[:-1]).all():  # reduceat needs the rows' order
        o = st.argsort(kind="stable")
        nodes, st = nodes.take(o), st.take(o)
    last = st + cnt.take(nodes) - 1
    v = np.where(v == v, v, np.inf)  # a copy, NaN -> inf
    idx = np.arange(v.shape[0])
    best = np.full(cnt.shape[0], np.inf)
    crit = np.empty((PRUNE_ROWS, nodes.shape[0]), np.intp)
    for j in range(PRUNE_ROWS):
        best[nodes] = np.minimum.reduceat(v, st)
        p = np.minimum.reduceat(np.where(v == best.take(rel), idx, v.shape[0]), st)
        crit[j] = p = np.minimum(p, last, out=p)  # fewer rows than PRUNE_ROWS: its last again
        v[p] = np.inf
    if o is not None:  # back to the nodes' order
        nodes[o], crit[:, o] = nodes.copy(), crit.copy()
    return nodes, crit


def _raw(quads, px, py, cols):
    """Rows' raw values (:func:`._rows._tri_core` / :func:`._rows._quad_core`)."""
    if quads:
        return np.negative(_quad_core(px, py, cols)[0])
    return _tri_core(px, py, cols)[0]


_COMPASS = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)
_DX, _DY = _COMPASS[:, 0][:, None].copy(), _COMPASS[:, 1][:, None].copy()  # (8, 1) each
_ARANGE = np.arange(1 << 16)


def _arange(n: int) -> np.ndarray:
    """``np.arange(n)`` (a view of a kept one, up to 65536)."""
    return _ARANGE[:n] if n <= _ARANGE.shape[0] else np.arange(n)
