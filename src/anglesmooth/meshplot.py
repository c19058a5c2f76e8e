"""Which cells a mesh figure shows, and drawing a mesh fast (the part of :mod:`anglesmooth.plot` that is about cells).

* :func:`worst_cells` - the cells to mark: smallest minimum angles, largest maximum angles.
* :func:`zoom_window` - a square window of a few local cell sizes around one cell.
* :func:`edge_widths`, :func:`edge_alpha` - the local cell width at each edge and the
  opacity it is drawn with: edges narrower than :data:`EDGE_MIN_PX` on screen are not drawn.
* :func:`draw_mesh` - cells filled by a value (one rasterized renderer call for all of
  them, quads split in two) and the visible edges, on a matplotlib ``Axes``.

Everything but :func:`draw_mesh` is numpy only; matplotlib is imported when drawing.
"""

from __future__ import annotations

import numpy as np

from .quality import cell_areas, corner_angles
from .topology import CellTopology

__all__ = ["CMAP", "EDGE_FULL_PX", "EDGE_MIN_PX", "WORST_K", "ZOOM_HALF_CELLS", "draw_mesh", "edge_alpha",
           "edge_widths", "worst_cells", "zoom_window"]

CMAP = "RdYlGn"
#: Cells marked in each mesh panel: this many smallest minimum angles and largest maximum angles.
WORST_K = 20
#: An edge between cells narrower than this on screen (pixels; see :func:`edge_widths`) is not drawn ...
EDGE_MIN_PX = 6.0
#: ... and one at least this long is drawn at full strength (linear fade in between).
EDGE_FULL_PX = 24.0
#: Half-width of the zoom window in local cell sizes (median sqrt(area) of the cells around the worst one).
ZOOM_HALF_CELLS = 5.0


# ---------------------------------------------------------------- pure helpers


def _smallest(values: np.ndarray, k: int) -> np.ndarray:
    """Indices of the k smallest values, ascending, ties by lower index (``argsort(kind="stable")[:k]``)."""
    values = np.asarray(values, dtype=np.float64)
    k = min(int(k), values.size)
    if k <= 0:
        return np.zeros(0, dtype=np.int64)
    kth = np.partition(values, k - 1)[k - 1]
    below = np.flatnonzero(values < kth)
    at = np.flatnonzero(values == kth)[: k - below.size]
    idx = np.concatenate([below, at])
    return idx[np.lexsort((idx, values[idx]))]


def worst_cells(points: np.ndarray, topo: CellTopology, k: int = WORST_K) -> tuple[np.ndarray, np.ndarray]:
    """The cells a figure marks: (k smallest minimum angles, k largest maximum angles).

    Cell indices count triangles first, then quads (as in :mod:`anglesmooth.quality`);
    the first array is sorted by increasing minimum angle, the second by decreasing
    maximum angle, ties by lower index.  O(n) (``np.partition``), no full sort.

    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_cell_topology
    >>> m = Mesh2D.from_arrays([[0, 0], [4, 0], [4, 1], [0, 1], [2, 3]],
    ...                        triangles=[[3, 2, 4]], quads=[[0, 1, 2, 3]])
    >>> lo, hi = worst_cells(m.points, build_cell_topology(m), k=1)
    >>> lo.tolist(), hi.tolist()  # the triangle's 2-unit-high apex: min 56.3 deg, max 112.6 deg
    ([0], [0])
    """
    mins, maxs = _extremes(points, topo)
    return _smallest(mins, k), _smallest(-maxs, k)


def _extremes(points: np.ndarray, topo: CellTopology) -> tuple[np.ndarray, np.ndarray]:
    """Cell minimum and maximum angles (as ``cell_min_angles`` / ``cell_max_angles``) from one angle pass."""
    t, q = corner_angles(points, topo)
    return (np.concatenate([t.min(axis=1, initial=np.inf), q.min(axis=1, initial=np.inf)]),
            np.concatenate([t.max(axis=1, initial=-np.inf), q.max(axis=1, initial=-np.inf)]))


