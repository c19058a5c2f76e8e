"""Helpers of :mod:`anglesmooth.io`: meshio's import and silence, format candidates, readable reasons."""

from __future__ import annotations

import contextlib
import io as _stdio
from pathlib import Path

from .. import gmshfile


@contextlib.contextmanager
def _quiet():
    """Silence meshio's stdout blank lines and its rich warnings on stderr."""
    sink = _stdio.StringIO()
    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
        yield


def _meshio():
    """Import meshio, fixing its MSH 2.2 ElementData reader once.

    meshio 5.3.5 splits MSH 2.2 ``$ElementData`` by ``len((type, array))`` (= 2),
    so any file with element data fails to load; the wrapper passes the arrays.
    """
    import meshio
    from meshio.gmsh import _gmsh22

    orig = _gmsh22.cell_data_from_raw
    if not getattr(orig, "_anglesmooth_fix", False):

        def cell_data_from_raw(cells, cell_data_raw):
            return orig([c[1] if isinstance(c, tuple) else c for c in cells], cell_data_raw)

        cell_data_from_raw._anglesmooth_fix = True
        _gmsh22.cell_data_from_raw = cell_data_from_raw
    gmshfile.install()
    return meshio


def supported_formats() -> list[str]:
    """File extensions meshio knows, for help texts.

    >>> ".vtu" in supported_formats() and ".msh" in supported_formats()
    True
    """
    import meshio

    return sorted(meshio.extension_to_filetypes)


def _formats_for(path: Path) -> list[str]:
    import meshio

    out: list[str] = []
    ext = ""
    for suffix in reversed(path.suffixes):
        ext = (suffix + ext).lower()
        out += meshio.extension_to_filetypes.get(ext, [])
    return out


def _gmsh_header(path: Path) -> tuple[str, bool] | None:
    """(version, binary) from a ``$MeshFormat`` header, or None if not gmsh."""
    try:
        with open(path, "rb") as f:
            head = f.read(256)
    except OSError:
        return None
    lines = head.split(b"\n")
    if len(lines) < 2 or not lines[0].strip().startswith(b"$MeshFormat"):
        return None
    parts = lines[1].split()
    try:
        return parts[0].decode("ascii"), parts[1] == b"1"
    except (IndexError, UnicodeDecodeError):
        return None


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or "no details"
    text = text if len(text) <= 160 else text[:157] + "..."
    return f"{type(exc).__name__}: {text}"


def _plain_reason(exc: BaseException) -> str:
    """A reader's exception in words a user can act on, the technical reason after a colon.

    meshio's readers fail on corrupt files with numpy's own errors (an ``IndexError`` for a cell
    naming a node the file does not define, a ``ValueError`` from ``reshape`` for a file cut short);
    those alone say nothing about the file.
    """
    if not str(exc).strip():
        return "truncated or corrupt"
    tech = _reason(exc)
    if isinstance(exc, (IndexError, KeyError)):
        return f"a cell refers to a node the file does not define, or node numbers repeat; {tech}"
    text = str(exc)
    if isinstance(exc, (ValueError, EOFError)) and any(
        w in text for w in ("reshape", "buffer", "unpack", "could not convert", "invalid literal", "not enough values")
    ):
        return f"truncated or corrupt; {tech}"
    return tech
