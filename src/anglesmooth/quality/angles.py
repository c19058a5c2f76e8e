"""Corner angles: per corner, and the smallest / largest per cell."""

from __future__ import annotations

import numpy as np

from ..topology import CellTopology
from ._corners import _corners, _unit

__all__ = ["cell_max_angles", "cell_min_angles", "corner_angles"]


def corner_angles(points: np.ndarray, topo: CellTopology) -> tuple[np.ndarray, np.ndarray]:
    """Corner angles of every triangle and quad, in degrees.

    The angle at node v with previous node p and next node n (counter-clockwise
    cell order) is the counter-clockwise angle from ``n - v`` to ``p - v``,
    ``atan2(cross, dot)`` mapped to [0, 360): convex corners of valid cells lie in
    (0, 180), reflex corners of non-convex quads and corners of inverted cells
    are > 180, and a corner with a zero-length edge is 0.

    Parameters
    ----------
    points : (N, 2) float array
    topo : CellTopology (or Topology)

    Returns
    -------
    tri_angles : (nt, 3) float64
        Angle at corner k of ``topo.tri[i]``.
    quad_angles : (nq, 4) float64
        Angle at corner k of ``topo.quad[i]``.

    Examples
    --------
    >>> import numpy as np
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> m = Mesh2D.from_arrays([[0, 0], [1, 0], [0, 1]], triangles=[[0, 1, 2]])
    >>> t, q = corner_angles(m.points, build_topology(m))
    >>> np.round(t, 6).tolist(), q.shape
    ([[90.0, 45.0, 45.0]], (0, 4))
    """
    return tuple(np.ascontiguousarray(a.T) for a in _angle_rows(points, topo))


def cell_min_angles(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Smallest corner angle of each cell (triangles, then quads), degrees.

    Angles as in :func:`corner_angles`.

    Examples
    --------
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> m = Mesh2D.from_arrays([[0, 0], [2, 0], [2, 1], [0, 1], [1, 2]],
    ...                        triangles=[[3, 2, 4]], quads=[[0, 1, 2, 3]])
    >>> cell_min_angles(m.points, build_topology(m)).round(6).tolist()
    [45.0, 90.0]
    """
    t, q = _angle_rows(points, topo)
    return np.concatenate([t.min(axis=0, initial=np.inf), q.min(axis=0, initial=np.inf)])


def cell_max_angles(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Largest corner angle of each cell (triangles, then quads), degrees.

    Angles as in :func:`corner_angles`; a non-convex quad's reflex corner is > 180.

    Examples
    --------
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> m = Mesh2D.from_arrays([[0, 0], [2, 0], [2, 1], [0, 1], [1, 2]],
    ...                        triangles=[[3, 2, 4]], quads=[[0, 1, 2, 3]])
    >>> cell_max_angles(m.points, build_topology(m)).round(6).tolist()
    [90.0, 90.0]
    """
    t, q = _angle_rows(points, topo)
    return np.concatenate([t.max(axis=0, initial=-np.inf), q.max(axis=0, initial=-np.inf)])


def _angle_rows(points: np.ndarray, topo: CellTopology) -> tuple[np.ndarray, np.ndarray]:
    """Corner angles (degrees) of the triangles and of the quads as (k, n) rows, on the scaled points."""
    pts = _unit(points)[0]
    return tuple(_corners(pts, cells).angle for cells in (topo.tri, topo.quad))
