"""Exceptions raised by anglesmooth.

Every error the library raises on bad input is an :class:`AngleSmoothError`; the
command line turns each into one line on stderr and the exit code in its
``exit_code`` attribute (2 usage, 3 input/output).
"""

from __future__ import annotations

__all__ = [
    "AngleSmoothError",
    "ConfigurationError",
    "GateFileError",
    "InvalidMeshError",
    "MeshReadError",
    "MeshWriteError",
    "UnknownMethodError",
    "UnsupportedMeshError",
]


class AngleSmoothError(Exception):
    """Base class of all errors raised by anglesmooth."""

    exit_code = 3


class MeshReadError(AngleSmoothError):
    """The input file cannot be read (missing, unreadable, corrupt, unknown format)."""


class MeshWriteError(AngleSmoothError):
    """The output file cannot be written."""


class UnsupportedMeshError(AngleSmoothError):
    """The mesh is readable but not a planar triangle/quad mesh (3D cells, polygons, non-planar)."""


class InvalidMeshError(AngleSmoothError):
    """The mesh is structurally invalid (bad indices, NaN coordinates, no 2D cells, ...)."""


class UnknownMethodError(AngleSmoothError):
    """A smoothing method name that is not in the registry."""

    exit_code = 2


class GateFileError(AngleSmoothError):
    """A quality-gate file that cannot be used (unreadable, invalid TOML, unknown key, bad value)."""

    exit_code = 2


class ConfigurationError(AngleSmoothError):
    """A setting from the environment that cannot be used (e.g. ``ANGLESMOOTH_KERNEL``)."""

    exit_code = 2
