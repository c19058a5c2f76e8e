"""Format names, their aliases, and the encoding (ASCII / binary) of an input file.

Format names are meshio's (``gmsh``, ``vtu``, ``xdmf``, ...) plus ``gmsh22``,
``gmsh40``, ``gmsh41`` for a given MSH version; every file extension meshio
knows is an alias of its format without the dot (``msh`` = ``gmsh``, ``xmf`` =
``xdmf``, ``inp`` = ``abaqus``, ...), and ``msh22`` / ``msh40`` / ``msh41`` name
the MSH versions.  An unknown name is an :class:`UnknownFormatError` (a usage
error, exit code 2) that lists every name.

>>> resolve("msh"), resolve("MSH41"), resolve("vtu"), resolve("xmf")
('gmsh', 'gmsh41', 'vtu', 'xdmf')
>>> resolve("foo")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
anglesmooth.formats.UnknownFormatError: unknown format 'foo'; formats: abaqus, ...; aliases: avs=avsucd, ...
"""

from __future__ import annotations

import re
from pathlib import Path

from .errors import AngleSmoothError

__all__ = ["BINARY_CHOICE", "UnknownFormatError", "all_names", "detect_binary", "resolve"]

# formats whose writer has an ASCII / binary choice (xdmf: inline XML / HDF5)
BINARY_CHOICE = ("gmsh", "gmsh22", "gmsh40", "gmsh41", "vtu", "vtk", "ply", "stl", "xdmf", "flac3d", "mdpa", "ansys")
_EXTRA = {"msh22": "gmsh22", "msh40": "gmsh40", "msh41": "gmsh41", "msh2": "gmsh22", "msh4": "gmsh41"}


class UnknownFormatError(AngleSmoothError):
    """A format name that is neither a meshio format nor an alias (a usage error)."""

    exit_code = 2


def _tables() -> tuple[list[str], dict[str, str]]:
    import meshio
    from meshio._helpers import _writer_map, reader_map

    names = sorted(set(reader_map) | set(_writer_map) | {"gmsh40", "gmsh41"})
    aliases: dict[str, str] = {}
    for ext, types in meshio.extension_to_filetypes.items():
        key = ext.lstrip(".").lower()
        if key in names:
            continue
        aliases[key] = "gmsh" if "gmsh" in types else types[0]
    aliases.update(_EXTRA)
    return names, dict(sorted(aliases.items()))


def all_names() -> str:
    """'formats: a, b, ...; aliases: x=y, ...' (for help and error texts, never cut)."""
    names, aliases = _tables()
    return f"formats: {', '.join(names)}; aliases: {', '.join(f'{k}={v}' for k, v in aliases.items())}"


def resolve(name: str | None) -> str | None:
    """The format name for a format name or alias (case-insensitive); None stays None."""
    if name is None:
        return None
    names, aliases = _tables()
    key = str(name).strip().lower().lstrip(".")
    if key in names:
        return key
    if key in aliases:
        return aliases[key]
    raise UnknownFormatError(f"unknown format '{name}'; {all_names()}")


_VTU_FORMAT = re.compile(rb'format="(ascii|binary|appended)"')


def detect_binary(path: Path, fmt: str | None) -> bool | None:
    """Whether a VTU / VTK / XDMF / PLY / STL file is binary (XDMF: HDF5 data), from its first bytes; None if unknown."""
    try:
        with open(path, "rb") as f:
            head = f.read(1 << 16)
    except OSError:
        return None
    if fmt == "vtu":
        m = _VTU_FORMAT.search(head)
        return None if m is None else m.group(1) != b"ascii"
    if fmt == "vtk":
        lines = head.split(b"\n", 3)
        return None if len(lines) < 3 else lines[2].strip().upper() == b"BINARY"
    if fmt == "xdmf":
        m = re.search(rb'Format="(XML|HDF|Binary)"', head)
        return None if m is None else m.group(1) != b"XML"
    if fmt == "ply":
        return b"format ascii" not in head[:512]
    if fmt == "stl":
        return not head[:5].lower().startswith(b"solid")
    return None
