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
def maybe_below(pts, cells, t):
    """(m,) bool: some corner of the cell has cross < t * |dot| + 1e-300 (see ``_patch._maybe_below``)."""
    m, k = cells.shape
    out = np.zeros(m, np.bool_)
    ex = np.empty(k)
    ey = np.empty(k)
    for i in range(m):
        for c in range(k):  # the edges e_c = p_{c+1} - p_c: u = e_c, w = -e_{c-1} (see ``_patch._maybe_below``)
            a = cells[i, c]
            b = cells[i, c + 1 if c + 1 < k else 0]
            ex[c] = pts[b, 0] - pts[a, 0]
            ey[c] = pts[b, 1] - pts[a, 1]
        for c in range(k):
            p = c - 1 if c > 0 else k - 1
            cr = ey[c] * ex[p] - ex[c] * ey[p]
            dot = abs(ex[c] * ex[p] + ey[c] * ey[p]) * t + 1e-300
            if cr < dot:
                out[i] = True
                break
    return out
