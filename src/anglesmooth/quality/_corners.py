"""Edge vectors, corner cross products and corner angles of one cell type, computed once.

The shared base of :mod:`.angles`, :mod:`.validity`, :mod:`.verdict` and
:mod:`.summary`; arrays are (k, n): row k is corner / edge k of every cell.
:func:`_unit` is the scaling every measure is computed after (scale invariance).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

_R2D = 180.0 / np.pi
_BELOW_360 = np.nextafter(360.0, 0.0)


def _unit(points: np.ndarray) -> tuple[np.ndarray, int]:
    """``points`` times ``2**-e``, the power of two that brings their bounding-box diagonal into [0.5, 1), and ``e``.

    The scaling is exact (it only changes exponents), so a measure computed on the result is the
    measure of ``points``: lengths times ``2**-e``, areas times ``4**-e``, angles, signs and ratios
    bit for bit the same.  Only under- and overflow go away: the products of two or four lengths
    (cross products, squared areas) of a mesh of size 1e-100 or 1e+150 are computed as for a mesh
    of size 1, so that every measure is scale-invariant.  ``e = 0`` (the points as they are)
    without nodes, for coincident nodes and for non-finite coordinates.

    >>> import numpy as np
    >>> p, e = _unit(np.array([[0.0, 0.0], [3e-300, 4e-300]]))
    >>> e, bool(0.5 <= np.hypot(*p[1]) < 1.0)
    (-994, True)
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[0] == 0:
        return pts, 0
    with np.errstate(over="ignore", invalid="ignore"):
        xy = pts[:, :2]
        # column by column: a reduction over axis 0 of the (N, 2) array is 40x slower (1M triangles: 26 ms)
        span = [xy[:, j].max() - xy[:, j].min() for j in (0, -1)]
        size = float(np.hypot(span[0], span[1]))
        if not math.isfinite(size):  # the differences overflow (|coordinates| near 1e308): scale by the coordinates
            size = float(np.abs(xy).max())
    if not (math.isfinite(size) and size > 0):
        return pts, 0
    e = math.frexp(size)[1]
    return (pts if e == 0 else np.ldexp(pts, -e)), e


class _Corners(NamedTuple):
    """Edge vectors and corner quantities of one cell type, computed once.

    Arrays are (k, n): row k is corner / edge k of every cell, so that all the
    arithmetic runs on contiguous rows (the public functions return (n, k)).
    """

    length: np.ndarray  # (k, n) length of edge k: node k -> node k+1
    cross: np.ndarray  # (k, n) cross(next - v, prev - v) at corner k
    angle: np.ndarray  # (k, n) corner angle in degrees, [0, 360)


def _edges(points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ex, ey), each (k, n): e_k = p_{k+1} - p_k for (n, k) cells."""
    pts = np.asarray(points, dtype=np.float64)
    index = np.ascontiguousarray(cells.T)  # (k, n); a gather takes the layout of its index
    out = []
    for coord in (pts[:, 0], pts[:, 1]):
        c = np.take(coord, index)  # the same gather, 2-4x faster than coord[index] with a 2-D index
        e = np.empty_like(c)
        np.subtract(c[1:], c[:-1], out=e[:-1])
        np.subtract(c[0], c[-1], out=e[-1])
        out.append(e)
    return out[0], out[1]


def _cross(ex: np.ndarray, ey: np.ndarray) -> np.ndarray:
    """cross(next - v, prev - v) = cross(e_{k-1}, e_k) at every corner k, (k, n)."""
    out = np.empty_like(ex)
    for k in range(ex.shape[0]):
        j = k - 1  # e_{k-1}, wrapping to the last edge
        np.multiply(ex[j], ey[k], out=out[k])
        out[k] -= ey[j] * ex[k]
    return out


def _corners(points: np.ndarray, cells: np.ndarray) -> _Corners:
    """Edge lengths, corner cross products and corner angles of (n, k) ccw cells, as (k, n) arrays."""
    ex, ey = _edges(points, cells)
    # at corner k: a = next - v = e_k, b = prev - v = -e_{k-1}
    cross = _cross(ex, ey)  # cross(a, b) = cross(e_{k-1}, e_k)
    dot = np.empty_like(ex)  # dot(a, b) = -(e_k . e_{k-1})
    for k in range(ex.shape[0]):
        np.multiply(ex[k], ex[k - 1], out=dot[k])
        dot[k] += ey[k] * ey[k - 1]
    np.negative(dot, out=dot)
    ang = np.arctan2(cross, dot, out=dot)
    ang *= _R2D
    np.add(ang, 360.0, out=ang, where=ang < 0)
    np.minimum(ang, _BELOW_360, out=ang)  # -tiny + 360 rounds to 360
    length = np.hypot(ex, ey, out=ex)
    # a corner with a zero-length edge has no angle: call it 0 (atan2(0, -0) would say 180)
    zero = length == 0
    zero |= np.roll(zero, 1, axis=0)
    ang[zero] = 0.0
    return _Corners(length, cross, ang)


def _tri_area(c: _Corners) -> np.ndarray:
    """Signed triangle areas from the cross product at corner 0.

    Bit-identical to :func:`anglesmooth.topology.signed_areas`: cross(p0 - p2,
    p1 - p0) rounds like cross(p1 - p0, p2 - p0) (exact negations, same products).
    """
    return 0.5 * c.cross[0]
