"""Seeded test meshes: the paper's examples and meshes for benchmarks.

Every generator returns a :class:`~anglesmooth.mesh.Mesh2D` with
counter-clockwise cells and no inverted or degenerate cell, and is deterministic
for a given ``seed`` (``numpy.random.default_rng(seed)``).  Everything is
vectorized numpy, so a million-triangle mesh takes a few seconds (mostly
Delaunay).

The meshes of Zhou & Shimada (2000), "An angle-based approach to
two-dimensional mesh smoothing", Section 5, and how each is built where the
paper is silent:

* :func:`paper_triangle_mesh` -- Section 5.1.2: 500 uniformly random interior
  nodes in a 100 x 100 square, 20 equally spaced nodes per side, Delaunay:
  exactly 580 nodes and 1078 triangles.
* :func:`paper_mixed_mesh` -- Section 5.1.2: the same triangulation with
  adjacent triangles greedily merged into convex quads (about 262 triangles and
  408 quads; 262 + 2 * 408 = 1078, so the paper's mixed mesh is exactly such a
  pairing of a 580-node triangulation).
* :func:`graded_mesh` -- Section 5.1.3: 100 + 100 + 100 random nodes in the
  whole square, its lower-left quarter and lower-left 1/16, 48 boundary nodes.
* :func:`paper_quad_mesh` -- Section 5.4: an all-quad mesh of exactly 571 nodes
  and 530 quads (Euler's formula then forces 80 boundary nodes: 20 per side).
* :func:`five_element_polygon` -- Figures 2, 3 and 12: one free node inside an
  irregular pentagon.
* :func:`distorted_mesh` -- Figure 8: a star-shaped ring whose vertex centroid
  lies outside the ring's kernel, so Laplacian smoothing inverts a triangle.

scipy (for Delaunay) is only needed by the random triangle generators and is
imported lazily.

Modules: ``convert`` (triangle -> quad conversions), ``structured``, ``benchmark``
(random meshes of any size) and ``paper``; everything public is imported here:
``from anglesmooth.generate import X``.

>>> m = structured_quads(3, 2)
>>> m.n_points, m.quads.shape[0]
(12, 6)
"""

from __future__ import annotations

from .benchmark import random_delaunay, random_quad_mesh
from .convert import pair_triangles, split_to_quads
from .paper import (distorted_mesh, five_element_polygon, five_element_starts, graded_mesh, paper_mixed_mesh,
                    paper_quad_mesh, paper_triangle_mesh)
from .structured import structured_quads, structured_triangles

__all__ = [
    "distorted_mesh",
    "five_element_polygon",
    "five_element_starts",
    "graded_mesh",
    "pair_triangles",
    "paper_mixed_mesh",
    "paper_quad_mesh",
    "paper_triangle_mesh",
    "random_delaunay",
    "random_quad_mesh",
    "split_to_quads",
    "structured_quads",
    "structured_triangles",
]

