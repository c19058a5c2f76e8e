"""The row layout of a block's incident cells, shared by the numpy kernels of :mod:`._local`.

Every incident cell of a block's node is one *row*; the rows are grouped by the number of rows per
node (:class:`_Rows`) so that a per-node minimum is a few vectorized operations, and the layout
(which depends on the topology only) is built once per block (:func:`_layout`).  :func:`strict_quad`
rescales the quad rows' scores where the optimization asks for it.
"""

from __future__ import annotations

import math

import numpy as np

from ..topology import Block, Topology
from ._blocks import INTP_MAX

_CHUNK = 16384  # rows per kernel call: the temporaries of one call stay in the L2 cache
_SMALL = 4096  # up to this many rows, one ragged chunk (see _Rows)
#: the same for a block's subset (:meth:`BlockGeometry.restrict`: the nodes that choose among five
#: candidates, the few that get optimized, the keep test): up to this many rows one ragged chunk, one
#: numpy call per operation instead of one per distinct row count (measured, CPU per default pass:
#: 100k quads 77 -> 68 ms; 100k and 1M triangles, 1M quads within 2 %; 16x this is 5-13 % slower at 1M)
_SMALL_SUBSET = _CHUNK
#: rows of a regular chunk of a layout (:class:`_Rows`: nodes with the same number of rows), which every score
#: of the block's nodes reads in one go: fewer, larger numpy calls.  100k random quads, numpy, a default pass:
#: 331.0 M instructions with _CHUNK, 327.7 with 2 x, 321.8 with this; CPU of a default over a literal pass
#: (medians of interleaved runs, NUMBA_NUM_THREADS=1, a loaded machine) 100k quads 2.59 / 2.58 / 2.51 and
#: 2.47 (2 x) / 2.43, 1M quads 2.19 / 2.08 / 2.04 (one earlier run of 6 had this one at 2.62 against 2.48)
_LAYOUT_CHUNK = 4 * _CHUNK
#: a group of nodes with the same number of rows that has fewer rows than this joins the ragged chunks (see
#: _Rows; 100k random triangles, numpy: the score at every node's angle position 60.1 M instructions a pass with
#: none, 45.9 with 2048, 40.2 with 8192, 39.8 with this)
_MERGE = _CHUNK


