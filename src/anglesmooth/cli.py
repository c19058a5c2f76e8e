"""The command line: ``anglesmooth INPUT OUTPUT``, ``anglesmooth check`` and ``anglesmooth compare``.

This is the only module with a console, progress bars and exit codes.  Tables,
warnings and progress go to stderr; stdout carries only data (the mesh when
OUTPUT is ``-``, the JSON report with ``--json -``).

Exit codes: 0 success, 1 a quality gate failed, 2 usage error, 3 unreadable /
unsupported / invalid input or unwritable output, 4 internal error (a bug),
130 interrupted (SIGINT), 143 terminated (SIGTERM).
"""

from __future__ import annotations

import contextlib
import functools
import os
import signal
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.markup import escape

from . import report
from .__about__ import __version__
from .driver import smooth as run_smooth
from .errors import AngleSmoothError, GateFileError, MeshWriteError
from .gates import Gate, evaluate, resolve_thresholds
from .quality import cell_areas, cell_min_angles, summarize
from .smoothers import SMOOTHERS
from .smoothers._fast import active as fast_active
from .smoothers._fast import kernel_mode, would_help
from .topology import build_cell_topology, build_topology

__all__ = ["cli", "main"]

EXIT_OK, EXIT_GATE, EXIT_USAGE, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3, 4
EXIT_SIGINT, EXIT_SIGTERM = 130, 143
#: Cells above which the progress bar is shown by default (when stderr is a terminal).
PROGRESS_MIN_CELLS = 50_000
STDIO = "-"

# meshio format name -> file suffix, for the temporary files behind stdin/stdout.
_SUFFIX = {"gmsh": ".msh", "gmsh22": ".msh", "ansys": ".msh", "vtu": ".vtu", "vtk": ".vtk", "xdmf": ".xdmf",
           "abaqus": ".inp", "nastran": ".nas", "medit": ".mesh", "obj": ".obj", "off": ".off", "ply": ".ply",
           "stl": ".stl", "su2": ".su2", "dolfin-xml": ".xml", "tecplot": ".dat", "ugrid": ".ugrid",
           "avsucd": ".avs", "flac3d": ".f3grid", "permas": ".post", "wkt": ".wkt", "mdpa": ".mdpa"}


class _Usage(Exception):
    """A usage problem found after parsing (exit 2, one line)."""


class _Terminated(KeyboardInterrupt):
    """Raised by the SIGTERM handler so that cleanup (atomic writes) runs as for Ctrl-C."""


def _on_sigterm(signum, frame):  # pragma: no cover - exercised in a subprocess
    raise _Terminated()


def _error(message: str) -> None:
    """The one line every error gets on stderr."""
    click.echo(f"anglesmooth: error: {' '.join(str(message).split())}", err=True)


