"""Mesh files of the command line: stdin/stdout, path checks, the extra fixed nodes."""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import click
import numpy as np

from .. import _paths
from ..errors import AngleSmoothError, MeshReadError
from ..formats import UnknownFormatError, resolve
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


def format_name(name: str | None, option: str) -> str | None:
    """A format name or alias -> the format name; unknown: a usage error listing every name."""
    try:
        return resolve(name)
    except UnknownFormatError as exc:
        raise Usage(f"{option}: {exc}") from None


def _family(fmt: str | None) -> str | None:
    """A format with its versions taken as one (gmsh22, gmsh41 -> gmsh)."""
    return "gmsh" if fmt and fmt.startswith("gmsh") else fmt


def check_in_place_format(path: str, input_format: str | None, output_format: str | None) -> None:
    """--in-place rewrites a file in its own format: an --output-format (e.g. from a configuration file) of
    another format would put that format under the input's name and lose the input (a usage error)."""
    if not output_format:
        return
    from .. import io as mesh_io

    wanted = format_name(output_format, "--output-format")
    try:
        own = format_name(input_format, "--input-format") if input_format else mesh_io.output_format(path)
    except AngleSmoothError:
        own = None
    if _family(own) != _family(wanted):
        raise Usage(f"--in-place keeps the format of '{path}' ({own or 'unknown'}); --output-format {wanted} "
                    "would write another format under its name")


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

    file_format = format_name(file_format, "--input-format")
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


def check_output(mesh, path: str, file_format: str | None, binary: bool | None) -> None:
    """Fail before smoothing (exit 3, one line) if OUTPUT's format cannot hold ``mesh``."""
    from .. import io as mesh_io

    file_format = format_name(file_format, "--output-format")
    target = Path("stdout" + _suffix(file_format)) if path == STDIO else Path(path)
    if path == STDIO and file_format == "xdmf" and binary is None:
        binary = False  # stdout carries one file: inline XML, no .h5 beside it
    try:
        with contextlib.redirect_stdout(sys.stderr):
            mesh_io.check_output(mesh, target, file_format=file_format, binary=binary)
    except AngleSmoothError as exc:
        raise _retarget(exc, target, "<stdout>") if path == STDIO else exc from None


def write_mesh(mesh, path: str, points: np.ndarray, file_format: str | None, binary: bool | None = None) -> None:
    """Write to ``path`` or, for ``-``, stage the bytes for stdout (both committed by the active Outputs)."""
    from .. import io as mesh_io

    file_format = format_name(file_format, "--output-format")
    if path != STDIO:
        with contextlib.redirect_stdout(sys.stderr):
            mesh_io.write(mesh, path, points=points, file_format=file_format, binary=binary)
        return
    if file_format == "xdmf" and binary is None:
        binary = False  # stdout carries one file: inline XML, no .h5 beside it

    def write(tmp):
        try:
            with contextlib.redirect_stdout(sys.stderr):
                mesh_io.write(mesh, tmp, points=points, file_format=file_format, binary=binary)
        except AngleSmoothError as exc:
            raise _retarget(exc, Path(tmp), "<stdout>") from None

    _paths.active().stage_stdout("OUTPUT", write, suffix=_suffix(file_format))


def prepare_output(mesh, path: str, file_format: str | None, binary: bool | None = None) -> bool:
    """Start the part of :func:`write_mesh` that the smoothing does not change, in the background
    (``io.prepare_write``: compressed VTU's cell arrays); nothing for stdout.  True when started."""
    from .. import io as mesh_io

    if path == STDIO:
        return False
    return mesh_io.prepare_write(mesh, path, file_format=format_name(file_format, "--output-format"), binary=binary)


def check_paths(input, output, *, force, in_place, input_format, output_format, json_path, plot=None,
                fix_nodes=None, gate_file=None, junit_path=None) -> tuple[str, _paths.Outputs]:
    """Validate INPUT / OUTPUT and the overwrite rules; return the output path and every output, checked."""
    if in_place:
        if output is not None:
            raise Usage("--in-place writes back to INPUT; do not give an OUTPUT")
        if input == STDIO:
            raise Usage("--in-place needs an INPUT file, not '-'")
        check_in_place_format(input, input_format, output_format)
        output = input
    if output is None:
        raise Usage("missing OUTPUT (a file, '-' for stdout, or --in-place to overwrite INPUT)")
    if input == STDIO and not input_format:
        raise Usage("reading from stdin ('-') needs --input-format (e.g. --input-format gmsh)")
    if output == STDIO and not output_format:
        raise Usage("writing to stdout ('-') needs --output-format (e.g. --output-format vtu)")
    if output == STDIO and json_path == STDIO:
        raise Usage("OUTPUT '-' and --json - cannot both use stdout")
    format_name(input_format, "--input-format")  # an unknown name is a usage error before any work
    format_name(output_format, "--output-format")
    # an existing OUTPUT is replaced (atomically, see _paths), as gmsh -o, meshio convert, cp and sort -o do;
    # only the input itself (the same file by path, symlink or hard link) needs --force or --in-place
    outs = plan_outputs({"OUTPUT": output, "--json": json_path, "--plot": plot, "--junit-xml": junit_path,
                         H5_LABEL: hdf5_beside(output, output_format)},
                        [("INPUT", input), ("--fix-nodes", fix_nodes), ("--gate-file", gate_file)],
                        may_replace_input=("OUTPUT", H5_LABEL) if force or in_place else ())
    return output, outs