class _Rows:
    """Rows (incident cells) of the block's nodes, grouped by the number of rows per node.

    ``perm`` reorders the input rows so that the nodes with ``d`` rows are
    contiguous (in node order, each node's rows in their original order); the
    rows of such a group then reshape to (nodes, d) and reduce per node with
    ``d - 1`` vectorized minimums instead of a ``reduceat`` (which pays per
    segment).  ``chunks`` are (r0, r1, nodes, d) over the reordered rows, at
    most about ``_LAYOUT_CHUNK`` rows each (ragged ones ``_CHUNK``).

    A set of at most ``_SMALL`` rows (the small blocks of a small mesh, the few
    nodes that get optimized) is one *ragged* chunk instead, ``d`` then being
    the array of row counts per node: one numpy call per operation rather than
    one per distinct count, where the calls' overhead outweighs their work.
    In a larger set, the groups of fewer than ``_MERGE`` rows come last, their
    nodes in node order, in ragged chunks of about ``_CHUNK`` rows: a chunk
    costs every operation's call overhead (about 60 numpy calls a score), more
    than a ``reduceat`` over its nodes, and most groups are small (100k random
    triangles: about ten per block, half of them under 1000 rows).
    """

    def __init__(self, rel: np.ndarray, n: int, small: int = _SMALL):
        counts = np.bincount(rel, minlength=n)
        m = rel.shape[0]
        if m <= small:
            self.perm = np.argsort(rel, kind="stable")
            nodes = np.flatnonzero(counts)
            self.chunks = [(0, m, nodes, counts[nodes])] if m else []
            return
        # groups of nodes by row count, each in regular chunks; the groups of fewer than _MERGE rows last,
        # together in ragged chunks (see the class docstring)
        cnum = np.bincount(counts)  # nodes per row count
        rank = np.arange(cnum.shape[0], dtype=np.int64)
        tail = (cnum * rank < _MERGE) & (cnum > 0)
        tail[0] = False
        rank[tail] = cnum.shape[0]  # after every regular group, in node order among themselves
        if np.all(rel[1:] >= rel[:-1]):
            offs = np.cumsum(counts) - counts
            nodes = np.argsort(rank[counts], kind="stable")
            nodes = nodes[counts[nodes] > 0]
            c = counts[nodes]
            self.perm = np.repeat(offs[nodes] - (np.cumsum(c) - c), c) + np.arange(m)
        else:
            key = rank[counts[rel]] * np.int64(n) + rel
            if np.all(key[1:] >= key[:-1]):  # already grouped (a restricted layout): what lexsort gives
                self.perm = np.arange(m)
            else:
                self.perm = np.lexsort((rel, rank[counts[rel]]))
            first = np.ones(m, bool)
            first[1:] = rel[self.perm][1:] != rel[self.perm][:-1]
            nodes = rel[self.perm][first]
            c = counts[nodes]
        self.chunks = []
        n_reg = int(np.count_nonzero(~tail[c]))  # nodes in regular groups (first)
        bounds = np.concatenate([[0], np.flatnonzero(np.diff(c[:n_reg])) + 1, [n_reg]]).tolist()
        r = 0
        for g0, g1 in zip(bounds[:-1], bounds[1:]):
            if g1 <= g0:
                continue
            d = int(c[g0])
            step = max(1, _LAYOUT_CHUNK // d)
            for k0 in range(g0, g1, step):
                k1 = min(k0 + step, g1)
                self.chunks.append((r, r + (k1 - k0) * d, nodes[k0:k1], d))
                r += (k1 - k0) * d
        if n_reg < c.shape[0]:  # the ragged chunks, of about _CHUNK rows each
            tc = c[n_reg:]
            ends = np.cumsum(tc)
            cuts = np.unique(np.concatenate([[0], np.searchsorted(ends, np.arange(_CHUNK, ends[-1], _CHUNK)) + 1,
                                             [tc.shape[0]]])).tolist()
            for k0, k1 in zip(cuts[:-1], cuts[1:]):
                r1 = r + int(tc[k0:k1].sum())
                self.chunks.append((r, r1, nodes[n_reg + k0:n_reg + k1], tc[k0:k1]))
                r = r1


def _rowreduce(vals: np.ndarray, d, ufunc=np.minimum, starts=None) -> np.ndarray:
    """``ufunc``-reduce every ``d`` consecutive values along the last axis: (..., m * d) -> (..., m).

    ``d`` may also be an array of run lengths (a ragged chunk of :class:`_Rows`; ``starts``: their
    ``np.cumsum(d) - d`` if the caller has it).
    """
    if not isinstance(d, int):
        return ufunc.reduceat(vals, np.cumsum(d) - d if starts is None else starts, axis=-1)
    w = vals.reshape(vals.shape[:-1] + (-1, d))
    out = w[..., 0].copy()
    for j in range(1, d):
        ufunc(out, w[..., j], out=out)
    return out


def _gather_xy(points: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The x and y coordinates of the points ``idx`` as two contiguous arrays: one gather of the rows, one
    transposing copy.  A strided column view (``np.take(points, idx, axis=0)[:, 0]``) costs every later
    operation that reads it numpy's scalar loop instead of its SIMD one (stages 1-3 of the default pass
    read these columns many times; 100k triangles, numpy: 225 -> 205 M instructions a pass without
    stages 4-5); two gathers from the flat coordinates (``x`` at ``2 i``, ``y`` at ``2 i + 1``) cost more
    instructions (a gather is about 13 an item, the copy 7 a row).  The same numbers either way."""
    xy = np.take(points, idx, axis=0).T.copy()
    return xy[0], xy[1]


def _layout(topo: Topology, blk: Block, subset: np.ndarray | None):
    """Row layout of a block's incident cells (depends on the topology only, cached for whole blocks).

    Returns (n, tri rows, tri rel, (v1, v2), quad rows, quad rel, (v1, v2, v3), tri ids, quad ids)
    with the rows reordered by :class:`_Rows`, the vertex columns as contiguous index arrays and
    the incidence row (index into ``topo.tri_verts`` / ``quad_verts``) of every row.
    """
    a = blk.nodes.start
    n = blk.size
    t_rel = topo.tri_loc[blk.tris] - a
    t_v = topo.tri_verts[blk.tris]
    t_ids = np.arange(topo.tri_loc.shape[0])[blk.tris]
    q_rel = topo.quad_loc[blk.quads] - a
    q_v = topo.quad_verts[blk.quads]
    q_ids = np.arange(topo.quad_loc.shape[0])[blk.quads]
    if subset is not None:
        remap = np.full(n, -1, np.int64)
        remap[subset] = np.arange(subset.shape[0])
        keep = remap[t_rel] >= 0
        t_rel, t_v, t_ids = remap[t_rel[keep]], t_v[keep], t_ids[keep]
        keep = remap[q_rel] >= 0
        q_rel, q_v, q_ids = remap[q_rel[keep]], q_v[keep], q_ids[keep]
        n = subset.shape[0]
    t_rows, q_rows = _Rows(t_rel, n), _Rows(q_rel, n)
    # intp: numpy gathers with int32 indices (the topology's tables) convert them every time; not for
    # large blocks, where the copies would cost memory (see _blocks.INTP_MAX; the same indices either way)
    ix = np.intp if 3 * (t_v.shape[0] + q_v.shape[0]) <= INTP_MAX else None
    t_cols = tuple(np.ascontiguousarray(t_v[t_rows.perm, k], dtype=ix) for k in (1, 2))
    q_cols = tuple(np.ascontiguousarray(q_v[q_rows.perm, k], dtype=ix) for k in (1, 2, 3))
    t_rel, q_rel = t_rel[t_rows.perm], q_rel[q_rows.perm]
    if ix is not None:
        t_rel, q_rel = t_rel.astype(np.intp), q_rel.astype(np.intp)
    t_ids, q_ids = t_ids[t_rows.perm], q_ids[q_rows.perm]  # incidence row of each layout row
    t_rows.perm = q_rows.perm = None  # applied; not needed again
    return n, t_rows, t_rel, t_cols, q_rows, q_rel, q_cols, t_ids, q_ids


def _largest_rows(quads: bool, px, py, cols) -> np.ndarray:
    """Per row, ``-cos`` of the largest corner that moves with p0 at (px, py) (:meth:`._local.BlockGeometry.largest`):
    the score kernels' operations (``cols``: ``BlockGeometry._TRI`` / ``_QUAD``), written in place."""
    if quads:
        x1, y1, x3, y3, ux, uy, vx, vy, l12, l23 = cols[:10]
        ex1, ey1, ex3, ey3 = x1 - px, y1 - py, x3 - px, y3 - py
        l1, l3 = _norm(ex1, ey1), _norm(ex3, ey3)
        v = ex1 * ex3  # corner 0: -((e1.e3) / (l1 l3))
        v += ey1 * ey3
        v /= l1 * l3
        np.negative(v, out=v)
        c1 = ux * ex1  # corner 1: (e12.e1) / (l12 l1)
        c1 += uy * ey1
        c1 /= l12 * l1
        np.maximum(v, c1, out=v)
        c3 = ex3 * vx  # corner 3: -((e3.e23) / (l3 l23))
        c3 += ey3 * vy
        c3 /= l3 * l23
        np.negative(c3, out=c3)
        return np.maximum(v, c3, out=v)
    x1, y1, x2, y2, ux, uy, l12 = cols[:7]
    ex1, ey1, fx2, fy2 = x1 - px, y1 - py, px - x2, py - y2
    l1, l2 = _norm(ex1, ey1), _norm(fx2, fy2)
    v = ex1 * fx2  # corner 0
    v += ey1 * fy2
    v /= l1 * l2
    c1 = ux * ex1  # corner 1
    c1 += uy * ey1
    c1 /= l12 * l1
    np.maximum(v, c1, out=v)
    c2 = fx2 * ux  # corner 2
    c2 += fy2 * uy
    c2 /= l2 * l12
    return np.maximum(v, c2, out=v)


def _norm(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``np.sqrt(x * x + y * y)`` with one temporary (the same numbers)."""
    t = x * x
    t += y * y
    return np.sqrt(t, out=t)


#: The score of an invalid position, less one per invalid incident cell (see :mod:`._local`)
INVALID = -3.0
#: What an inverted incident cell counts in that, against 1 for another invalid one
INVERTED_WEIGHT = 1000.0


def _tri_core(px, py, cols):
    """The raw value (-max cos of the three corners, no validity) of triangle rows with p0 at (px, py)
    and the fixed corners' ``cols`` (``BlockGeometry._TRI``), and its parts: (vals, ex1, ey1, fx2, fy2,
    l1, l2).  Where a row is valid (:func:`_tri_vals`) its value is ``vals``, bit for bit.

    With f2 = p0 - p2 = -(p2 - p0) (exact in floating point), the negated
    cosines come out without negations: -cos0 = e1.f2 / (l1 l2),
    -cos1 = e12.e1 / (l12 l1), -cos2 = f2.e12 / (l2 l12), and the corner
    cross product e1 x e2 = -(e1 x f2) -- bit for bit the same values.
    """
    x1, y1, x2, y2, ux, uy, l12 = cols
    ex1 = x1 - px
    ey1 = y1 - py
    fx2 = px - x2
    fy2 = py - y2
    l1 = _norm(ex1, ey1)
    l2 = _norm(fx2, fy2)
    vals = (ex1 * fx2 + ey1 * fy2) / (l1 * l2)
    np.minimum(vals, (ux * ex1 + uy * ey1) / (l12 * l1), out=vals)
    np.minimum(vals, (fx2 * ux + fy2 * uy) / (l2 * l12), out=vals)
    return vals, ex1, ey1, fx2, fy2, l1, l2


def _tri_vals(px, py, cols, fl, want_area=False):
    """(-max cos of the three corners, valid, area or None) of triangle rows (:func:`_tri_core`), input
    floors ``fl`` (``BlockGeometry._TRI_FLOORS``) or None; +inf where invalid."""
    vals, ex1, ey1, fx2, fy2, l1, l2 = _tri_core(px, py, cols)
    cr = ex1 * fy2 - ey1 * fx2
    # the area, _row_area's 0.5 * (e1 x e2) (up to the sign of a zero, which no comparison sees):
    # fx2 = -ex2 and fy2 = -ey2 exactly, so cr = -(e1 x e2) exactly (rounding is symmetric)
    ar = -0.5 * cr if want_area else None
    ok = cr < 0
    if fl is not None:  # -cr is twice the area
        fa, f1, f2 = fl
        ok &= (-cr >= fa) & (l1 >= f1) & (l2 >= f2)
    ok &= np.isfinite(vals)
    if np.count_nonzero(ok) != ok.size:  # (ok.all(), fewer instructions)
        vals[~ok] = np.inf
    return vals, ok, ar


def _quad_core(px, py, cols):
    """The raw max |cos| of the corners of quad rows (``cols``: ``BlockGeometry._QUAD``; its ``q_ok2``
    is not read) with p0 at (px, py), and its parts: (cm, ex1, ey1, ex3, ey3, l1, l3).  Where a row is
    valid (:func:`_quad_vals`) its value is ``-cm``, bit for bit."""
    x1, y1, x3, y3, ux, uy, vx, vy, l12, l23, _, cos2 = cols
    ex1 = x1 - px
    ey1 = y1 - py
    ex3 = x3 - px
    ey3 = y3 - py
    l1 = _norm(ex1, ey1)
    l3 = _norm(ex3, ey3)
    cm = np.abs((ex1 * ex3 + ey1 * ey3) / (l1 * l3))
    np.maximum(cm, np.abs((ux * ex1 + uy * ey1) / (l12 * l1)), out=cm)
    c3 = np.abs((ex3 * vx + ey3 * vy) / (l3 * l23))
    np.maximum(c3, cos2, out=c3)
    np.maximum(cm, c3, out=cm)
    return cm, ex1, ey1, ex3, ey3, l1, l3


def _quad_vals(px, py, cols, fl, want_area=False):
    """(-max |cos| of the four corners, valid, area or None) of quad rows (:func:`_quad_core`; ``fl``:
    ``BlockGeometry._QUAD_FLOORS`` or None); +inf where invalid."""
    x1, y1, x3, y3, ux, uy, vx, vy = cols[:8]
    cm, ex1, ey1, ex3, ey3, l1, l3 = _quad_core(px, py, cols)
    # a corner's cross product a - b is > 0 exactly where a > b (a difference of two doubles is zero only
    # where they are equal, NaN where both are the same infinity): one subtraction fewer a corner
    ok = np.greater(ex1 * ey3, ey1 * ex3)  # corner 0: e1 x e3
    ok &= np.greater(uy * ex1, ux * ey1)  # corner 1: e12 x (-e1)
    ok &= np.greater(ex3 * vy, ey3 * vx)  # corner 3: e3 x e23
    ok &= cols[10] if cols[10].dtype == bool else cols[10] > 0  # q_ok2 (a float 0 / 1 in a packed copy)
    ar = None
    if fl is not None or want_area:
        # twice the area: the same operations as _row_area's
        a2 = (x1 + ux - px) * (y3 - y1) - (y1 + uy - py) * (x3 - x1)
        ar = 0.5 * a2 if want_area else None
    if fl is not None:
        ok &= (a2 >= fl[0]) & (l1 >= fl[1]) & (l3 >= fl[2])
    ok &= np.isfinite(cm)
    np.negative(cm, out=cm)
    if np.count_nonzero(ok) != ok.size:  # (ok.all(), fewer instructions)
        cm[~ok] = np.inf
    return cm, ok, ar


def _row_area(quads: bool, px, py, cols):
    """The signed area of rows (``BlockGeometry._TRI`` / ``_QUAD`` ``cols``) with p0 at (px, py): the operations
    of :func:`_tri_vals` / :func:`_quad_vals`'s areas (a triangle's up to the sign of a zero)."""
    if quads:
        x1, y1, x3, y3, ux, uy = cols[:6]
        return 0.5 * ((x1 + ux - px) * (y3 - y1) - (y1 + uy - py) * (x3 - x1))
    x1, y1, x2, y2 = cols[:4]
    return 0.5 * ((x1 - px) * (y2 - py) - (y1 - py) * (x2 - px))


def score_rows(quads: bool, px, py, cols, fl, d, starts=None, strict=None, band=None):
    """The local score's parts over segments of rows: the numpy scorer both :meth:`._local.BlockGeometry.score`
    (a block's chunks of rows) and the compass search's pruned scores (:class:`._compass._Pruned`: rows
    gathered per (position, node) pair) use.

    Rows of one kind (``quads``) with p0 at (px, py) (``(..., rows)``) and the fixed corners' ``cols`` / input
    floors ``fl`` (or None); a segment (a node at one position) is every ``d`` consecutive rows (``d`` an int)
    or the runs of lengths ``d`` starting at ``starts`` (``np.cumsum(d) - d``).  ``strict``: per row (or None),
    quad rows that score :func:`strict_quad`; ``band``: (lo, hi) per segment or None.  Returns, per segment,
    (the smallest row value, +inf where invalid; the invalid rows' weight -- 1, or
    :data:`INVERTED_WEIGHT` for an inverted one (area <= 0) -- or None if no row is invalid; True where a
    row's area leaves [lo, hi] (a NaN area or bound too), or None if none does / no band).
    """
    vals, ok, ar = (_quad_vals if quads else _tri_vals)(px, py, cols, fl, band is not None)
    if strict is not None:
        vals = np.where(strict, strict_quad(vals), vals)
    low = _rowreduce(vals, d, starts=starts)
    bad = out = None
    if np.count_nonzero(ok) != ok.size:  # (ok.all(), fewer instructions)
        if ar is None:
            ar = _row_area(quads, px, py, cols)
        # an inverted cell (area <= 0) weighs more than any number of other invalid (non-convex) cells:
        # swapping one for the other is never an improvement
        weight = np.where(ar > 0, 1.0, INVERTED_WEIGHT)[~ok]
        hit = np.nonzero(~ok)
        seg = hit[-1] // d if isinstance(d, int) else np.searchsorted(starts, hit[-1], side="right") - 1
        m = low.shape[-1]
        if low.ndim == 2:
            seg = hit[0] * m + seg
        bad = np.bincount(seg, weights=weight, minlength=low.size).reshape(low.shape)
    if band is not None:
        # every row within [lo, hi]: the segment's smallest and largest area within (NaN: outside)
        inside = _rowreduce(ar, d, starts=starts) >= band[0]
        inside &= _rowreduce(ar, d, np.maximum, starts) <= band[1]
        if np.count_nonzero(inside) != inside.size:
            out = ~inside
    return low, bad, out


def finish_scores(best: np.ndarray, bad: np.ndarray | None, out_band: np.ndarray | None) -> np.ndarray:
    """The scores from :func:`score_rows`'s parts gathered per position: ``INVALID - bad`` where a row is invalid,
    -inf where one leaves the band, else the smallest row value (``best`` itself if neither)."""
    out = best if bad is None else np.where(bad > 0, INVALID - bad, best)
    if out_band is not None:
        out[out_band] = -np.inf
    return out


_C30 = math.cos(math.pi / 6)


def strict_quad(v: np.ndarray) -> np.ndarray:
    """A quad corner's score ``v = -|cos q|`` (``q = min(angle, 180 - angle)``) as ``-cos(q - 30 deg)``.

    That is the triangle score of ``q - 30``: a quad corner ``d`` degrees away from a right angle
    counts like a triangle corner ``d`` degrees below 60 (a 116 deg quad corner like a 34 deg
    triangle corner; the plain ``-|cos|`` counts it like 64 deg).  Exact, no trigonometry:
    ``cos(q - 30) = cos 30 |cos q| + sin 30 sin q``; monotone in ``q``, continued linearly in
    ``|cos q|`` below ``q = 30`` (score -1 there), so the worst quads still order.  Invalid rows
    (``+inf``) stay ``+inf``.
    """
    c = -v
    s = np.sqrt(np.maximum(1.0 - c * c, 0.0))
    return np.where(c <= _C30, -(_C30 * c + 0.5 * s), _C30 - 1.0 - c)