def _handle_errors(fn: Callable) -> Callable:
    """Turn every exception of a command into one stderr line and an exit code (traceback with --debug)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        debug = kwargs.get("debug", False)
        try:
            return fn(*args, **kwargs)
        except (click.exceptions.ClickException, click.exceptions.Exit, click.exceptions.Abort):
            raise
        except BaseException as exc:
            if isinstance(exc, SystemExit):
                raise
            if debug:
                traceback.print_exc(file=sys.stderr)
            code, message = _classify(exc)
            if message:
                _error(message)
            raise click.exceptions.Exit(code) from None

    return wrapper


def _classify(exc: BaseException) -> tuple[int, str]:
    if isinstance(exc, _Terminated):
        return EXIT_SIGTERM, "terminated"
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_SIGINT, "interrupted"
    if isinstance(exc, _Usage):
        return EXIT_USAGE, str(exc)
    if isinstance(exc, AngleSmoothError):
        return int(getattr(exc, "exit_code", EXIT_INPUT)), str(exc)
    if isinstance(exc, MemoryError):
        return EXIT_INPUT, "out of memory (the mesh is too large for this machine)"
    if isinstance(exc, BrokenPipeError):
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141, ""
    return EXIT_INTERNAL, f"internal error: {type(exc).__name__}: {exc} (please report it; --debug shows the traceback)"


# ---------------------------------------------------------------- mesh input / output


def _display(path: str) -> str:
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
    from . import io as mesh_io

    if path != STDIO:
        with contextlib.redirect_stdout(sys.stderr):
            return mesh_io.read(path, file_format=file_format)
    if not file_format:
        raise _Usage("reading from stdin ('-') needs --input-format (e.g. --input-format gmsh)")
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
    from . import io as mesh_io

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


def _check_paths(input, output, *, force, in_place, input_format, output_format, json_path) -> str:
    """Validate INPUT / OUTPUT and the overwrite rules; return the output path."""
    if in_place:
        if output is not None:
            raise _Usage("--in-place writes back to INPUT; do not give an OUTPUT")
        if input == STDIO:
            raise _Usage("--in-place needs an INPUT file, not '-'")
        output = input
    if output is None:
        raise _Usage("missing OUTPUT (a file, '-' for stdout, or --in-place to overwrite INPUT)")
    if input == STDIO and not input_format:
        raise _Usage("reading from stdin ('-') needs --input-format (e.g. --input-format gmsh)")
    if output == STDIO and not output_format:
        raise _Usage("writing to stdout ('-') needs --output-format (e.g. --output-format vtu)")
    if output == STDIO and json_path == STDIO:
        raise _Usage("OUTPUT '-' and --json - cannot both use stdout")
    if STDIO not in (input, output) and not (force or in_place) and _same_file(input, output):
        raise _Usage(f"OUTPUT '{output}' is the input file; pass --force or --in-place to overwrite it")
    if output != STDIO:
        _check_writable(output, "cannot write")
    if json_path is not None and json_path != STDIO:
        _check_writable(json_path, "cannot write JSON report")
    return output


def _check_writable(path: str, what: str) -> None:
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


def _read_fix_nodes(path: str) -> np.ndarray:
    """0-based node indices, whitespace-separated; ``#`` starts a comment."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise _Usage(f"--fix-nodes: cannot read '{path}': {getattr(exc, 'strerror', None) or exc}") from None
    tokens = [t for line in text.splitlines() for t in line.split("#", 1)[0].split()]
    try:
        return np.array([int(t) for t in tokens], dtype=np.int64)
    except ValueError:
        bad = next(t for t in tokens if not t.lstrip("+-").isdigit())
        raise _Usage(f"--fix-nodes: '{path}' holds {bad!r}, expected 0-based node indices") from None


def _extra_fixed(mesh, groups: tuple[str, ...], nodes: np.ndarray | None) -> np.ndarray | None:
    if not groups and nodes is None:
        return None
    mask = np.zeros(mesh.n_points, dtype=bool)
    for name in groups:
        if name not in mesh.groups:
            known = ", ".join(sorted(mesh.groups)) or "none (the mesh has no named groups)"
            raise _Usage(f"--fix-group: no group {name!r} in the mesh; available: {known}")
        mask[mesh.groups[name]] = True
    if nodes is not None and nodes.size:
        bad = nodes[(nodes < 0) | (nodes >= mesh.n_points)]
        if bad.size:
            raise _Usage(f"--fix-nodes: node {int(bad[0])} out of range (the mesh has nodes 0..{mesh.n_points - 1})")
        mask[nodes] = True
    return mask


# ---------------------------------------------------------------- reporting helpers


def _console(quiet: bool) -> Console:
    # Not a terminal (CI logs, pipes): rich would assume 80 columns and squeeze the tables.
    wide = None if sys.stderr.isatty() or os.environ.get("COLUMNS") else 132
    return Console(stderr=True, quiet=quiet, highlight=False, width=wide)


def _thresholds(gate_opts: dict) -> tuple[dict, bool]:
    exit_zero = gate_opts.pop("exit_zero", False)
    gate_file = gate_opts.pop("gate_file", None)
    try:
        return resolve_thresholds(gate_opts, gate_file), exit_zero
    except GateFileError as exc:
        raise _Usage(str(exc)) from None


