"""The meshes of Zhou & Shimada (2000), Section 5 (see the package notes for how each is built)."""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh2D
from ._common import _delaunay, _square_boundary
from .convert import pair_triangles, split_to_quads

__all__ = ["distorted_mesh", "five_element_polygon", "five_element_starts", "graded_mesh", "paper_mixed_mesh",
           "paper_quad_mesh", "paper_triangle_mesh"]


def paper_triangle_mesh(seed: int = 0, n_interior: int = 500, per_side: int = 20, size: float = 100.0) -> Mesh2D:
    """The random Delaunay triangle mesh of Section 5.1.2.

    ``n_interior`` uniformly random nodes in the open square ``(0, size)^2`` plus
    ``per_side`` equally spaced nodes on each side (corners counted once), then
    Delaunay.  With the defaults: 580 nodes, 80 of them on the boundary, and
    ``2 * 580 - 80 - 2 = 1078`` triangles, as in the paper.  ``size = 100``
    puts the areas on the paper's scale (Table 3: mean area 9.3; the paper's
    original mesh ranges over 0.01 .. 60.36).

    Boundary nodes come first (counter-clockwise from the origin), then the
    interior nodes.

    >>> m = paper_triangle_mesh(seed=1)
    >>> m.n_points, m.triangles.shape[0]
    (580, 1078)
    """
    rng = np.random.default_rng(seed)
    bnd = _square_boundary(per_side, size)
    inner = rng.uniform(0.0, size, size=(n_interior, 2))
    pts = np.concatenate([bnd, inner])
    return Mesh2D.from_arrays(pts, triangles=_delaunay(pts))


def paper_mixed_mesh(
    seed: int = 0,
    n_interior: int = 500,
    per_side: int = 20,
    size: float = 100.0,
    max_angle: float = 160.0,
    longest_edge: bool = False,
) -> Mesh2D:
    """The tri-quad mixed mesh of Section 5.1.2.

    The paper's counts (580 nodes, 262 triangles, 408 quads) satisfy
    ``262 + 2 * 408 = 1078``: its mixed mesh is a 580-node triangulation with 408
    triangle pairs merged.  We take :func:`paper_triangle_mesh` (same seed) and
    merge pairs with :func:`pair_triangles`: greedy matching on quad quality
    (``1 - max|angle - 90°| / 90°``, best pair first), only when the merged quad
    is convex with every angle below ``max_angle`` (160°).  Over seeds 0..19
    this gives 389..414 quads (mean 403) and 250..300 triangles (paper: 408 and
    262); the node count is 580.  (Merging only across longest edges gives
    fewer quads, about 375 at 160°.)

    >>> m = paper_mixed_mesh(seed=1)
    >>> m.n_points, m.triangles.shape[0] + 2 * m.quads.shape[0]
    (580, 1078)
    """
    base = paper_triangle_mesh(seed, n_interior, per_side, size)
    tri, quad = pair_triangles(base.points, base.triangles, max_angle=max_angle, longest_edge=longest_edge)
    return Mesh2D.from_arrays(base.points, triangles=tri, quads=quad)


def graded_mesh(seed: int = 0, size: float = 100.0, per_layer: int = 100, per_side: int = 12) -> Mesh2D:
    """The graded mesh of Section 5.1.3 (Figure 11).

    ``per_layer`` random nodes in the whole square, ``per_layer`` in its
    lower-left quarter ``[0, size/2)^2`` and ``per_layer`` in its lower-left 1/16
    ``[0, size/4)^2``, plus ``4 * per_side`` equally spaced boundary nodes (48 by
    default), Delaunay.  Defaults: 348 nodes, ``2 * 348 - 48 - 2 = 646`` triangles.

    >>> m = graded_mesh(seed=2)
    >>> m.n_points, m.triangles.shape[0]
    (348, 646)
    """
    rng = np.random.default_rng(seed)
    layers = [rng.uniform(0.0, size / s, size=(per_layer, 2)) for s in (1, 2, 4)]
    # a random node exactly on x = 0 or y = 0 has probability zero; keep them off the boundary anyway
    inner = np.concatenate(layers)
    inner = np.clip(inner, 1e-9 * size, size * (1 - 1e-9))
    pts = np.concatenate([_square_boundary(per_side, size), inner])
    return Mesh2D.from_arrays(pts, triangles=_delaunay(pts))


