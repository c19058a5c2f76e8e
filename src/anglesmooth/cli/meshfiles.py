"""Mesh files of the command line: stdin/stdout, path checks, the extra fixed nodes."""

from __future__ import annotations

import contextlib
import sys
import tempfile
from pathlib import Path

import click
import numpy as np

from .. import _paths
from ..errors import AngleSmoothError, MeshReadError
from .errors import EXIT_INPUT, Usage

STDIO = "-"
#: ``ctx.meta`` key of the configuration file in use (set by ``main.configure``): an input of every command.
CONFIG_PATH = "anglesmooth.config_path"

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
    if _paths.std_fd_closed(0):
        raise MeshReadError("cannot read <stdin>: standard input is closed")
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
    """Write to ``path`` or, for ``-``, stage the bytes for stdout (both committed by the active Outputs)."""
    from .. import io as mesh_io

    if path != STDIO:
        with contextlib.redirect_stdout(sys.stderr):
            mesh_io.write(mesh, path, points=points, file_format=file_format)
        return

    def write(tmp):
        try:
            with contextlib.redirect_stdout(sys.stderr):
                mesh_io.write(mesh, tmp, points=points, file_format=file_format)
        except AngleSmoothError as exc:
            raise _retarget(exc, Path(tmp), "<stdout>") from None

    _paths.active().stage_stdout("OUTPUT", write, suffix=_suffix(file_format))


def check_paths(input, output, *, force, in_place, input_format, output_format, json_path, plot=None,
                fix_nodes=None, gate_file=None, junit_path=None) -> tuple[str, _paths.Outputs]:
    """Validate INPUT / OUTPUT and the overwrite rules; return the output path and every output, checked."""
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
    outs = plan_outputs({"OUTPUT": output, "--json": json_path, "--plot": plot, "--junit-xml": junit_path},
                        [("INPUT", input), ("--fix-nodes", fix_nodes), ("--gate-file", gate_file)],
                        may_replace_input=("OUTPUT",) if force or in_place else ())
    return output, outs


def plan_outputs(outputs: dict, inputs: list, may_replace_input=()) -> _paths.Outputs:
    """Every output of a command, resolved and checked against every input and each other (see _paths)."""
    what = {"--json": "cannot write JSON report", "--plot": "cannot write plot", "--junit-xml": "cannot write JUnit XML"}
    ctx = click.get_current_context(silent=True)
    config = ctx.meta.get(CONFIG_PATH) if ctx is not None else None
    inputs = [*inputs, ("the configuration file", str(config) if config is not None else None)]
    return _paths.Outputs.check(outputs, inputs, may_replace_input=may_replace_input, what=what)


def read_fix_nodes(path: str) -> np.ndarray:
    """0-based node indices, whitespace-separated; ``#`` starts a comment."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise Usage(f"--fix-nodes: cannot read '{path}': {getattr(exc, 'strerror', None) or exc}") from None
    tokens = [t for line in text.splitlines() for t in line.split("#", 1)[0].split()]
    try:
        values = [int(t) for t in tokens]
    except ValueError:
        bad = next(t for t in tokens if not t.lstrip("+-").isdigit())
        raise Usage(f"--fix-nodes: '{path}' holds {bad!r}, expected 0-based node indices") from None
    big = next((v for v in values if not -(2**63) <= v < 2**63), None)
    if big is not None:
        raise Usage(f"--fix-nodes: node {big} in '{path}' is out of range")
    return np.array(values, dtype=np.int64)


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
