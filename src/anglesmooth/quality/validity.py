"""Signed areas and what makes a cell invalid: inverted, degenerate, non-convex.

*Inverted* (signed area < 0: the orientation is flipped) and *degenerate* (0 <= signed area <=
:data:`DEGENERATE_REL` x the squared bounding-box diagonal: zero area, or too little to tell) are
disjoint: a cell is one, the other or valid.  Both are decided on coordinates scaled by a power of
two (:func:`._corners._unit`, exact), so that a mesh of size 1e-100 is not read as all zero areas.
:func:`invalid_cells`, the guard's test, is not scaled: it is what the smoothers check.
"""

from __future__ import annotations

import numpy as np

from ..topology import CellTopology, signed_areas
from ._corners import _cross, _edges, _unit

__all__ = ["DEGENERATE_REL", "cell_areas", "degenerate_cells", "invalid_cells", "inverted_cells", "nonconvex_quads"]

#: Relative area up to which a cell that is not inverted counts as degenerate: 0 <= A <= DEGENERATE_REL * diag(bbox)^2.
DEGENERATE_REL = 1.0e-12


def _diag2(pts: np.ndarray) -> float:
    """Squared diagonal of the bounding box of all nodes (0 without nodes)."""
    if not pts.shape[0]:
        return 0.0
    x, y = pts[:, 0], pts[:, 1]
    return float(((np.array([x.max(), y.max()]) - np.array([x.min(), y.min()])) ** 2).sum())


def _degenerate_mask(area: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Degenerate cells among signed areas ``area`` of cells on nodes ``pts``: 0 <= area <= DEGENERATE_REL * diag^2."""
    return (area >= 0) & (area <= DEGENERATE_REL * _diag2(pts))


def cell_areas(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Signed area of each cell (triangles, then quads), positive when valid.

    Shoelace formula (:func:`anglesmooth.topology.signed_areas`) on the
    counter-clockwise cells of ``topo``, so the sign is relative to the mesh
    orientation.

    Examples
    --------
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> m = Mesh2D.from_arrays([[0, 0], [0, 1], [1, 1], [1, 0]], quads=[[0, 1, 2, 3]])
    >>> cell_areas(m.points, build_topology(m)).tolist()  # written clockwise, read as valid
    [1.0]
    """
    return signed_areas(np.asarray(points, dtype=np.float64), topo.tri, topo.quad)


def inverted_cells(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Indices of the cells (triangles, then quads) with signed area < 0: orientation flipped.

    A cell of zero area is degenerate (:func:`degenerate_cells`), not inverted.

    Examples
    --------
    >>> import numpy as np
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]])
    >>> m = Mesh2D.from_arrays(pts, triangles=[[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> topo = build_topology(m)
    >>> moved = pts.copy(); moved[4] = [0.5, -0.2]   # the centre node leaves the square
    >>> inverted_cells(moved, topo).tolist()
    [0]
    """
    return np.flatnonzero(cell_areas(_unit(points)[0], topo) < 0)


def degenerate_cells(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Indices of the cells (triangles, then quads) of zero or nearly zero area that are not inverted.

    ``0 <= A <= DEGENERATE_REL * d^2`` with A the signed area and d the diagonal of the bounding
    box of all nodes: a collapsed cell (three collinear nodes, a repeated node) or one too thin to
    tell from it.  Disjoint from :func:`inverted_cells` (A < 0).

    Examples
    --------
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> m = Mesh2D.from_arrays([[0, 0], [1, 0], [2, 0], [0, 1]], triangles=[[0, 1, 3], [0, 1, 2]])
    >>> topo = build_topology(m)
    >>> degenerate_cells(m.points, topo).tolist(), inverted_cells(m.points, topo).tolist()
    ([1], [])
    """
    pts = _unit(points)[0]
    return np.flatnonzero(_degenerate_mask(cell_areas(pts, topo), pts))


def invalid_cells(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Mask (triangles, then quads) of cells a guarded smoother must not create.

    A cell is invalid when some corner has ``cross(next - v, prev - v) <= 0``
    (or NaN): inverted and degenerate cells, and non-convex quads.  Computed on
    ``points`` as they are (not scaled): the test the smoothers' guard applies.

    Examples
    --------
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> dart = Mesh2D.from_arrays([[0, 0], [2, 1], [0, 2], [0.5, 1]], quads=[[0, 1, 2, 3]])
    >>> invalid_cells(dart.points, build_topology(dart)).tolist()
    [True]
    """
    return np.concatenate([~(_cross(*_edges(points, cells)) > 0).all(axis=0) for cells in (topo.tri, topo.quad)])


def nonconvex_quads(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Indices (into ``topo.quad``) of non-convex quads.

    A quad is non-convex when its signed area is positive and at least one
    corner has ``cross(next - v, prev - v) <= 0`` (corner angle >= 180 or 0,
    bow-ties included).  Quads with signed area < 0 are inverted and quads of
    zero area degenerate, not non-convex.

    Examples
    --------
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> dart = Mesh2D.from_arrays([[0, 0], [2, 1], [0, 2], [0.5, 1]], quads=[[0, 1, 2, 3]])
    >>> nonconvex_quads(dart.points, build_topology(dart)).tolist()
    [0]
    """
    pts = _unit(points)[0]
    cross = _cross(*_edges(pts, topo.quad))
    area = signed_areas(pts, topo.tri[:0], topo.quad)
    return np.flatnonzero((area > 0) & (cross <= 0).any(axis=0))
