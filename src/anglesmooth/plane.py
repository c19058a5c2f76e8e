"""The plane of a planar mesh in 3D: fitted once at read time, used again at write time.

A mesh read from a file with three coordinates is smoothed in its own plane:
:func:`fit_plane` returns a :class:`PlaneFrame` (an origin and two orthonormal
in-plane axes) and the (N, 2) in-plane coordinates; :meth:`PlaneFrame.to_3d`
maps smoothed coordinates back.

* A mesh whose x, y or z column is constant (within ``1e-12`` of the mesh
  size) gets an *axis frame*: its two other columns are the plane coordinates,
  unchanged, and the constant column is never touched (the z = const case is
  what anglesmooth always did; the x-z plane of axisymmetric models is the
  same with y).
* Any other plane is found from the eigenvectors of the points' covariance (the
  SVD of the centred points); the points must lie within ``1e-8`` of the mesh
  size of that plane (plus the rounding of their coordinates), otherwise
  :class:`~anglesmooth.errors.UnsupportedMeshError` says how far off they are.

>>> import numpy as np
>>> p = np.array([[0, 0, 0], [1, 0, 1], [0, 1, 0], [1, 1, 1.0]])  # the plane z = x
>>> frame, uv = fit_plane(p)
>>> frame.columns is None, np.allclose(frame.to_3d(uv), p)
(True, True)
>>> frame, uv = fit_plane(np.array([[0, 5, 0], [1, 5, 0], [0, 5, 2.0]]))  # y = 5: x-z plane
>>> frame.columns, uv.tolist()
((0, 2), [[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import UnsupportedMeshError

__all__ = ["AXIS_TOL", "PLANE_TOL", "PlaneFrame", "describe", "fit_plane"]

AXIS_TOL = 1e-12  # a column varying by less than this x the mesh size is constant (as before)
PLANE_TOL = 1e-8  # largest distance from the fitted plane, x the mesh size
_NAMES = "xyz"


@dataclass(frozen=True, eq=False)
class PlaneFrame:
    """Origin (3,) and orthonormal in-plane axes (2, 3) of a planar mesh in 3D.

    ``columns`` is set for an axis frame: the two coordinate columns that are
    the plane coordinates (the third is constant and never written).
    """

    origin: np.ndarray
    axes: np.ndarray
    columns: tuple[int, int] | None = None

    @property
    def normal(self) -> np.ndarray:
        return np.cross(self.axes[0], self.axes[1])

    def to_plane(self, points3: np.ndarray) -> np.ndarray:
        """(N, 3) points -> (N, 2) plane coordinates."""
        p = np.asarray(points3, dtype=np.float64)
        if self.columns is not None:
            return np.ascontiguousarray(p[:, list(self.columns)])
        d = p - self.origin
        return np.column_stack([d @ self.axes[0], d @ self.axes[1]])

    def to_3d(self, uv: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
        """(N, 2) plane coordinates -> (N, 3) points.

        With ``base`` (the original (N, 3) points), rows whose plane coordinates
        equal ``self.to_plane(base)`` exactly are copied from ``base`` bit for
        bit (fixed nodes); for an axis frame only the two plane columns of
        ``base`` are replaced.
        """
        uv = np.asarray(uv, dtype=np.float64)
        if self.columns is not None:
            out = np.zeros((uv.shape[0], 3)) if base is None else np.array(base, dtype=np.float64, copy=True)
            out[:, self.columns[0]] = uv[:, 0]
            out[:, self.columns[1]] = uv[:, 1]
            return out
        new = self.origin + uv[:, :1] * self.axes[0] + uv[:, 1:2] * self.axes[1]
        if base is None:
            return new
        out = np.array(base, dtype=np.float64, copy=True)
        moved = (uv != self.to_plane(base)).any(axis=1)
        out[moved] = new[moved]
        return out


def _num(value: float, spec: str) -> str:
    """``value`` formatted with ``spec``, a negative zero (an eigenvector's -0.0) printed as 0.

    >>> _num(-0.0, ".3g"), _num(-1e-300 * 1e-300, ".3g"), _num(-0.5, ".3g")
    ('0', '0', '-0.5')
    """
    return format(float(value) + 0.0, spec)


def _size(p: np.ndarray) -> float:
    return max(float(np.ptp(p[:, k])) for k in range(p.shape[1]))  # per column: faster than axis=0 on (N, 3)


def fit_plane(points3: np.ndarray) -> tuple[PlaneFrame, np.ndarray]:
    """The plane frame of (N, 3) points and their (N, 2) plane coordinates.

    Raises
    ------
    UnsupportedMeshError
        When the points are not coplanar within :data:`PLANE_TOL` x the mesh size.
    """
    p = np.asarray(points3, dtype=np.float64)
    size = _size(p)
    for k in (2, 1, 0):  # z = const first: the classic case, bit-identical to before
        col = p[:, k]
        if float(col.max()) - float(col.min()) <= AXIS_TOL * size:
            cols = tuple(c for c in range(3) if c != k)
            axes = np.eye(3)[list(cols)]
            frame = PlaneFrame(np.zeros(3), axes, cols)  # type: ignore[arg-type]
            return frame, frame.to_plane(p)
    origin = p.mean(axis=0)
    d = p - origin
    cov = d.T @ d
    _, vecs = np.linalg.eigh(cov)  # ascending eigenvalues: the last two span the plane
    e1, e2, n = vecs[:, 2], vecs[:, 1], vecs[:, 0]
    if n[np.argmax(np.abs(n))] < 0:  # a deterministic orientation: the normal's largest component positive
        n = -n
    e2 = np.cross(n, e1)
    dist = np.abs(d @ n)
    scale = float(np.abs(p).max()) if p.size else 0.0
    tol = PLANE_TOL * size + 8 * np.finfo(np.float64).eps * scale
    worst = int(np.argmax(dist)) if dist.size else 0
    if dist.size and dist[worst] > tol:
        normal = ", ".join(_num(v, ".3g") for v in n)
        raise UnsupportedMeshError(
            f"mesh is not planar: node {worst} lies {dist[worst]:.3g} from the best-fit plane "
            f"(normal ({normal})), more than the tolerance {tol:.3g} ({PLANE_TOL:g} x the mesh size {size:.3g})"
        )
    frame = PlaneFrame(origin, np.stack([e1, e2]))
    return frame, frame.to_plane(p)


def describe(frame: PlaneFrame | None) -> str:
    """'x-y plane', 'x-z plane' or 'plane through (..) with normal (..)', for reports."""
    if frame is None:
        return "x-y plane"
    if frame.columns is not None:
        return f"{_NAMES[frame.columns[0]]}-{_NAMES[frame.columns[1]]} plane"
    o = ", ".join(_num(v, ".4g") for v in frame.origin)
    n = ", ".join(_num(v, ".4g") for v in frame.normal)
    return f"plane through ({o}) with normal ({n})"
