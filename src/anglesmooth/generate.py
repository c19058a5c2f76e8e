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

>>> m = structured_quads(3, 2)
>>> m.n_points, m.quads.shape[0]
(12, 6)
"""

from __future__ import annotations

import numpy as np

from .mesh import Mesh2D

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


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def _delaunay(points: np.ndarray) -> np.ndarray:
    """Delaunay triangles of ``points``, counter-clockwise, degenerate ones dropped."""
    try:
        from scipy.spatial import Delaunay
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "anglesmooth.generate needs scipy for Delaunay triangulation: pip install 'anglesmooth[bench]'"
        ) from exc
    tri = np.ascontiguousarray(Delaunay(points).simplices, dtype=np.int64)
    return _ccw_nondegenerate(points, tri)


def _ccw_nondegenerate(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    p0, p1, p2 = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    cross = (p1[:, 0] - p0[:, 0]) * (p2[:, 1] - p0[:, 1]) - (p1[:, 1] - p0[:, 1]) * (p2[:, 0] - p0[:, 0])
    tri = tri.copy()
    neg = cross < 0
    tri[neg] = tri[neg][:, ::-1]
    # a triangle of three collinear boundary nodes has zero area: drop it
    scale = np.abs(cross).max() if cross.size else 1.0
    return tri[np.abs(cross) > 1e-14 * scale]


def _square_boundary(per_side: int, size: float) -> np.ndarray:
    """``4 * per_side`` equally spaced nodes on the square's sides, counter-clockwise, corners once."""
    t = np.arange(per_side) * (size / per_side)
    z = np.zeros(per_side)
    s = np.full(per_side, size)
    return np.concatenate(
        [
            np.stack([t, z], 1),  # bottom, left to right
            np.stack([s, t], 1),  # right, bottom to top
            np.stack([size - t, s], 1),  # top, right to left
            np.stack([z, size - t], 1),  # left, top to bottom
        ]
    )