def _centroids(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Vertex centroid of every cell (triangles, then quads)."""
    parts = []
    for cells in (topo.tri, topo.quad):
        acc = np.zeros((cells.shape[0], 2))
        for j in range(cells.shape[1]):
            acc += points[cells[:, j]]
        parts.append(acc / cells.shape[1])
    return np.concatenate(parts)


def _cell_nodes(topo: CellTopology, cell: int) -> np.ndarray:
    nt = topo.n_tri
    return topo.tri[cell] if cell < nt else topo.quad[cell - nt]


def zoom_window(points: np.ndarray, topo: CellTopology, cell: int, *, n_near: int = 40,
                half_cells: float = ZOOM_HALF_CELLS, centroids: np.ndarray | None = None,
                areas: np.ndarray | None = None) -> tuple[float, float, float, float]:
    """A square ``(x0, x1, y0, y1)`` centred on ``cell``, about ``2 * half_cells`` local cells wide.

    The local cell size is the median ``sqrt(|area|)`` of the ``n_near`` cells whose
    centroids are nearest; the window also holds the whole cell (a long sliver), and slides
    into the mesh's bounding box where it fits; it is the whole mesh when that is smaller.  ``centroids`` and ``areas`` (per cell)
    may be passed when already computed.
    """
    cent = _centroids(points, topo) if centroids is None else centroids
    c = cent[cell]
    d2 = ((cent - c) ** 2).sum(axis=1)
    near = np.argpartition(d2, min(n_near, d2.size) - 1)[:n_near] if d2.size > n_near else np.arange(d2.size)
    areas = cell_areas(points, topo) if areas is None else areas
    h = float(np.median(np.sqrt(np.abs(areas[near]))))
    extent = float(np.ptp(points[_cell_nodes(topo, cell)], axis=0).max())
    half = max(half_cells * h, 0.6 * extent)
    if not half > 0:
        half = 1.0
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = float((hi - lo).max())
    if 2 * half >= span > 0:  # a mesh of a few cells: the whole mesh
        mid = (lo + hi) / 2
        half = 0.55 * span
        return (float(mid[0] - half), float(mid[0] + half), float(mid[1] - half), float(mid[1] + half))
    # slide the window into the mesh's bounding box where it fits (a worst cell on the boundary)
    # (but keep the cell at least a quarter of the window away from the edges)
    x0, y0 = (float(np.clip(min(max(c[i] - half, lo[i]), max(hi[i] - 2 * half, lo[i])),
                            c[i] - 1.5 * half, c[i] - 0.5 * half)) for i in (0, 1))
    return (float(x0), float(x0 + 2 * half), float(y0), float(y0 + 2 * half))


def _cells_in(points: np.ndarray, topo: CellTopology, window) -> np.ndarray:
    """Cells whose bounding box meets ``window`` (triangles first, then quads)."""
    x0, x1, y0, y1 = window
    out = []
    for base, cells in ((0, topo.tri), (topo.n_tri, topo.quad)):
        if not cells.shape[0]:
            continue
        xs, ys = points[cells, 0], points[cells, 1]
        hit = (xs.max(1) >= x0) & (xs.min(1) <= x1) & (ys.max(1) >= y0) & (ys.min(1) <= y1)
        out.append(base + np.flatnonzero(hit))
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _split(points: np.ndarray, topo: CellTopology, cells: np.ndarray | None):
    """Triangles to draw and the cell each comes from; a quad becomes two triangles.

    A quad is split along the diagonal whose smaller half has the larger signed
    area, so a non-convex quad is covered by its two valid halves.
    """
    nt = topo.n_tri
    if cells is None:
        t_idx, q_idx = np.arange(nt), np.arange(topo.n_quad)
    else:
        cells = np.asarray(cells, dtype=np.int64)
        t_idx, q_idx = cells[cells < nt], cells[cells >= nt] - nt
    tri, quad = topo.tri[t_idx], topo.quad[q_idx]

    def area(a, b, c):
        pa, pb, pc = points[a], points[b], points[c]
        return (pb[:, 0] - pa[:, 0]) * (pc[:, 1] - pa[:, 1]) - (pb[:, 1] - pa[:, 1]) * (pc[:, 0] - pa[:, 0])

    q0, q1, q2, q3 = quad.T
    d02 = np.minimum(area(q0, q1, q2), area(q0, q2, q3)) >= np.minimum(area(q0, q1, q3), area(q1, q2, q3))
    first = np.where(d02[:, None], quad[:, [0, 1, 2]], quad[:, [0, 1, 3]])
    second = np.where(d02[:, None], quad[:, [0, 2, 3]], quad[:, [1, 2, 3]])
    tris = np.concatenate([tri, first, second])
    owner = np.concatenate([t_idx, nt + q_idx, nt + q_idx])
    return tris, owner


def _edges_of(topo: CellTopology, cells: np.ndarray | None) -> np.ndarray:
    if cells is None:
        return topo.edges
    used = np.zeros(topo.n_points, dtype=bool)
    nt = topo.n_tri
    cells = np.asarray(cells, dtype=np.int64)
    used[topo.tri[cells[cells < nt]]] = True
    used[topo.quad[cells[cells >= nt] - nt]] = True
    return topo.edges[used[topo.edges].all(axis=1)]


def _widths(points: np.ndarray, topo: CellTopology) -> np.ndarray:
    """Width of every cell: ``sqrt(2 |area|)`` for a triangle, ``sqrt(|area|)`` for a quad."""
    area = np.abs(cell_areas(points, topo))
    area[: topo.n_tri] *= 2
    return np.sqrt(area)


def edge_widths(points: np.ndarray, topo: CellTopology, edges: np.ndarray | None = None, *,
                widths: np.ndarray | None = None) -> np.ndarray:
    """The local cell width at each edge (data units): what decides whether the edge is drawn.

    A cell's width is ``sqrt(2 |area|)`` for a triangle and ``sqrt(|area|)`` for a quad
    (the side of a square of that area, a triangle being half of one); a node takes the
    mean width of its cells, an edge the mean of its two nodes.  Averaging over the cells
    around an edge keeps a long sliver edge in a fine region from being drawn alone.
    ``widths`` (per cell) may be passed when already computed.
    """
    edges = topo.edges if edges is None else edges
    widths = _widths(points, topo) if widths is None else widths
    nt, n = topo.n_tri, topo.n_points
    total = np.zeros(n)
    count = np.zeros(n)
    for cells, width in ((topo.tri, widths[:nt]), (topo.quad, widths[nt:])):
        total += np.bincount(cells.ravel(), np.repeat(width, cells.shape[1]), minlength=n)
        count += np.bincount(cells.ravel(), minlength=n)
    node = total / np.maximum(count, 1)
    return 0.5 * (node[edges[:, 0]] + node[edges[:, 1]])


def _median_width(points: np.ndarray, topo: CellTopology, cells: np.ndarray | None, widths=None) -> float:
    """Median cell width (as in :func:`edge_widths`) of ``cells`` (default: all)."""
    widths = _widths(points, topo) if widths is None else widths
    width = widths if cells is None else widths[cells]
    return float(np.median(width)) if width.size else 0.0


def edge_alpha(width_px: np.ndarray) -> np.ndarray:
    """Opacity of an edge from its local cell width on screen (pixels, see :func:`edge_widths`).

    0 (not drawn) below :data:`EDGE_MIN_PX`, then 0.2 rising to 0.8 at :data:`EDGE_FULL_PX` and above.
    """
    width_px = np.asarray(width_px, dtype=np.float64)
    ramp = np.clip((width_px - EDGE_MIN_PX) / (EDGE_FULL_PX - EDGE_MIN_PX), 0.0, 1.0)
    return np.where(width_px >= EDGE_MIN_PX, 0.2 + 0.6 * ramp, 0.0)


# ---------------------------------------------------------------- drawing


def _px_per_unit(ax) -> float:
    """Screen pixels per data unit of an equal-aspect axes whose layout is final."""
    ax.apply_aspect()
    x0, x1 = ax.get_xlim()
    return float(ax.bbox.width / abs(x1 - x0)) if x1 != x0 else 1.0


_FLAT_TRIANGLES = None


def _flat_triangles_class():
    """The artist that fills the cells (defined on first use: matplotlib is imported lazily)."""
    global _FLAT_TRIANGLES
    if _FLAT_TRIANGLES is None:
        from matplotlib import artist

        class FlatTriangles(artist.Artist):
            """Triangles ``verts`` (T, 3, 2) filled with one colour each, ``rgba`` (T, 4), in one renderer call.

            What ``tripcolor(..., shading="gouraud")`` draws, with the three corners of a triangle
            sharing its colour: flat cells without the seams of unantialiased polygons, several
            times faster than tripcolor's flat ``PolyCollection`` (one ``Path`` per cell) and with
            less than half of a ``TriMesh``'s memory (64 instead of 156 bytes per triangle: the
            corner colours exist only while drawing).
            """

            def __init__(self, verts, rgba, **kwargs):
                super().__init__()
                self.verts = np.ascontiguousarray(verts, dtype=np.float64)
                self.rgba = np.ascontiguousarray(rgba, dtype=np.float32)
                self.set(**kwargs)

            @artist.allow_rasterization
            def draw(self, renderer):
                if not self.get_visible() or not self.verts.shape[0]:
                    return
                renderer.open_group("flat_triangles", gid=self.get_gid())
                gc = renderer.new_gc()
                self._set_gc_clip(gc)
                colours = np.repeat(self.rgba[:, None, :].astype(np.float64), 3, axis=1)
                renderer.draw_gouraud_triangles(gc, self.verts, colours, self.get_transform().frozen())
                gc.restore()
                renderer.close_group("flat_triangles")

        _FLAT_TRIANGLES = FlatTriangles
    return _FLAT_TRIANGLES


def draw_mesh(ax, points: np.ndarray, topo: CellTopology, values: np.ndarray, *, norm, cmap=CMAP,
              px_per_unit: float | None = None, cells: np.ndarray | None = None) -> dict:
    """Fill the cells of ``topo`` (or the subset ``cells``) by ``values`` (one per cell), draw the visible edges.

    ``px_per_unit`` (screen pixels per data unit) decides which edges are drawn: none
    when the median cell is narrower than :data:`EDGE_MIN_PX` on screen, otherwise those
    between cells at least that wide (:func:`edge_widths`, :func:`edge_alpha`); ``None``
    draws every edge.  Returns the artists:
    ``{"cells": the filled triangles (quads split in two) or None, "edges": a LineCollection or None}``.
    """
    import matplotlib
    from matplotlib.collections import LineCollection

    points = np.asarray(points, dtype=np.float64)
    tris, owner = _split(points, topo, cells)
    artists = {"cells": None, "edges": None}
    if tris.shape[0]:
        cmap = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
        rgba = cmap(norm(np.asarray(values, dtype=np.float64)[owner]))
        mesh = _flat_triangles_class()(points[tris], rgba, rasterized=True, gid="cells")
        ax.add_artist(mesh)
        artists["cells"] = mesh
    edges = _edges_of(topo, cells)
    if px_per_unit is None:
        alpha = np.full(edges.shape[0], 0.8)
    elif _median_width(points, topo, cells, widths := _widths(points, topo)) * px_per_unit < EDGE_MIN_PX:
        alpha = np.zeros(edges.shape[0])  # most cells are too small to show their edges: none at all
    else:
        alpha = edge_alpha(edge_widths(points, topo, edges, widths=widths) * px_per_unit)
    keep = alpha > 0
    if keep.any():
        rgba = np.zeros((int(keep.sum()), 4))
        rgba[:, 3] = alpha[keep]
        lc = LineCollection(points[edges[keep]], colors=rgba, linewidths=0.45, rasterized=True, gid="edges")
        ax.add_collection(lc, autolim=False)
        artists["edges"] = lc
    return artists
