"""anglesmooth: angle-based smoothing of 2D finite-element meshes (Zhou & Shimada 2000).

The public API::

    import anglesmooth
    mesh = anglesmooth.read("in.msh")                 # Mesh2D
    result = anglesmooth.smooth(mesh, "angle", passes=10)
    anglesmooth.write(mesh, "out.vtu", points=result.points)
    anglesmooth.summarize(result.points, result.topology)["min_angle"]

meshio is imported only when :func:`read` or :func:`write` is called.

A ``meshio.Mesh`` is accepted wherever a :class:`Mesh2D` is taken (:func:`smooth`,
:func:`write`, :func:`build_topology`, :func:`build_cell_topology`), and
``result.to_meshio()`` / ``mesh.to_meshio()`` give one back with everything of
the input kept (cell blocks, point / cell / field data, z or the mesh's plane)::

    result = anglesmooth.smooth(meshio.read("in.msh"))
    meshio.write("out.vtu", result.to_meshio())

>>> import meshio
>>> from anglesmooth import build_topology, smooth
>>> m = meshio.Mesh([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [0.3, 0.4, 0]],
...                 [("triangle", [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])],
...                 point_data={"T": [0.0, 1, 2, 3, 4]})
>>> out = smooth(m, "laplacian", passes=1).to_meshio()
>>> out.points[4].tolist(), out.point_data["T"].tolist(), m.points[4].tolist()
([1.0, 1.0, 0.0], [0.0, 1.0, 2.0, 3.0, 4.0], [0.3, 0.4, 0.0])
>>> int(build_topology(m).fixed.sum())
4

>>> import numpy as np
>>> from anglesmooth import Mesh2D, SMOOTHERS, smooth
>>> mesh = Mesh2D.from_arrays([[0, 0], [2, 0], [2, 2], [0, 2], [0.3, 0.4]],
...                           triangles=[[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
>>> result = smooth(mesh, "laplacian", passes=1)
>>> result.points[4].tolist()
[1.0, 1.0]
>>> sorted(SMOOTHERS) == sorted(["angle", "laplacian", "smart-laplacian", "optimization"])
True
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING

from .__about__ import __version__
from .errors import (
    AngleSmoothError,
    InvalidMeshError,
    MeshReadError,
    MeshWriteError,
    UnknownMethodError,
    UnsupportedMeshError,
)

# numpy and the numerical modules load on first use (PEP 562): ``import anglesmooth`` and the
# command line's start-up stay cheap, so a Ctrl-C while they load is handled by the CLI
_LAZY = {"SmoothResult": "driver", "smooth": "driver", "Mesh2D": "mesh", "summarize": "quality",
         "SMOOTHERS": "smoothers", "CellTopology": "topology", "Topology": "topology",
         "build_cell_topology": "topology", "build_topology": "topology",
         "FileResult": "batch", "check_files": "batch", "smooth_files": "batch"}


_TAKE_MESHIO = ("build_cell_topology", "build_topology")  # smooth and write convert themselves


def _accepts_meshio(fn):
    """``fn(mesh, ...)`` that also takes a ``meshio.Mesh`` (converted as :func:`read` would)."""

    @functools.wraps(fn)
    def wrapper(mesh, *args, **kwargs):
        from .mesh import Mesh2D

        if not isinstance(mesh, Mesh2D):
            from .io import as_mesh2d

            mesh = as_mesh2d(mesh)
        return fn(mesh, *args, **kwargs)

    return wrapper


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        if name in _TAKE_MESHIO:
            value = _accepts_meshio(value)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np

    from .mesh import Mesh2D

__all__ = [
    "SMOOTHERS",
    "AngleSmoothError",
    "CellTopology",
    "FileResult",
    "InvalidMeshError",
    "Mesh2D",
    "MeshReadError",
    "MeshWriteError",
    "SmoothResult",
    "Topology",
    "UnknownMethodError",
    "UnsupportedMeshError",
    "__version__",
    "build_cell_topology",
    "build_topology",
    "check_files",
    "read",
    "smooth",
    "smooth_files",
    "summarize",
    "write",
]


def read(path: str | Path, *, file_format: str | None = None) -> Mesh2D:
    """Read a mesh file into a :class:`Mesh2D` (see :func:`anglesmooth.io.read`)."""
    from .io import read as _read

    return _read(path, file_format=file_format)


def write(
    mesh: Mesh2D,
    path: str | Path,
    *,
    points: np.ndarray | None = None,
    file_format: str | None = None,
    binary: bool | None = None,
) -> None:
    """Write ``mesh`` (a Mesh2D or a meshio.Mesh, optionally with new ``points``) atomically (see :func:`anglesmooth.io.write`)."""
    from .io import write as _write

    _write(mesh, path, points=points, file_format=file_format, binary=binary)
