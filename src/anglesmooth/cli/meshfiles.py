"""Mesh files of the command line: stdin/stdout, path checks, the extra fixed nodes."""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import AngleSmoothError, MeshWriteError
from .errors import EXIT_INPUT, Usage

STDIO = "-"

# meshio format name -> file suffix, for the temporary files behind stdin/stdout.
_SUFFIX = {"gmsh": ".msh", "gmsh22": ".msh", "ansys": ".msh", "vtu": ".vtu", "vtk": ".vtk", "xdmf": ".xdmf",
           "abaqus": ".inp", "nastran": ".nas", "medit": ".mesh", "obj": ".obj", "off": ".off", "ply": ".ply",
           "stl": ".stl", "su2": ".su2", "dolfin-xml": ".xml", "tecplot": ".dat", "ugrid": ".ugrid",
           "avsucd": ".avs", "flac3d": ".f3grid", "permas": ".post", "wkt": ".wkt", "mdpa": ".mdpa"}


def display(path: str) -> str:
    return "<stdin>" if path == STDIO else path


def _suffix(fmt: str) -> str:
    return _SUFFIX.get(fmt, "." + fmt.split("-")[0])


def _binary(stream):
    """The byte stream under a text stream (click's CliRunner swaps sys.stdin/stdout too)."""
    return getattr(stream, "buffer", stream)


def _retarget(exc: AngleSmoothError, tmp: Path, name: str) -> AngleSmoothError:
    new = type(exc)(str(exc).replace(str(tmp), name))
    new.exit_code = getattr(exc, "exit_code", EXIT_INPUT)
    return new


def read_mesh(path: str, file_format: str | None):
    """Read a mesh file, or stdin for ``-`` (through a temporary file: meshio cannot read gmsh/VTU from a stream)."""
    from .. import io as mesh_io

    if path != STDIO:
        with contextlib.redirect_stdout(sys.stderr):
            return mesh_io.read(path, file_format=file_format)
    if not file_format:
        raise Usage("reading from stdin ('-') needs --input-format (e.g. --input-format gmsh)")
    data = _binary(sys.stdin).read()
    with tempfile.TemporaryDirectory(prefix="anglesmooth-") as tmpdir:
        tmp = Path(tmpdir) / ("stdin" + _suffix(file_format))
        tmp.write_bytes(data)
        try:
            with contextlib.redirect_stdout(sys.stderr):
                return mesh_io.read(tmp, file_format=file_format)
        except AngleSmoothError as exc:
            raise _retarget(exc, tmp, "<stdin>") from None


def write_mesh(mesh, path: str, points: np.ndarray, file_format: str | None) -> None:
    """Write atomically to ``path``, or to stdout for ``-`` (via a temporary file)."""
    from .. import io as mesh_io

    if path != STDIO:
        with contextlib.redirect_stdout(sys.stderr):
            mesh_io.write(mesh, path, points=points, file_format=file_format)
        return
    with tempfile.TemporaryDirectory(prefix="anglesmooth-") as tmpdir:
        tmp = Path(tmpdir) / ("stdout" + _suffix(file_format))
        try:
            with contextlib.redirect_stdout(sys.stderr):
                mesh_io.write(mesh, tmp, points=points, file_format=file_format)
        except AngleSmoothError as exc:
            raise _retarget(exc, tmp, "<stdout>") from None
        out = _binary(sys.stdout)
        out.write(tmp.read_bytes())
        out.flush()


def check_paths(input, output, *, force, in_place, input_format, output_format, json_path) -> str:
    """Validate INPUT / OUTPUT and the overwrite rules; return the output path."""
    if in_place:
        if output is not None:
            raise Usage("--in-place writes back to INPUT; do not give an OUTPUT")
        if input == STDIO:
            raise Usage("--in-place needs an INPUT file, not '-'")
        output = input
    if output is None:
        raise Usage("missing OUTPUT (a file, '-' for stdout, or --in-place to overwrite INPUT)")
    if input == STDIO and not input_format:
        raise Usage("reading from stdin ('-') needs --input-format (e.g. --input-format gmsh)")
    if output == STDIO and not output_format:
        raise Usage("writing to stdout ('-') needs --output-format (e.g. --output-format vtu)")
    if output == STDIO and json_path == STDIO:
        raise Usage("OUTPUT '-' and --json - cannot both use stdout")
    if STDIO not in (input, output) and not (force or in_place) and _same_file(input, output):
        raise Usage(f"OUTPUT '{output}' is the input file; pass --force or --in-place to overwrite it")
    if output != STDIO:
        check_writable(output, "cannot write")
    if json_path is not None and json_path != STDIO:
        check_writable(json_path, "cannot write JSON report")
    return output


def check_writable(path: str, what: str) -> None:
    """Fail before any work if a file cannot be created in ``path``'s directory."""
    parent = Path(path).absolute().parent
    if not parent.exists():
        raise MeshWriteError(f"{what} '{path}': directory '{parent}' does not exist")
    if not parent.is_dir():
        raise MeshWriteError(f"{what} '{path}': '{parent}' is not a directory")
    if Path(path).is_dir():
        raise MeshWriteError(f"{what} '{path}': it is a directory")
    try:
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".anglesmooth-probe-"):
            pass
    except OSError as exc:
        raise MeshWriteError(f"{what} '{path}': cannot create a file in '{parent}': {exc.strerror or exc}") from None


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def read_fix_nodes(path: str) -> np.ndarray:
    """0-based node indices, whitespace-separated; ``#`` starts a comment."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise Usage(f"--fix-nodes: cannot read '{path}': {getattr(exc, 'strerror', None) or exc}") from None
    tokens = [t for line in text.splitlines() for t in line.split("#", 1)[0].split()]
    try:
        return np.array([int(t) for t in tokens], dtype=np.int64)
    except ValueError:
        bad = next(t for t in tokens if not t.lstrip("+-").isdigit())
        raise Usage(f"--fix-nodes: '{path}' holds {bad!r}, expected 0-based node indices") from None


def extra_fixed(mesh, groups: tuple[str, ...], nodes: np.ndarray | None) -> np.ndarray | None:
    if not groups and nodes is None:
        return None
    mask = np.zeros(mesh.n_points, dtype=bool)
    for name in groups:
        if name not in mesh.groups:
            known = ", ".join(sorted(mesh.groups)) or "none (the mesh has no named groups)"
            raise Usage(f"--fix-group: no group {name!r} in the mesh; available: {known}")
        mask[mesh.groups[name]] = True
    if nodes is not None and nodes.size:
        bad = nodes[(nodes < 0) | (nodes >= mesh.n_points)]
        if bad.size:
            raise Usage(f"--fix-nodes: node {int(bad[0])} out of range (the mesh has nodes 0..{mesh.n_points - 1})")
        mask[nodes] = True
    return mask
