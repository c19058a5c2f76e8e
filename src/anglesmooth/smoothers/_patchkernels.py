"""The compiled screening of stage 5 (:func:`._patch._maybe_below`), for meshes on the compiled kernels.

One loop over the cells instead of numpy's gathers and temporaries (1M triangles: about 0.2 s a
pass in numpy, most of stage 5 there).  The same test, operation for operation; it only screens
(the exact quality of the cells it keeps decides), so the patches are those of the numpy path.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def _compiled(fn):
    try:
        return njit(cache=True, error_model="numpy", nogil=True)(fn)
    except RuntimeError:  # no writable cache location: compile in every process
        return njit(error_model="numpy", nogil=True)(fn)


@_compiled
def _corner_below(ux, uy, px, py, t):
    """Corner with edges u = e_c out and e_p = e_{c-1} in: cross < t * |dot| + 1e-300 (w = -e_p)."""
    return uy * px - ux * py < abs(ux * px + uy * py) * t + 1e-300


#: cells a chunk of the area range :func:`_screen_below` gives with the screen (a few chunks are
#: recomputed after stage 5 moved some nodes: :func:`_chunk_ranges`)
RANGE_CHUNK = 256


@_compiled
def _max_cot(xs, ys, k):
    """``_patch._cell_cot`` of one cell with corners (xs[i], ys[i]), i < k: the largest corner cotangent
    dot / cross (quads: its absolute value), +inf if some cross product is not positive; its operations
    (u = p_{c+1} - p_c, w = p_{c-1} - p_c, cross = ux wy - uy wx, dot = ux wx + uy wy) and its fold
    (``max`` over the corners in order, NaN kept)."""
    best, valid = 0.0, True
    for c in range(k):
        n, p = (c + 1) % k, (c - 1) % k
        ux, uy, wx, wy = xs[n] - xs[c], ys[n] - ys[c], xs[p] - xs[c], ys[p] - ys[c]
        cr = ux * wy - uy * wx
        q = (ux * wx + uy * wy) / cr
        if k == 4:
            q = abs(q)
        valid &= cr > 0
        if c == 0 or q != q:
            best = q
        elif best == best and q > best:
            best = q
    return best if valid else np.inf


@_compiled
def _screen_below(pts, cells, t, c0, c1, out, lo, hi, nan, cot):
    """Cells ``c0:c1`` (``c0`` a multiple of :data:`RANGE_CHUNK`): ``out[i]`` some corner of cell i has
    cross < t * |dot| + 1e-300 (see ``_patch._maybe_below``; the edges e_c = p_{c+1} - p_c in scalars,
    the same operations as the numpy screen), and then its largest corner cotangent (:func:`_max_cot`,
    ``_patch._cell_cot``'s number) into ``cot[c0 + h]``, h the number of kept cells before it from
    ``c0`` on (packed: a few pages of ``cot`` touched, not all of them); returns the number kept; per chunk j
    of :data:`RANGE_CHUNK` cells the smallest
    and largest signed area ``lo[j]``, ``hi[j]`` (``_fastkernels._cell_area_range``' operations, in its
    order; ``nan[j]``: one is NaN).  One read of the cells for the screen and the next pass's area
    range (:func:`_fold_range`); a part of the cells each, so that threads can share a call."""
    k = cells.shape[1]
    xs, ys = np.empty(4), np.empty(4)
    h = c0
    for j0 in range(c0, c1, RANGE_CHUNK):
        j1 = min(j0 + RANGE_CHUNK, c1)
        l, hh, bad = np.inf, -np.inf, False
        if k == 3:
            for i in range(j0, j1):
                a, b, c = cells[i, 0], cells[i, 1], cells[i, 2]
                x0, y0, x1, y1, x2, y2 = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1], pts[c, 0], pts[c, 1]
                e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
                hit = (_corner_below(e0x, e0y, e2x, e2y, t) | _corner_below(e1x, e1y, e0x, e0y, t)
                       | _corner_below(e2x, e2y, e1x, e1y, t))
                out[i] = hit
                if hit:
                    xs[0], xs[1], xs[2], ys[0], ys[1], ys[2] = x0, x1, x2, y0, y1, y2
                    cot[h] = _max_cot(xs, ys, 3)
                    h += 1
                ar = 0.5 * ((x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0))
                bad |= ar != ar
                l, hh = min(l, ar), max(hh, ar)
        else:
            for i in range(j0, j1):
                a, b, c, d = cells[i, 0], cells[i, 1], cells[i, 2], cells[i, 3]
                x0, y0, x1, y1, x2, y2 = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1], pts[c, 0], pts[c, 1]
                x3, y3 = pts[d, 0], pts[d, 1]
                e0x, e0y, e1x, e1y = x1 - x0, y1 - y0, x2 - x1, y2 - y1
                e2x, e2y, e3x, e3y = x3 - x2, y3 - y2, x0 - x3, y0 - y3
                hit = (_corner_below(e0x, e0y, e3x, e3y, t) | _corner_below(e1x, e1y, e0x, e0y, t)
                       | _corner_below(e2x, e2y, e1x, e1y, t) | _corner_below(e3x, e3y, e2x, e2y, t))
                out[i] = hit
                if hit:
                    xs[0], xs[1], xs[2], xs[3], ys[0], ys[1], ys[2], ys[3] = x0, x1, x2, x3, y0, y1, y2, y3
                    cot[h] = _max_cot(xs, ys, 4)
                    h += 1
                ar = 0.5 * ((x2 - x0) * (y3 - y1) - (y2 - y0) * (x3 - x1))
                bad |= ar != ar
                l, hh = min(l, ar), max(hh, ar)
        j = j0 // RANGE_CHUNK
        lo[j], hi[j], nan[j] = l, hh, bad
    return h - c0


@_compiled
def _chunk_ranges(pts, cells, chunks, lo, hi, nan):
    """The area range of the chunks ``chunks`` of :func:`_screen_below` again (after some nodes moved):
    the same operations and order, into ``lo``, ``hi``, ``nan``."""
    k = cells.shape[1]
    m = cells.shape[0]
    for q in range(chunks.shape[0]):
        j = chunks[q]
        l, h, bad = np.inf, -np.inf, False
        for i in range(j * RANGE_CHUNK, min((j + 1) * RANGE_CHUNK, m)):
            if k == 3:
                a, b, c = cells[i, 0], cells[i, 1], cells[i, 2]
                x0, y0 = pts[a, 0], pts[a, 1]
                ar = 0.5 * ((pts[b, 0] - x0) * (pts[c, 1] - y0) - (pts[b, 1] - y0) * (pts[c, 0] - x0))
            else:
                a, b, c, d = cells[i, 0], cells[i, 1], cells[i, 2], cells[i, 3]
                ar = 0.5 * ((pts[c, 0] - pts[a, 0]) * (pts[d, 1] - pts[b, 1]) - (pts[c, 1] - pts[a, 1]) * (pts[d, 0] - pts[b, 0]))
            bad |= ar != ar
            l, h = min(l, ar), max(h, ar)
        lo[j], hi[j], nan[j] = l, h, bad


@_compiled
def _fold_range(lo, hi, nan):
    """(smallest, largest) of the chunks' ranges, in order with ``min`` / ``max`` as
    ``_cell_area_range`` folds its cells (a first-of-equals selection: the same bits, a zero's sign
    included); (NaN, NaN) when a chunk has a NaN; (inf, -inf) for none."""
    l, h, bad = np.inf, -np.inf, False
    for j in range(lo.shape[0]):
        bad |= nan[j]
        l, h = min(l, lo[j]), max(h, hi[j])
    return (np.nan, np.nan) if bad else (l, h)