def paper_quad_mesh(seed: int = 0, size: float = 100.0, n_interior: int = 90, per_side: int = 10) -> Mesh2D:
    """An all-quad mesh like the one of Section 5.4: exactly 571 nodes and 530 quads.

    For an all-quad mesh of a disc Euler's formula gives ``V = 1 + F + Vb / 2``,
    so the paper's 571 nodes and 530 quads mean 80 boundary nodes (20 per side)
    and an unstructured interior.  We build it as: a random Delaunay mesh with
    ``n_interior`` random interior nodes and ``per_side`` boundary nodes per side
    (defaults: 130 nodes, 218 triangles), the best 62 triangle pairs merged into
    quads (:func:`pair_triangles`), then every cell split into quads through its
    edge midpoints and centroid (:func:`split_to_quads`): ``3 * 94 + 4 * 62 =
    530`` quads, ``130 + 285 edges + 94 + 62 = 571`` nodes, 20 equally spaced
    boundary nodes per side.  The random Delaunay input leaves small and large,
    skewed quads to smooth (area ratio of order 100, as in the paper's Table 3).

    >>> m = paper_quad_mesh(seed=3)
    >>> m.n_points, m.quads.shape[0]
    (571, 530)
    """
    rng = np.random.default_rng(seed)
    pts = np.concatenate([_square_boundary(per_side, size), rng.uniform(0.0, size, size=(n_interior, 2))])
    tri = _delaunay(pts)
    n_target = 530 if (n_interior, per_side) == (90, 10) else None
    max_pairs = None
    if n_target is not None:
        max_pairs = (3 * tri.shape[0] - n_target) // 2
    t, q = pair_triangles(pts, tri, max_angle=170.0, longest_edge=False, max_pairs=max_pairs)
    p2, quads = split_to_quads(pts, t, q)
    return Mesh2D.from_arrays(p2, quads=quads)


_PENTAGON = np.array([[2.5, 1.0], [4.0, 2.0], [5.0, 3.0], [6.5, 5.0], [2.0, 4.5]])


def five_element_polygon(center=None) -> Mesh2D:
    """The 5-element polygon of Figures 2, 3 and 12: one free node, 5 triangles.

    An irregular convex pentagon (nodes 0 .. 4, counter-clockwise) whose three
    lower-right vertices are bunched together, and a central node 5 at
    ``center`` (default ``(3.0, 2.5)``, off both optima).  The bunched vertices
    pull the Laplacian optimum (the vertex centroid) to ``(4.0, 3.1)``, where the
    minimum angle is 15.9°; the fixed point of the literal angle-based step is
    about ``(3.468, 3.488)``, 0.66 away, with a minimum angle of 20.2°.  From
    each start of :func:`five_element_starts` the displacement of pass 10 is
    0.07 % .. 1.1 % of that of pass 1 (the paper reports 0.1 %).
    :func:`five_element_starts` gives three starting positions for Figure 12.

    >>> m = five_element_polygon((3.0, 3.0))
    >>> m.n_points, m.triangles.shape[0], m.points[5].tolist()
    (6, 5, [3.0, 3.0])
    """
    c = np.array([3.0, 2.5] if center is None else center, dtype=np.float64).reshape(2)
    pts = np.concatenate([_PENTAGON, c[None]])
    tri = np.stack([np.arange(5), (np.arange(5) + 1) % 5, np.full(5, 5)], axis=1)
    return Mesh2D.from_arrays(pts, triangles=tri)


def five_element_starts() -> np.ndarray:
    """Three starting positions of the central node for Figure 12, in three corners of the pentagon.

    >>> five_element_starts().shape
    (3, 2)
    """
    return np.array([[3.0, 1.8], [5.2, 4.0], [3.0, 4.0]])


# Figure 8: a "V"-shaped ring (arms up, reflex notch vertex at (0, 1)) around a
# centre node at the origin.  The arms' vertices pull the vertex centroid up to
# (0, 0.625), above the lines through the arms' inner edges, i.e. outside the
# ring's kernel (on the axis the kernel ends at y = 1/14).
_DISTORTED_RING = np.array(
    [[0.0, -2.0], [2.0, -2.0], [6.0, 3.5], [2.5, 1.5], [0.0, 1.0], [-2.5, 1.5], [-6.0, 3.5], [-2.0, -2.0]]
)


def distorted_mesh() -> Mesh2D:
    """A severely distorted single-node mesh like Figure 8.

    Eight ring nodes (0 .. 7) forming a "V" (two arms going up, a reflex notch
    vertex 4 at ``(0, 1)``) around one free node 8 at the origin; the minimum
    angle is 0.51°.  The ring is star-shaped from the origin, but its vertex
    centroid ``(0, 0.625)`` lies outside the ring's kernel (above the lines
    through the arms' inner edges), so moving the centre node there (one
    unguarded Laplacian step) inverts two triangles.  The literal angle-based
    step moves it down instead, to about ``(0, -1.2)`` after 10 passes, with a
    minimum angle of 8.3° and no inverted triangle.

    >>> m = distorted_mesh()
    >>> m.n_points, m.triangles.shape[0]
    (9, 8)
    """
    pts = np.concatenate([_DISTORTED_RING, [[0.0, 0.0]]])
    k = _DISTORTED_RING.shape[0]
    tri = np.stack([np.arange(k), (np.arange(k) + 1) % k, np.full(k, k)], axis=1)
    return Mesh2D.from_arrays(pts, triangles=tri)
