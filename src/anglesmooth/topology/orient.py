"""Signed areas and the consistent (counter-clockwise) orientation of cells."""

from __future__ import annotations

import numpy as np

from ._keys import _edge_cell, _HalfEdges

__all__ = ["signed_areas"]


#: Cells per chunk of :func:`signed_areas` (its gathers and products stay in the caches).
CHUNK = 1 << 16


def signed_areas(points: np.ndarray, tri: np.ndarray, quad: np.ndarray) -> np.ndarray:
    """Signed areas of triangles then quads (shoelace; positive when counter-clockwise).

    >>> import numpy as np
    >>> signed_areas(np.array([[0., 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]]), np.zeros((0, 4), int)).tolist()
    [0.5]
    """
    out = np.empty(tri.shape[0] + quad.shape[0])
    points = np.asarray(points)
    if points.dtype != np.float64 or points.ndim != 2 or points.shape[1] != 2:
        return _signed_areas_columns(points, tri, quad, out)
    # one complex128 gather fetches x and y of a node together (one cache line, not two: the nodes of
    # a cell are anywhere in memory); complex subtraction is the two real ones, so the values are the
    # same bits as from the x and y columns.  Intp indices: numpy's int32 fancy indexing is 2x slower.
    z = np.ascontiguousarray(points).view(np.complex128).ravel()
    for cells, part in ((tri, out[: tri.shape[0]]), (quad, out[tri.shape[0] :])):
        for s in range(0, cells.shape[0], CHUNK):
            c = cells[s : s + CHUNK].T.astype(np.intp)
            if cells.shape[1] == 3:
                z0 = z[c[0]]
                u = z[c[1]]
                u -= z0
                v = z[c[2]]
                v -= z0
            else:
                u = z[c[2]]
                u -= z[c[0]]
                v = z[c[3]]
                v -= z[c[1]]
            _half_cross(u.real, u.imag, v.real, v.imag, part[s : s + CHUNK])
    return out


def _signed_areas_columns(points, tri, quad, out):
    """:func:`signed_areas` from the x and y columns (any dtype and width of ``points``)."""
    # gathers from the x and y columns (1-D) are much faster than from (N, 2) rows
    x, y = points[:, 0], points[:, 1]
    if tri.shape[0]:
        x0, y0 = x[tri[:, 0]], y[tri[:, 0]]
        _half_cross(x[tri[:, 1]] - x0, y[tri[:, 1]] - y0, x[tri[:, 2]] - x0, y[tri[:, 2]] - y0, out[: tri.shape[0]])
    if quad.shape[0]:
        q = [quad[:, k] for k in range(4)]
        _half_cross(x[q[2]] - x[q[0]], y[q[2]] - y[q[0]], x[q[3]] - x[q[1]], y[q[3]] - y[q[1]], out[tri.shape[0] :])
    return out


def _half_cross(ux, uy, vx, vy, out: np.ndarray) -> None:
    """``out = 0.5 * cross(u, v)``, rounded exactly as ``0.5 * (ux * vy - uy * vx)``."""
    ux *= vy
    uy *= vx
    ux -= uy
    np.multiply(ux, 0.5, out=out)


def _components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected components of a graph with n vertices and edges (u, v): min-label hooking + pointer jumping."""
    label = np.arange(n, dtype=np.int64)
    while True:
        lu, lv = label[u], label[v]
        new = label.copy()
        np.minimum.at(new, lu, lv)
        np.minimum.at(new, lv, lu)
        while True:  # pointer jumping
            nxt = new[new]
            if np.array_equal(nxt, new):
                break
            new = nxt
        if np.array_equal(new, label):
            return label
        label = new


def _orient(points, tri, quad, he: _HalfEdges):
    """Flip cells so that each consistently wound patch is counter-clockwise."""
    nt, nq = tri.shape[0], quad.shape[0]
    nc = nt + nq
    area = signed_areas(points, tri, quad)
    if not he.dup.any():  # every shared edge is traversed in opposite directions
        flip = np.full(nc, area.sum() < 0)
    else:
        i0, i1 = he.order[:-1][he.same], he.order[1:][he.same]
        consistent = he.a[i0] != he.a[i1]  # opposite directions
        cell = _edge_cell(nt, nq)
        comp = _components(nc, cell[i0][consistent], cell[i1][consistent])
        total = np.bincount(comp, weights=area, minlength=nc)
        flip = total[comp] < 0
    if flip.any():
        tri = tri.copy()
        quad = quad.copy()
        ft, fq = flip[:nt], flip[nt:]
        tri[ft] = tri[ft][:, ::-1]
        quad[fq] = quad[fq][:, ::-1]
    return tri, quad, flip
