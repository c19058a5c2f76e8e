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


@_compiled
def _screen_below(pts, cells, t):
    """(m,) bool: some corner of the cell has cross < t * |dot| + 1e-300 (see ``_patch._maybe_below``);
    the edges e_c = p_{c+1} - p_c in scalars, the same operations as the numpy screen."""
    m, k = cells.shape
    out = np.zeros(m, np.bool_)
    if k == 3:
        for i in range(m):
            a, b, c = cells[i, 0], cells[i, 1], cells[i, 2]
            x0, y0, x1, y1, x2, y2 = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1], pts[c, 0], pts[c, 1]
            e0x, e0y, e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x0 - x2, y0 - y2
            out[i] = (_corner_below(e0x, e0y, e2x, e2y, t) or _corner_below(e1x, e1y, e0x, e0y, t)
                      or _corner_below(e2x, e2y, e1x, e1y, t))
        return out
    for i in range(m):
        a, b, c, d = cells[i, 0], cells[i, 1], cells[i, 2], cells[i, 3]
        x0, y0, x1, y1, x2, y2, x3, y3 = (pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1], pts[c, 0], pts[c, 1],
                                          pts[d, 0], pts[d, 1])
        e0x, e0y, e1x, e1y, e2x, e2y, e3x, e3y = x1 - x0, y1 - y0, x2 - x1, y2 - y1, x3 - x2, y3 - y2, x0 - x3, y0 - y3
        out[i] = (_corner_below(e0x, e0y, e3x, e3y, t) or _corner_below(e1x, e1y, e0x, e0y, t)
                  or _corner_below(e2x, e2y, e1x, e1y, t) or _corner_below(e3x, e3y, e2x, e2y, t))
    return out
