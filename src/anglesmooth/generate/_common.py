"""Helpers of the generators: Delaunay (scipy, imported lazily), square boundaries, corner angles, interior edges."""

from __future__ import annotations

import numpy as np


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