#: The label of an XDMF OUTPUT's HDF5 data file among the outputs (see :func:`hdf5_beside`).
H5_LABEL = "the .h5 beside OUTPUT"


def hdf5_beside(output: str | None, output_format: str | None) -> str | None:
    """``NAME.h5`` for an XDMF OUTPUT ``NAME.xdmf``: its heavy data, written beside it (see ``anglesmooth.io``).

    It is an output like the others: it must not be an input (``--gate-file out.h5``) or another output
    (``--json out.h5``), which it would replace.  Checked whether or not HDF5 is chosen in the end.
    """
    if output is None or output == STDIO:
        return None
    fmt = format_name(output_format, "--output-format") if output_format else None
    if fmt is None:
        from ..formats import resolve as _resolve

        try:
            fmt = _resolve(Path(output).suffix.lstrip(".").lower() or None)
        except UnknownFormatError:
            return None
    if fmt != "xdmf":
        return None
    # a symlinked OUTPUT is followed: the data goes beside (and is named after) the link's target
    return str(Path(os.path.realpath(output) if os.path.islink(output) else output).with_suffix(".h5"))


def plan_outputs(outputs: dict, inputs: list, may_replace_input=(), created=()) -> _paths.Outputs:
    """Every output of a command, resolved and checked against every input and each other (see _paths)."""
    what = {"--json": "cannot write JSON report", "--plot": "cannot write plot", "--junit-xml": "cannot write JUnit XML"}
    ctx = click.get_current_context(silent=True)
    config = ctx.meta.get(CONFIG_PATH) if ctx is not None else None
    inputs = [*inputs, ("the configuration file", str(config) if config is not None else None)]
    return _paths.Outputs.check(outputs, inputs, may_replace_input=may_replace_input, what=what, created=created)


_NUMBERING = {"index": "0-based node indices", "gmsh": "gmsh node tags (1-based)"}


def read_fix_nodes(path: str, numbering: str = "index") -> np.ndarray:
    """Node numbers, whitespace-separated; ``#`` starts a comment (0-based indices or gmsh tags, see ``numbering``)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise Usage(f"--fix-nodes: cannot read '{path}': {getattr(exc, 'strerror', None) or exc}") from None
    tokens = [t for line in text.splitlines() for t in line.split("#", 1)[0].split()]
    try:
        values = [int(t) for t in tokens]
    except ValueError:
        bad = next(t for t in tokens if not t.lstrip("+-").isdigit())
        raise Usage(f"--fix-nodes: '{path}' holds {bad!r}, expected {_NUMBERING[numbering]} "
                    f"(--node-numbering {numbering})") from None
    big = next((v for v in values if not -(2**63) <= v < 2**63), None)
    if big is not None:
        raise Usage(f"--fix-nodes: node {big} in '{path}' is out of range")
    return np.array(values, dtype=np.int64)


def fix_node_indices(mesh, numbers: np.ndarray, numbering: str) -> np.ndarray:
    """The 0-based indices of the --fix-nodes numbers (gmsh tags mapped through the MSH file's node tags)."""
    from .. import io as mesh_io

    n = mesh.n_points
    if numbering == "index":
        bad = numbers[(numbers < 0) | (numbers >= n)]
        if bad.size:
            hint = "; for gmsh node tags use --node-numbering gmsh" if mesh_io.node_tags(mesh) is not None else ""
            raise Usage(f"--fix-nodes: node {int(bad[0])} out of range: 0-based node indices are expected "
                        f"(--node-numbering index) and the mesh has nodes 0..{n - 1}{hint}")
        return numbers
    tags = mesh_io.node_tags(mesh)
    if tags is None:
        raise Usage("--node-numbering gmsh: the input has no gmsh node tags (only MSH files have them); "
                    "give 0-based indices with --node-numbering index")
    order = np.argsort(tags, kind="stable")
    pos = np.searchsorted(tags, numbers, sorter=order)
    pos = np.minimum(pos, n - 1)
    found = tags[order[pos]] == numbers
    if not found.all():
        bad = int(numbers[~found][0])
        raise Usage(f"--fix-nodes: gmsh node tag {bad} is not in the mesh (--node-numbering gmsh: 1-based tags "
                    f"{int(tags.min())}..{int(tags.max())})")
    return order[pos]