def _cross2(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _corner_angles(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Interior angles (radians) at every corner of counter-clockwise polygons ``cells`` (m, k)."""
    p = points[cells]
    u = np.roll(p, 1, axis=1) - p
    v = np.roll(p, -1, axis=1) - p
    # angle from v (next) counter-clockwise to u (prev): > pi at a reflex corner
    return np.mod(np.arctan2(_cross2(v, u), np.einsum("...i,...i", u, v)), 2 * np.pi)


def _interior_edges(tri: np.ndarray, n: int):
    """Interior edges of a triangle mesh as (t1, k1, t2, k2): triangles and the local index of the opposite corner."""
    nt = tri.shape[0]
    a = np.roll(tri, -1, axis=1).ravel()  # edge opposite corner k is (tri[k+1], tri[k+2])
    b = np.roll(tri, -2, axis=1).ravel()
    key = np.minimum(a, b) * np.int64(n) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    dup = np.flatnonzero(ks[1:] == ks[:-1])
    h1, h2 = order[dup], order[dup + 1]
    return h1 // 3, h1 % 3, h2 // 3, h2 % 3, np.arange(nt)


# --------------------------------------------------------------------------
# triangle -> quad conversions
# --------------------------------------------------------------------------
def pair_triangles(
    points,
    triangles,
    *,
    max_angle: float = 180.0,
    longest_edge: bool = False,
    max_pairs: int | None = None,
):
    """Merge adjacent triangles into convex quads by greedy matching on quad quality.

    Candidate pairs are the interior edges whose two triangles form a strictly
    convex quad with every corner angle below ``max_angle`` degrees; with
    ``longest_edge`` the shared edge must also be the longest edge of at least
    one of the two triangles (merging across a short edge makes a kite, not a
    quad).  The quality of a candidate is ``1 - max|corner angle - 90| / 90``.
    Candidates are accepted best first, each triangle at most once: the greedy
    matching, computed in vectorized rounds (a candidate is accepted in a round
    when it is the best remaining candidate of both its triangles, which gives
    exactly the sequential greedy result).

    Parameters
    ----------
    points : (N, 2) array
    triangles : (nt, 3) int array, counter-clockwise
    max_angle : float
        Largest corner angle (degrees) allowed in a merged quad.
    longest_edge : bool
        Only merge across an edge that is the longest of one of its triangles.
    max_pairs : int, optional
        Keep only the best ``max_pairs`` accepted pairs.

    Returns
    -------
    triangles : (nt - 2 p, 3) int array
        The triangles left unpaired.
    quads : (p, 4) int array
        The merged quads, counter-clockwise.

    >>> pts = np.array([[0., 0], [1, 0], [1, 1], [0, 1]])
    >>> t, q = pair_triangles(pts, np.array([[0, 1, 2], [0, 2, 3]]))
    >>> t.shape, q.tolist()
    ((0, 3), [[1, 2, 3, 0]])
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    t1, k1, t2, k2, _ = _interior_edges(tri, pts.shape[0])
    o1 = tri[t1, k1]
    p = tri[t1, (k1 + 1) % 3]
    q = tri[t1, (k1 + 2) % 3]
    o2 = tri[t2, k2]
    quads = np.stack([o1, p, o2, q], axis=1)
    ang = np.degrees(_corner_angles(pts, quads))
    ok = (ang > 1e-6).all(axis=1) & (ang < max_angle).all(axis=1)
    if longest_edge:
        e = np.linalg.norm(pts[np.roll(tri, -1, 1)] - pts[np.roll(tri, -2, 1)], axis=2)  # edge opposite corner k
        longest = np.argmax(e, axis=1)
        ok &= (longest[t1] == k1) | (longest[t2] == k2)
    quality = 1.0 - np.abs(ang - 90.0).max(axis=1) / 90.0
    cand = np.flatnonzero(ok)
    # rank: higher is better; ties broken by edge order (deterministic)
    order = cand[np.lexsort((-cand, quality[cand]))]
    rank = np.empty(quads.shape[0], np.int64)
    rank[order] = np.arange(order.shape[0])
    live = order
    nt = tri.shape[0]
    taken = np.zeros(nt, bool)
    accepted = []
    while live.size:
        best = np.full(nt, -1, np.int64)
        np.maximum.at(best, t1[live], rank[live])
        np.maximum.at(best, t2[live], rank[live])
        win = live[(best[t1[live]] == rank[live]) & (best[t2[live]] == rank[live])]
        accepted.append(win)
        taken[t1[win]] = True
        taken[t2[win]] = True
        live = live[~(taken[t1[live]] | taken[t2[live]])]
    acc = np.concatenate(accepted) if accepted else np.zeros(0, np.int64)
    acc = acc[np.argsort(-rank[acc], kind="stable")]  # best first
    if max_pairs is not None:
        acc = acc[:max_pairs]
    used = np.zeros(nt, bool)
    used[t1[acc]] = True
    used[t2[acc]] = True
    return tri[~used], quads[np.sort(acc)]


def split_to_quads(points, triangles=None, quads=None):
    """Split every triangle into 3 quads and every quad into 4 (edge midpoints + cell centroid).

    New nodes are appended after the old ones: edge midpoints (in sorted edge
    order), then triangle centroids, then quad centroids.  Convex cells give
    convex quads.

    Returns
    -------
    points : (N', 2) array
    quads : (3 nt + 4 nq, 4) int array, counter-clockwise if the input was

    >>> p, q = split_to_quads([[0., 0], [1, 0], [0, 1]], [[0, 1, 2]])
    >>> p.shape, q.shape
    ((7, 2), (3, 4))
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.zeros((0, 3), np.int64) if triangles is None else np.asarray(triangles, np.int64).reshape(-1, 3)
    quad = np.zeros((0, 4), np.int64) if quads is None else np.asarray(quads, np.int64).reshape(-1, 4)
    n = pts.shape[0]
    # directed edges (c[k], c[k+1]) of each cell, in cell order
    ea = np.concatenate([tri.ravel(), quad.ravel()])
    eb = np.concatenate([np.roll(tri, -1, 1).ravel(), np.roll(quad, -1, 1).ravel()])
    key = np.minimum(ea, eb) * np.int64(n) + np.maximum(ea, eb)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.ones(ks.shape[0], bool)
    first[1:] = ks[1:] != ks[:-1]
    uid = np.empty(ks.shape[0], np.int64)
    uid[order] = np.cumsum(first) - 1
    uk = ks[first]
    mid = 0.5 * (pts[uk // n] + pts[uk % n])
    ne = uk.shape[0]
    nt, nq = tri.shape[0], quad.shape[0]
    tc = pts[tri].mean(axis=1)
    qc = pts[quad].mean(axis=1)
    new_pts = np.concatenate([pts, mid, tc, qc])
    out = []
    for cells, k, off, cstart in ((tri, 3, 0, n + ne), (quad, 4, 3 * nt, n + ne + nt)):
        m = cells.shape[0]
        if not m:
            continue
        e_next = (n + uid[off : off + k * m]).reshape(m, k)  # midpoint of edge (c[j], c[j+1])
        e_prev = np.roll(e_next, 1, axis=1)  # midpoint of edge (c[j-1], c[j])
        centre = np.broadcast_to((cstart + np.arange(m))[:, None], (m, k))
        out.append(np.stack([cells, e_next, centre, e_prev], axis=2).reshape(-1, 4))
    return new_pts, (np.concatenate(out) if out else np.zeros((0, 4), np.int64))


# --------------------------------------------------------------------------
# the paper's meshes
# --------------------------------------------------------------------------
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


# --------------------------------------------------------------------------
# benchmark meshes
# --------------------------------------------------------------------------
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


def structured_triangles(nx: int, ny: int, equilateral: bool = True) -> Mesh2D:
    """A regular triangle mesh with ``2 nx ny`` triangles.

    With ``equilateral`` (default) every triangle is equilateral with unit
    edges: ``ny + 1`` rows of ``nx + 1`` nodes, row ``j`` at height
    ``j sqrt(3)/2`` and shifted right by 1/2 on odd rows (so the left and right
    sides zigzag; every interior node has six neighbours at 60°).  Otherwise
    unit squares each cut by the diagonal from lower left to upper right.

    >>> m = structured_triangles(4, 3)
    >>> m.n_points, m.triangles.shape[0]
    (20, 24)
    """
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))  # (ny+1, nx+1), row-major by j
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    if equilateral:
        x = i + 0.5 * (j % 2)
        y = j * (np.sqrt(3.0) / 2.0)
    else:
        x, y = i.astype(float), j.astype(float)
    pts = np.stack([x.ravel(), y.ravel()], axis=1).astype(np.float64)
    b0, b1 = idx[:-1, :-1], idx[:-1, 1:]  # bottom row nodes i, i+1
    t0, t1 = idx[1:, :-1], idx[1:, 1:]  # top row nodes i, i+1
    if equilateral:
        even = (np.arange(ny) % 2 == 0)[:, None]
        # even strip (top shifted right): (b0, b1, t0), (b1, t1, t0); odd strip: (b0, b1, t1), (b0, t1, t0)
        up = np.where(even[..., None], np.stack([b0, b1, t0], -1), np.stack([b0, b1, t1], -1))
        down = np.where(even[..., None], np.stack([b1, t1, t0], -1), np.stack([b0, t1, t0], -1))
    else:
        up = np.stack([b0, b1, t1], -1)
        down = np.stack([b0, t1, t0], -1)
    tri = np.stack([up, down], axis=2).reshape(-1, 3)
    return Mesh2D.from_arrays(pts, triangles=tri)


def structured_quads(nx: int, ny: int) -> Mesh2D:
    """``nx x ny`` unit squares; node ``(i, j)`` is ``j (nx + 1) + i`` at ``(i, j)``.

    >>> structured_quads(2, 2).quads[0].tolist()
    [0, 1, 4, 3]
    """
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    pts = np.stack([i.ravel(), j.ravel()], axis=1).astype(np.float64)
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], axis=-1).reshape(-1, 4)
    return Mesh2D.from_arrays(pts, quads=quads)


# --------------------------------------------------------------------------
# single-node examples
# --------------------------------------------------------------------------
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
