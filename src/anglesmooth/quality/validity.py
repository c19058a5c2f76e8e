"""Signed areas and what makes a cell invalid: inverted, degenerate, non-convex."""

from __future__ import annotations

import numpy as np

from ..topology import CellTopology, signed_areas
from ._corners import _cross, _edges

__all__ = ["DEGENERATE_REL", "cell_areas", "invalid_cells", "inverted_cells", "nonconvex_quads"]

#: Relative area below which a cell counts as degenerate: |A| <= DEGENERATE_REL * diag(bbox)^2.
DEGENERATE_REL = 1.0e-12


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
    """Indices of the cells (triangles, then quads) with signed area <= 0.

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
    return np.flatnonzero(cell_areas(points, topo) <= 0)


def invalid_cells(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Mask (triangles, then quads) of cells a guarded smoother must not create.

    A cell is invalid when some corner has ``cross(next - v, prev - v) <= 0``
    (or NaN): inverted and degenerate cells, and non-convex quads.

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
    bow-ties included).  Quads with signed area <= 0 are inverted, not
    non-convex.

    Examples
    --------
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> dart = Mesh2D.from_arrays([[0, 0], [2, 1], [0, 2], [0.5, 1]], quads=[[0, 1, 2, 3]])
    >>> nonconvex_quads(dart.points, build_topology(dart)).tolist()
    [0]
    """
    cross = _cross(*_edges(points, topo.quad))
    area = signed_areas(np.asarray(points, dtype=np.float64), topo.tri[:0], topo.quad)
    return np.flatnonzero((area > 0) & (cross <= 0).any(axis=0))
