"""Which files a batch means and where their results go: directories and globs expanded, ``--exclude``,
output names, collisions refused, output directories made.

>>> output_name("in/a.msh", output_dir="out", suffix="_s", extension=".vtu")
'out/a_s.vtu'
>>> find_mesh_files(["no-such-file.msh"])
['no-such-file.msh']
"""

from __future__ import annotations

import fnmatch
import glob
import os
from collections.abc import Iterable, Sequence
from pathlib import Path, PurePath

from .errors import AngleSmoothError, MeshWriteError

__all__ = ["MESH_SUFFIXES", "BatchError", "expand", "find_mesh_files", "make_dirs", "output_name", "plan_outputs"]

#: File suffixes a directory is searched for (meshio formats that can hold a 2D mesh).
MESH_SUFFIXES = (".msh", ".vtu", ".vtk", ".xdmf", ".xmf", ".inp", ".med", ".mesh", ".meshb", ".nas", ".bdf",
                 ".fem", ".su2", ".ugrid", ".obj", ".off", ".ply", ".stl", ".avs", ".f3grid", ".mdpa", ".post")


class BatchError(AngleSmoothError):
    """Arguments of a batch that cannot be used (two files with one output, an output over an input)."""

    exit_code = 2

def _hidden(name: str) -> bool:
    return name.startswith(".")


def _walk(root: str) -> list[tuple[str, str]]:
    found = []
    for top, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not _hidden(d))
        for f in sorted(files):
            if not _hidden(f) and Path(f).suffix.lower() in MESH_SUFFIXES:
                path = os.path.join(top, f)
                found.append((path, os.path.relpath(path, root)))
    return found


def _excluded(path: str, patterns: Sequence[str]) -> bool:
    posix = PurePath(path).as_posix()
    return any(PurePath(posix).match(g) or fnmatch.fnmatch(posix, g) for g in patterns)


def expand(paths: Iterable[str], exclude: Sequence[str] = ()) -> list[tuple[str, str]]:
    """(path, name relative to the directory it was found in) for every file of ``paths``.

    A directory is walked for files with a suffix in :data:`MESH_SUFFIXES`
    (sorted, hidden files and directories skipped); a pattern that names no
    existing file is expanded like a shell glob (``**`` included; no match
    keeps the pattern); other paths are kept as they are (a missing file then
    fails as its own task).  A path
    that matches one of the ``exclude`` globs (a name such as ``*.vtk``, a
    trailing part such as ``build/*``, or the whole path) is left out.
    Repeated paths are kept once.
    """
    out: list[tuple[str, str]] = []
    for p in map(str, paths):
        if p != "-" and os.path.isdir(p):
            out += _walk(p)
        elif p != "-" and not os.path.exists(p) and glob.has_magic(p):
            matches = sorted(glob.glob(p, recursive=True))
            for match in matches:
                out += _walk(match) if os.path.isdir(match) else [(match, os.path.basename(match))]
            if not matches:  # as a shell does: the pattern itself, which then is no such file
                out.append((p, os.path.basename(p)))
        else:
            out.append((p, os.path.basename(p)))
    seen: set[str] = set()
    unique = []
    for path, rel in out:
        if path not in seen and not _excluded(path, exclude):
            seen.add(path)
            unique.append((path, rel))
    return unique


def find_mesh_files(paths: Iterable[str], exclude: Sequence[str] = ()) -> list[str]:
    """The files named by ``paths`` (files, directories, globs), without the ``exclude`` ones (see :func:`expand`).

    >>> find_mesh_files(["no-such-file.msh"])
    ['no-such-file.msh']
    """
    return [path for path, _ in expand(paths, exclude)]


def output_name(path: str, *, output_dir: str | None = None, suffix: str = "", extension: str | None = None,
                relative: str | None = None) -> str:
    """Where the result of ``path`` goes: ``output_dir/relative`` (or beside ``path``) with ``suffix`` added
    to the stem and the extension replaced by ``extension``.

    >>> output_name("in/a.msh", output_dir="out", suffix="_s", extension=".vtu")
    'out/a_s.vtu'
    >>> output_name("in/a.msh", suffix="_s")
    'in/a_s.msh'
    """
    if any(sep and sep in suffix for sep in (os.sep, os.altsep, "/")) or "\0" in suffix:
        raise BatchError(f"the suffix {suffix!r} (--suffix) is added to each file name and must not contain "
                         "'/' (put the outputs in another directory with --output-dir)")
    rel = PurePath(relative if relative is not None else os.path.basename(path))
    name = rel.stem + suffix + (extension if extension is not None else rel.suffix)
    if output_dir is None:
        return str(PurePath(path).with_name(name))
    return str(PurePath(output_dir) / rel.with_name(name))


def hdf5_sibling(path: str) -> str | None:
    """``NAME.h5`` for ``NAME.xdmf`` / ``NAME.xmf``: where an XDMF output's HDF5 data goes (beside it)."""
    pure = PurePath(path)
    return str(pure.with_suffix(".h5")) if pure.suffix.lower() in (".xdmf", ".xmf") else None


def plan_outputs(inputs: Sequence[str], outputs: Sequence[str], in_place: bool) -> None:
    """Refuse two inputs with one output, and an output that is another file's input (unless in place).

    The ``.h5`` an XDMF output writes beside itself counts as an output too: two outputs sharing one
    (``a.xdmf`` and ``a.xmf``), or one that is an input or another output, are refused.
    """
    seen: dict[str, str] = {}
    resolved_inputs = {os.path.realpath(p): p for p in inputs}
    for src, dst in zip(inputs, outputs):
        key = os.path.realpath(dst)
        if key in seen:
            raise BatchError(f"'{seen[key]}' and '{src}' would both be written to '{dst}'")
        seen[key] = src
        if not in_place and key in resolved_inputs:
            raise BatchError(f"the output of '{src}' would overwrite the input '{resolved_inputs[key]}' "
                             "(use --in-place to rewrite the inputs, or another --output-dir / --suffix)")
    for src, dst in zip(inputs, outputs):
        h5 = hdf5_sibling(dst)
        if h5 is None:
            continue
        key = os.path.realpath(h5)
        if key in seen or key in resolved_inputs:
            other = f"the output of '{seen[key]}'" if key in seen else f"the input '{resolved_inputs[key]}'"
            raise BatchError(f"the HDF5 data of '{dst}' (the output of '{src}') would be written to '{h5}', "
                             f"over {other}")
        seen[key] = src


def make_dirs(directories: Iterable[str]) -> None:
    """Create the output directories (and their parents) that do not exist yet."""
    for directory in sorted(set(map(str, directories))):
        try:
            Path(directory).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise MeshWriteError(f"cannot create the output directory '{directory}': {exc.strerror or exc}") from None
