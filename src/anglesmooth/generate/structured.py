"""Regular meshes: equilateral or right triangles, unit squares."""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh2D

__all__ = ["structured_quads", "structured_triangles"]


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
