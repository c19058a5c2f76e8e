"""anglesmooth: angle-based smoothing of 2D finite-element meshes (Zhou & Shimada 2000).

The public API::

    import anglesmooth
    mesh = anglesmooth.read("in.msh")                 # Mesh2D
    result = anglesmooth.smooth(mesh, "angle", passes=10)
    anglesmooth.write(mesh, "out.vtu", points=result.points)
    anglesmooth.summarize(result.points, result.topology)["min_angle"]

meshio is imported only when :func:`read` or :func:`write` is called.

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
         "build_cell_topology": "topology", "build_topology": "topology"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
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
    "read",
    "smooth",
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
    """Write ``mesh`` (optionally with new ``points``) atomically (see :func:`anglesmooth.io.write`)."""
    from .io import write as _write

    _write(mesh, path, points=points, file_format=file_format, binary=binary)
