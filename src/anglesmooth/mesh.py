"""The planar mesh the library works on.

:class:`Mesh2D` is what :func:`anglesmooth.io.read` returns and what every other
module consumes: node coordinates (N, 2) plus the corner connectivity of the
linear 2D cells.  It is a frozen dataclass with read-only arrays; operations
return new objects (``dataclasses.replace``) instead of mutating.

Second-order cells (triangle6, quad8, quad9) are represented by their corner
nodes; their mid-edge and centre nodes are listed in ``midside`` / ``centres`` so
that :func:`place_high_order` can put them back after the corners moved.

>>> import numpy as np
>>> m = Mesh2D.from_arrays([[0, 0], [1, 0], [0, 1]], triangles=[[0, 1, 2]])
>>> m.n_points, m.n_cells
(3, 1)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import InvalidMeshError

__all__ = ["MAX_COORD", "MIN_SIZE", "Mesh2D", "place_high_order"]

#: Largest coordinate magnitude a mesh may have (the file readers refuse larger ones too): squared
#: lengths and areas stay below the largest double (1.8e308).
MAX_COORD = 1.0e150

#: Smallest bounding-box diagonal of a mesh whose nodes do not all coincide: below it, squared lengths
#: and areas of its cells underflow double precision (the smoothers' arithmetic and the validity
#: checks would see zero areas everywhere).
MIN_SIZE = 1.0e-100

_EMPTY_I = np.zeros((0,), dtype=np.int64)


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Mesh2D:
    """A planar triangle / quad mesh.

    Attributes
    ----------
    points : (N, 2) float64
        Node coordinates (x, y).
    triangles : (nt, 3) int64
        Corner nodes of every triangle-like cell (triangle, triangle6, ...), all
        blocks concatenated in file order.
    quads : (nq, 4) int64
        Corner nodes of every quad-like cell (quad, quad8, quad9).
    triangle_region, quad_region : (nt,), (nq,) int64 or None
        Region tag per cell (e.g. gmsh:physical); nodes between cells of
        different regions are fixed.
    triangle_ids, quad_ids : (nt,), (nq,) int64
        Index of each cell among all cells of the source file (counting every
        block, lines and vertices included), for error messages.
    pinned : (N,) bool
        Nodes the file itself fixes: nodes of line and vertex cells.
    midside : (m, 3) int64
        Second-order mid-edge nodes as rows (mid, a, b).
    centres : (m, 5) int64
        quad9 centre nodes as rows (centre, c0, c1, c2, c3).
    groups : mapping str -> int64 array
        Node indices of each named group (physical groups, cell sets, point sets),
        for ``--fix-group``.
    physical : mapping (dim, number) -> int64 array
        Node indices of each gmsh physical group by dimension and number, named
        or not (``--fix-group 11``, ``--fix-group 2:11``).
    source : object
        The object the mesh was read from (a ``meshio.Mesh``), kept opaque so
        that :func:`anglesmooth.io.write` can write everything back.
    frame : PlaneFrame or None
        The plane of a mesh read with three coordinates
        (:class:`anglesmooth.plane.PlaneFrame`): ``points`` are coordinates in
        that plane and :func:`anglesmooth.io.write` maps moved nodes back to 3D.
        None: ``points`` are x, y.
    """

    points: np.ndarray
    triangles: np.ndarray
    quads: np.ndarray
    triangle_region: np.ndarray | None = None
    quad_region: np.ndarray | None = None
    triangle_ids: np.ndarray | None = None
    quad_ids: np.ndarray | None = None
    pinned: np.ndarray | None = None
    midside: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    centres: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.int64))
    groups: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: Any = None
    frame: Any = None
    physical: Mapping[tuple[int, int], np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise InvalidMeshError(f"points must have shape (N, 2), got {pts.shape}")
        n = pts.shape[0]
        pts = np.ascontiguousarray(pts)
        _check_size(pts)
        tri = np.asarray(self.triangles, dtype=np.int64).reshape(-1, 3)
        quad = np.asarray(self.quads, dtype=np.int64).reshape(-1, 4)
        set_ = object.__setattr__
        set_(self, "points", _ro(pts))
        set_(self, "triangles", _ro(tri))
        set_(self, "quads", _ro(quad))
        for name, cells in (("triangle", tri), ("quad", quad)):
            # one pass: a negative int64 seen as uint64 is above any node count
            if cells.size and int(cells.view(np.uint64).max()) >= n:
                bad = int(np.flatnonzero(((cells < 0) | (cells >= n)).any(axis=1))[0])
                raise InvalidMeshError(
                    f"{name} {bad} references node {int(cells[bad].max() if cells[bad].max() >= n else cells[bad].min())}, "
                    f"but the mesh has {n} nodes (valid: 0..{n - 1})"
                )
        for name, cells in (("triangle_region", tri), ("quad_region", quad)):
            val = getattr(self, name)
            if val is not None:
                val = np.asarray(val, dtype=np.int64).reshape(-1)
                if val.shape[0] != cells.shape[0]:
                    raise InvalidMeshError(f"{name} has {val.shape[0]} entries for {cells.shape[0]} cells")
                set_(self, name, _ro(val))
        for name, cells in (("triangle_ids", tri), ("quad_ids", quad)):
            val = getattr(self, name)
            val = np.arange(cells.shape[0], dtype=np.int64) if val is None else np.asarray(val, np.int64)
            if name == "quad_ids" and getattr(self, name) is None:
                val = val + tri.shape[0]
            set_(self, name, _ro(val))
        pinned = np.zeros(n, dtype=bool) if self.pinned is None else np.asarray(self.pinned, dtype=bool)
        if pinned.shape != (n,):
            raise InvalidMeshError(f"pinned mask has shape {pinned.shape}, expected ({n},)")
        set_(self, "pinned", _ro(pinned))
        set_(self, "midside", _ro(np.asarray(self.midside, dtype=np.int64).reshape(-1, 3)))
        set_(self, "centres", _ro(np.asarray(self.centres, dtype=np.int64).reshape(-1, 5)))
        set_(self, "groups", {k: _ro(np.asarray(v, dtype=np.int64).reshape(-1)) for k, v in self.groups.items()})
        set_(self, "physical", {(int(d), int(t)): _ro(np.asarray(v, dtype=np.int64).reshape(-1))
                                for (d, t), v in self.physical.items()})

    @classmethod
    def from_arrays(cls, points, triangles=None, quads=None, **kwargs) -> Mesh2D:
        """Build a mesh from plain arrays (no source file)."""
        tri = _EMPTY_I.reshape(0, 3) if triangles is None else triangles
        quad = _EMPTY_I.reshape(0, 4) if quads is None else quads
        return cls(points=points, triangles=tri, quads=quad, **kwargs)

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_cells(self) -> int:
        """Number of 2D cells (triangles + quads)."""
        return int(self.triangles.shape[0] + self.quads.shape[0])

    def points_3d(self, points: np.ndarray | None = None) -> np.ndarray:
        """(N, 3) coordinates of ``points`` (default ``self.points``) mapped back through the plane frame.

        >>> Mesh2D.from_arrays([[0, 0], [1, 0], [0, 1]], triangles=[[0, 1, 2]]).points_3d()[1].tolist()
        [1.0, 0.0, 0.0]
        """
        pts = self.points if points is None else np.asarray(points, dtype=np.float64)
        if self.frame is None:
            return np.column_stack([pts, np.zeros(pts.shape[0])])
        return self.frame.to_3d(pts)

    def to_meshio(self, points: np.ndarray | None = None):
        """A ``meshio.Mesh`` of this mesh (with ``points`` as its coordinates), everything of the source kept.

        See :func:`anglesmooth.io.to_meshio`.
        """
        from .io import to_meshio

        return to_meshio(self, points=points)

    def with_points(self, points: np.ndarray) -> Mesh2D:
        """Return a copy of this mesh with new (N, 2) coordinates."""
        from dataclasses import replace

        return replace(self, points=points)


def _check_size(pts: np.ndarray) -> None:
    """Refuse non-finite coordinates, coordinates beyond :data:`MAX_COORD` and meshes smaller than
    :data:`MIN_SIZE` (InvalidMeshError).

    One contiguous min and max of all coordinates decide the first two (a NaN makes both NaN);
    the per-node masks that name the first bad node are only computed for a bad mesh.  (Reductions
    over the short axis of (N, 2) run element by element: ten times slower.)
    """
    if not pts.shape[0]:
        return
    flat = pts.reshape(-1)
    lo, hi = float(flat.min()), float(flat.max())
    if not (math.isfinite(lo) and math.isfinite(hi)):
        i = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InvalidMeshError(f"node {i} has a non-finite coordinate {pts[i].tolist()}")
    if hi > MAX_COORD or lo < -MAX_COORD:
        i = int(np.flatnonzero((np.abs(pts) > MAX_COORD).any(axis=1))[0])
        raise InvalidMeshError(f"node {i} has an absurd coordinate {pts[i].tolist()} (limit {MAX_COORD:g})")
    # the diagonal is below MIN_SIZE only if every x is that close to x0 and every y to y0 (node 0):
    # when the smallest or the largest coordinate is near neither, it is not (no more passes)
    x0, y0 = float(pts[0, 0]), float(pts[0, 1])
    if any(min(abs(v - x0), abs(v - y0)) >= MIN_SIZE for v in (lo, hi)):
        return
    x, y = pts[:, 0], pts[:, 1]  # 1-D strided reductions: fast, unlike those over axis 0 of (N, 2)
    size = float(np.hypot(x.max() - x.min(), y.max() - y.min()))
    if 0 < size < MIN_SIZE:
        raise InvalidMeshError(f"the mesh is too small to compute with: its bounding-box diagonal is {size:.3g}, "
                               f"below {MIN_SIZE:g} (squared lengths and areas underflow double precision); "
                               "scale the coordinates up")


def place_high_order(mesh: Mesh2D, points: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Reposition second-order nodes after their corner nodes moved.

    A mid-edge node is put at the midpoint of its edge when an end of the edge
    moved (``points`` differs from ``mesh.points``) and not both ends are fixed
    (boundary and interface edges keep their, possibly curved, shape).  A quad9
    centre node is put at the bilinear centre of its quad (the mean of the four
    corners) when a corner moved and not all four are fixed.  Nodes of edges and
    cells whose corners did not move are left exactly as they are: ``passes=0``
    returns every node bit-identical, and a curved interior edge stays curved
    until smoothing moves one of its ends.

    >>> import numpy as np
    >>> m = Mesh2D.from_arrays([[0, 0], [2, 0], [0, 2], [1, 0.3]], triangles=[[0, 1, 2]],
    ...                        midside=[[3, 0, 1]])
    >>> fixed = np.array([False, False, True, True])
    >>> place_high_order(m, m.points, fixed)[3].tolist()  # nothing moved: the curved edge stays
    [1.0, 0.3]
    >>> moved = m.points.copy(); moved[1] = [2.2, 0]
    >>> place_high_order(m, moved, fixed)[3].tolist()
    [1.1, 0.0]
    """
    out = np.array(points, dtype=np.float64, copy=True)
    if not (mesh.midside.shape[0] or mesh.centres.shape[0]):
        return out
    moved = (out != mesh.points).any(axis=1)
    if mesh.midside.shape[0]:
        mid, a, b = mesh.midside.T
        move = ~(fixed[a] & fixed[b]) & (moved[a] | moved[b])
        out[mid[move]] = 0.5 * (out[a[move]] + out[b[move]])
    if mesh.centres.shape[0]:
        c = mesh.centres
        move = ~fixed[c[:, 1:5]].all(axis=1) & moved[c[:, 1:5]].any(axis=1)
        corners = out[c[move, 1:5]]
        out[c[move, 0]] = corners.mean(axis=1)
    return out
