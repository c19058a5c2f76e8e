"""What the commands print: the stderr console, gate lines, warnings, progress, the JSON report file."""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import click
from rich.console import Console
from rich.markup import escape

from .. import report
from ..errors import GateFileError, MeshWriteError
from ..gates import Gate, resolve_thresholds
from ..smoothers._fast import would_help
from .errors import Usage
from .meshfiles import STDIO

#: Cells above which the progress bar is shown by default (when stderr is a terminal).
PROGRESS_MIN_CELLS = 50_000


def make_console(quiet: bool) -> Console:
    # Not a terminal (CI logs, pipes): rich would assume 80 columns and squeeze the tables.
    wide = None if sys.stderr.isatty() or os.environ.get("COLUMNS") else 132
    return Console(stderr=True, quiet=quiet, highlight=False, width=wide)


def gate_thresholds(gate_opts: dict) -> tuple[dict, bool]:
    exit_zero = gate_opts.pop("exit_zero", False)
    gate_file = gate_opts.pop("gate_file", None)
    try:
        return resolve_thresholds(gate_opts, gate_file), exit_zero
    except GateFileError as exc:
        raise Usage(str(exc)) from None


def report_gates(console: Console, name: str, gates: list[Gate]) -> bool:
    """Print one line per failed gate (even with --quiet: it explains exit 1); return whether all passed."""
    failed = [g for g in gates if not g.passed]
    for g in failed:
        click.echo(g.message(name), err=True)
    if gates and not failed:
        plain(console, f"{name}: all {len(gates)} gates passed")
    return not failed


def emit_json(json_path: str | None, document: dict) -> None:
    """Write the JSON report to stdout, or atomically to a file."""
    if json_path is None:
        return
    if json_path == STDIO:
        click.echo(report.to_json(document))
        return
    os.replace(stage_json(json_path, document), json_path)


def stage_json(json_path: str, document: dict) -> Path:
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


def plain(console: Console, text: str) -> None:
    """Print text that holds file names or brackets as it is (rich would read ``[...]`` as markup)."""
    console.print(text, markup=False, highlight=False)


def note_fast(console: Console, topo, passes: int) -> None:
    if passes and would_help(topo):
        plain(console, f"note: {topo.n_free} free nodes and numba is not installed: "
                    "pip install 'anglesmooth[fast]' makes every pass 3-4x faster on meshes this size")


def warn_invalid(console: Console, name: str, summary: dict) -> None:
    if summary["inverted"]:
        first = ", ".join(map(str, summary["inverted_cells"]))
        console.print(f"[yellow]warning:[/] {escape(name)}: the input has {summary['inverted']} inverted cell(s) "
                      f"(first: {first}); guarded smoothing never adds inverted cells and takes moves that remove them")


@contextlib.contextmanager
def progress_bar(console: Console, total: int, n_cells: int, wanted: bool | None, compiled: bool = False,
                 compiling: bool = False):
    auto = wanted is None and console.is_terminal and n_cells > PROGRESS_MIN_CELLS
    if not (wanted or auto) or console.quiet or total == 0:
        yield None
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    # the first pass loads the compiled kernels, and on the very first run compiles them
    first = "smoothing"
    if compiled:
        first = "smoothing (compiling kernels once)" if compiling else "smoothing (loading the compiled kernels)"
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task(first, total=total)

        def callback(k, points, displacement):
            bar.update(task, completed=k, description=f"smoothing (displacement {displacement:.2e})")

        yield callback