def _report_gates(console: Console, name: str, gates: list[Gate]) -> bool:
    """Print one line per failed gate (even with --quiet: it explains exit 1); return whether all passed."""
    failed = [g for g in gates if not g.passed]
    for g in failed:
        click.echo(g.message(name), err=True)
    if gates and not failed:
        _plain(console, f"{name}: all {len(gates)} gates passed")
    return not failed


def _emit_json(json_path: str | None, document: dict) -> None:
    """Write the JSON report to stdout, or atomically to a file."""
    if json_path is None:
        return
    if json_path == STDIO:
        click.echo(report.to_json(document))
        return
    os.replace(_stage_json(json_path, document), json_path)


def _stage_json(json_path: str, document: dict) -> Path:
    """Write the JSON report to a temporary file beside ``json_path``; the caller renames it into place."""
    target = Path(json_path)
    fd, tmp = tempfile.mkstemp(dir=target.absolute().parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(report.to_json(document) + "\n")
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise MeshWriteError(f"cannot write JSON report '{json_path}': {exc.strerror or exc}") from None
        raise
    return Path(tmp)


def _plain(console: Console, text: str) -> None:
    """Print text that holds file names or brackets as it is (rich would read ``[...]`` as markup)."""
    console.print(text, markup=False, highlight=False)


def _note_fast(console: Console, topo, passes: int) -> None:
    if passes and would_help(topo):
        _plain(console, f"note: {topo.n_free} free nodes and numba is not installed: "
                        "pip install 'anglesmooth[fast]' makes every pass 3-4x faster on meshes this size")


def _warn_invalid(console: Console, name: str, summary: dict) -> None:
    if summary["inverted"]:
        first = ", ".join(map(str, summary["inverted_cells"]))
        console.print(f"[yellow]warning:[/] {escape(name)}: the input has {summary['inverted']} inverted cell(s) "
                      f"(first: {first}); guarded smoothing never adds inverted cells and takes moves that remove them")


@contextlib.contextmanager
def _progress(console: Console, total: int, n_cells: int, wanted: bool | None, compiled: bool = False):
    auto = wanted is None and console.is_terminal and n_cells > PROGRESS_MIN_CELLS
    if not (wanted or auto) or console.quiet or total == 0:
        yield None
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    # the first pass loads the compiled kernels, and on the very first run compiles them (~15 s)
    first = "smoothing (loading the compiled kernels; the first run ever compiles them)" if compiled else "smoothing"
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task(first, total=total)

        def callback(k, points, displacement):
            bar.update(task, completed=k, description=f"smoothing (displacement {displacement:.2e})")

        yield callback


# ---------------------------------------------------------------- click plumbing


class DefaultGroup(click.Group):
    """A group that runs ``smooth`` when the first argument is not a command name."""

    default_command = "smooth"

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in [*ctx.help_option_names, "--version"]:
            args = [self.default_command, *args]
        return super().parse_args(ctx, args)

    def format_usage(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        formatter.write_usage(ctx.command_path, "INPUT [OUTPUT] [SMOOTH OPTIONS]")
        formatter.write_usage(ctx.command_path, "COMMAND [ARGS]...", prefix="   or: ")


def _gate_options(f: Callable) -> Callable:
    options = [
        click.option("--min-angle", type=float, metavar="DEG", help="Gate: smallest corner angle must be >= DEG."),
        click.option("--max-angle", type=float, metavar="DEG", help="Gate: largest corner angle must be <= DEG."),
        click.option("--max-inverted", type=click.IntRange(min=0), metavar="N",
                     help="Gate: at most N inverted cells (0 when any other gate is given)."),
        click.option("--max-area-ratio", type=click.FloatRange(min=0), metavar="R",
                     help="Gate: max/min cell area must be <= R."),
        click.option("--max-aspect-ratio", type=click.FloatRange(min=0), metavar="R",
                     help="Gate: largest Verdict aspect ratio (triangles and quads) must be <= R."),
        click.option("--gate-file", type=click.Path(exists=True, dir_okay=False), metavar="FILE",
                     help="TOML file with gate thresholds (same names, underscores); options override it."),
        click.option("--exit-zero", is_flag=True, help="Report failed gates but exit 0."),
    ]
    for option in reversed(options):
        f = option(f)
    return f


_json_option = click.option("--json", "json_path", metavar="PATH|-", help="Write the report as JSON ('-': stdout).")
_quiet_option = click.option("--quiet", "-q", is_flag=True, help="Print nothing on stderr except errors and failed gates.")
_debug_option = click.option("--debug", is_flag=True, help="Show the traceback of an error.")
_input_format_option = click.option("--input-format", metavar="FORMAT",
                                    help="meshio format of INPUT (needed for '-'), e.g. gmsh, vtu, vtk.")
_order_option = click.option("--order", type=click.Choice(["colour", "jacobi"]), default="colour", show_default=True,
                             help="Update order: Gauss-Seidel over colour classes, or all nodes at once.")
_no_guard_option = click.option("--no-guard", is_flag=True,
                                help="Textbook methods: do not refuse moves that invert cells or lower the local minimum angle.")


@click.group(cls=DefaultGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="anglesmooth")
def cli() -> None:
    """Smooth 2D triangle/quad meshes with the angle-based method of Zhou & Shimada (2000).

    \b
    anglesmooth INPUT OUTPUT [OPTIONS]     smooth a mesh (same as 'anglesmooth smooth ...')
    anglesmooth check INPUT... [GATES]     report quality, gate CI on it
    anglesmooth compare INPUT              run every method, paper-style table

    Exit codes: 0 ok, 1 a quality gate failed, 2 usage error, 3 bad input or
    unwritable output, 4 internal error, 130 interrupted, 143 terminated.
    See 'anglesmooth smooth --help' for the smoothing options.
    """


@cli.command("smooth")
@click.argument("input", metavar="INPUT")
@click.argument("output", metavar="[OUTPUT]", required=False)
@click.option("--method", "-m", type=click.Choice(list(SMOOTHERS)), default="angle", show_default=True,
              help="Smoothing method (from the registry).")
@click.option("--passes", "-n", type=click.IntRange(min=0), default=10, show_default=True, help="Maximum passes.")
@click.option("--tol", type=click.FloatRange(min=0), metavar="T",
              help="Stop once a pass moves no node by more than T x the mean edge length.")
@_no_guard_option
@_order_option
@click.option("--fix-group", multiple=True, metavar="NAME", help="Also fix the nodes of this named group (repeatable).")
@click.option("--fix-nodes", type=click.Path(exists=True, dir_okay=False), metavar="FILE",
              help="Also fix these nodes: 0-based indices, whitespace-separated, '#' comments.")
@click.option("--force", is_flag=True, help="Allow OUTPUT to be the input file.")
@click.option("--in-place", is_flag=True, help="Overwrite INPUT (give no OUTPUT).")
@_input_format_option
@click.option("--output-format", metavar="FORMAT", help="meshio format of OUTPUT (needed for '-').")
@_gate_options
@_json_option
@click.option("--plot", type=click.Path(dir_okay=False), metavar="PNG",
              help="Write a PNG: mesh before/after coloured by minimum angle, angle histograms.")
@click.option("--progress/--no-progress", default=None,
              help=f"Progress bar over passes [default: on a terminal with > {PROGRESS_MIN_CELLS} cells].")
@_quiet_option
@_debug_option
@_handle_errors
def smooth_cmd(input, output, method, passes, tol, no_guard, order, fix_group, fix_nodes, force, in_place,
               input_format, output_format, json_path, plot, progress, quiet, debug, **gate_opts) -> None:
    """Smooth INPUT and write OUTPUT ('-' for stdin/stdout); gates apply to the result, after writing it."""
    console = _console(quiet)
    output = _check_paths(input, output, force=force, in_place=in_place, input_format=input_format,
                          output_format=output_format, json_path=json_path)
    thresholds, exit_zero = _thresholds(gate_opts)
    kernel_mode()  # a bad ANGLESMOOTH_KERNEL is a usage error before any work
    if plot:
        from .plot import require_matplotlib

        require_matplotlib()
    user_nodes = _read_fix_nodes(fix_nodes) if fix_nodes else None
    name, out_name = _display(input), "<stdout>" if output == STDIO else output
    mesh = read_mesh(input, input_format)
    topo = build_topology(mesh, _extra_fixed(mesh, fix_group, user_nodes))
    before = summarize(mesh.points, topo)
    _warn_invalid(console, name, before)
    _note_fast(console, topo, passes)
    with _progress(console, passes, mesh.n_cells, progress, compiled=fast_active(topo)) as callback:
        result = run_smooth(mesh, method, passes, tol=tol, guard=not no_guard, order=order, topology=topo,
                            callback=callback)
    after = summarize(result.points, topo)
    gates = evaluate(after, thresholds)
    document = report.smooth_json(
        input=name, output=out_name, method=method, guard=not no_guard, order=order, passes=result.passes,
        passes_requested=passes, tol=tol, displacements=result.displacements, rejected=result.rejected,
        before=before, after=after, elapsed_s=result.elapsed_s, gates=gates, passed=all(g.passed for g in gates))
    # the JSON file is staged first and renamed after the mesh is written: an error in
    # either leaves neither behind
    staged = _stage_json(json_path, document) if json_path not in (None, STDIO) else None
    try:
        write_mesh(mesh, output, result.points, output_format)
    except BaseException:
        if staged is not None:
            staged.unlink(missing_ok=True)
        raise
    if staged is not None:
        os.replace(staged, json_path)
    elif json_path == STDIO:
        _emit_json(json_path, document)
    run = {"passes performed": f"{result.passes} / {passes}", "rejected moves": result.rejected,
           "last displacement": f"{result.displacements[-1] if result.displacements else 0:.3g} x mean edge",
           "time": f"{result.elapsed_s:.3f} s"}
    guard = "guarded" if not no_guard else "no guard"
    console.print(report.smooth_table(before, after, run, title=f"{name} -> {out_name}: {method}, {guard}, {order}"))
    passed = _report_gates(console, out_name, gates)
    if plot:
        from .plot import plot_smooth

        plot_smooth(plot, topo, mesh.points, result.points, title=f"{name}: {method}, {result.passes} passes")
    if not passed and not exit_zero:
        raise click.exceptions.Exit(EXIT_GATE)


@cli.command("check")
@click.argument("inputs", nargs=-1, required=True, metavar="INPUT...")
@_input_format_option
@_gate_options
@_json_option
@_quiet_option
@_debug_option
@_handle_errors
def check_cmd(inputs, input_format, json_path, quiet, debug, **gate_opts) -> None:
    """Report the quality of meshes without changing them.

    Exit 0 when every file passes every gate, 1 when a gate fails, 3 when a file
    cannot be read (the others are still checked; 3 wins over 1).
    """
    console = _console(quiet)
    thresholds, exit_zero = _thresholds(gate_opts)
    entries, failures = [], []
    for path in inputs:
        entry, lines = _check_one(path, input_format, thresholds, debug)
        entries.append(entry)
        failures += lines
    if len(entries) == 1 and entries[0]["report"] is not None:
        console.print(report.check_table(entries[0]["report"], title=_display(inputs[0])))
    elif len(entries) > 1:
        console.print(report.files_table(entries, with_gates=bool(thresholds)))
    for line in failures:
        click.echo(line, err=True)
    for e in entries:
        if e["report"] is not None and e["passed"] and thresholds:
            _plain(console, f"{e['input']}: all {len(e['gates'])} gates passed")
    errors = any(e["error"] for e in entries)
    passed = not errors and all(e["passed"] for e in entries)
    _emit_json(json_path, report.check_json(entries, passed))
    if errors:
        raise click.exceptions.Exit(EXIT_INPUT)
    if not passed and not exit_zero:
        raise click.exceptions.Exit(EXIT_GATE)


def _check_one(path: str, input_format, thresholds: dict, debug: bool) -> tuple[dict, list[str]]:
    name = _display(path)
    entry = {"input": name, "report": None, "gates": [], "passed": None, "error": None}
    try:
        mesh = read_mesh(path, input_format)
        summary = summarize(mesh.points, build_cell_topology(mesh))  # no smoothing tables needed
    except (AngleSmoothError, MemoryError) as exc:
        if debug:
            traceback.print_exc(file=sys.stderr)
        entry["error"] = _classify(exc)[1]
        _error(f"{name}: {entry['error']}" if name not in entry["error"] else entry["error"])
        return entry, []
    gates = evaluate(summary, thresholds)
    entry.update(report=summary, gates=[g.to_dict() for g in gates], passed=all(g.passed for g in gates))
    return entry, [g.message(name) for g in gates if not g.passed]


@cli.command("compare")
@click.argument("input", metavar="INPUT")
@click.option("--passes", "-n", type=click.IntRange(min=0), default=10, show_default=True, help="Passes per method.")
@_no_guard_option
@_order_option
@_input_format_option
@_json_option
@click.option("--plot", type=click.Path(dir_okay=False), metavar="PNG",
              help="Write a PNG with min angle and area ratio per pass for every method.")
@_quiet_option
@_debug_option
@_handle_errors
def compare_cmd(input, passes, no_guard, order, input_format, json_path, plot, quiet, debug) -> None:
    """Run every registered method on INPUT and print one table (like the paper's Tables 1-2)."""
    console = _console(quiet)
    kernel_mode()  # a bad ANGLESMOOTH_KERNEL is a usage error before any work
    if plot:
        from .plot import require_matplotlib

        require_matplotlib()
    name = _display(input)
    mesh = read_mesh(input, input_format)
    topo = build_topology(mesh)
    before = summarize(mesh.points, topo)
    _warn_invalid(console, name, before)
    _note_fast(console, topo, passes)
    results = [_compare_one(mesh, topo, m, passes, not no_guard, order, before) for m in SMOOTHERS]
    guard = "guarded" if not no_guard else "no guard"
    console.print(report.compare_table(before, results, title=f"{name}: {passes} passes, {guard}, {order}"))
    _emit_json(json_path, report.compare_json(input=name, passes_requested=passes, guard=not no_guard,
                                              order=order, before=before, results=results))
    if plot:
        from .plot import plot_compare

        plot_compare(plot, {r["method"]: r["history"] for r in results}, title=f"{name}: {guard}, {order}")


def _curve_point(points: np.ndarray, topo) -> tuple[float, float | None]:
    areas = np.abs(cell_areas(points, topo))
    smallest = float(areas.min())
    return float(cell_min_angles(points, topo).min()), (float(areas.max()) / smallest if smallest > 0 else None)


def _compare_one(mesh, topo, method: str, passes: int, guard: bool, order: str, before: dict) -> dict:
    history = {"min_angle": [before["min_angle"]], "area_ratio": [before["area_ratio"]]}
    overhead = 0.0

    def callback(k, points, displacement):
        nonlocal overhead
        t0 = time.perf_counter()
        angle, ratio = _curve_point(points, topo)
        history["min_angle"].append(angle)
        history["area_ratio"].append(ratio)
        overhead += time.perf_counter() - t0

    result = run_smooth(mesh, method, passes, guard=guard, order=order, topology=topo, callback=callback)
    return {"method": method, "passes": result.passes, "rejected": result.rejected,
            "displacement": result.displacements[-1] if result.displacements else 0.0,
            "elapsed_s": max(result.elapsed_s - overhead, 0.0), "after": summarize(result.points, topo),
            "history": history}


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: install the SIGTERM handler and run the click group."""
    with contextlib.suppress(ValueError):  # not in the main thread
        signal.signal(signal.SIGTERM, _on_sigterm)
    cli.main(args=argv, prog_name="anglesmooth")
