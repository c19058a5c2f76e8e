"""Benchmark meshes of any size: random Delaunay triangles, jittered quads."""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh2D
from ._common import _delaunay, _square_boundary
from .structured import structured_quads

__all__ = ["random_delaunay", "random_quad_mesh"]


def random_delaunay(n_triangles: int, seed: int = 0, size: float = 1.0) -> Mesh2D:
    """A square with about ``n_triangles`` random Delaunay triangles (exactly, when it is even).

    ``m = round(sqrt(n_triangles / 2))`` equally spaced nodes per side (about the
    interior node spacing) and ``(n_triangles - 4 m + 2) / 2`` uniformly random
    interior nodes; a triangulation of ``n`` nodes with ``b`` on the convex hull
    has ``2 n - b - 2`` triangles.  One million triangles take a few seconds.

    >>> random_delaunay(1000, seed=0).triangles.shape[0]
    1000
    """
    m = max(1, int(round(np.sqrt(n_triangles / 2.0))))
    n_in = max(1, (int(n_triangles) - 4 * m + 2) // 2)
    rng = np.random.default_rng(seed)
    pts = np.concatenate([_square_boundary(m, size), rng.uniform(0.0, size, size=(n_in, 2))])
    return Mesh2D.from_arrays(pts, triangles=_delaunay(pts))


def random_quad_mesh(n_quads: int, seed: int = 0, jitter: float = 0.24, size: float = 1.0) -> Mesh2D:
    """A jittered structured quad mesh of about ``n_quads`` quads in a square.

    An ``n x n`` grid (``n = round(sqrt(n_quads))``) whose interior nodes are
    moved by a uniform random offset in ``[-jitter h, jitter h]^2`` (``h`` the
    grid spacing).  Every quad stays strictly convex for ``jitter < 0.25`` (the
    worst case, three nodes of a corner moved towards each other, leaves a
    corner cross product of ``(1 - 4 jitter) h^2``).

    >>> random_quad_mesh(100, seed=0).quads.shape[0]
    100
    """
    n = max(1, int(round(np.sqrt(n_quads))))
    base = structured_quads(n, n)
    h = size / n
    pts = base.points * h
    interior = (pts[:, 0] > 0.5 * h) & (pts[:, 0] < size - 0.5 * h) & (pts[:, 1] > 0.5 * h) & (pts[:, 1] < size - 0.5 * h)
    rng = np.random.default_rng(seed)
    pts[interior] += rng.uniform(-jitter * h, jitter * h, size=(int(interior.sum()), 2))
    return Mesh2D.from_arrays(pts, quads=base.quads)
