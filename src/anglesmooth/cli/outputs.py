"""What the commands print: the stderr console, gate lines, warnings, progress, the JSON report file."""

from __future__ import annotations

import contextlib
import os
import sys
import time

import click
from rich.console import Console
from rich.markup import escape

from .. import _paths, report
from ..errors import GateFileError
from ..gates import resolve_thresholds
from ..smoothers._fast import would_help
from .errors import Usage
from .meshfiles import STDIO

#: Cells above which the progress bar is shown by default (when stderr is a terminal).
PROGRESS_MIN_CELLS = 50_000

#: Seconds between the plain progress lines printed instead of the bar when stderr is not a terminal (CI logs).
PROGRESS_EVERY_S = 5.0


def make_console(quiet: bool) -> Console:
    # Not a terminal (CI logs, pipes): rich would assume 80 columns and squeeze the tables.
    wide = None if sys.stderr.isatty() or os.environ.get("COLUMNS") else 132
    return Console(stderr=True, quiet=quiet, highlight=False, width=wide)


#: ``click.Context.meta`` key of the gate thresholds of a configuration file (set by ``main``).
CONFIG_GATES = "anglesmooth.config_gates"


def gate_thresholds(gate_opts: dict, safe: bool = False) -> tuple[dict, bool]:
    """Thresholds from the configuration file, the gate file and the options (in that order, the last wins)."""
    exit_zero = gate_opts.pop("exit_zero", False)
    gate_file = gate_opts.pop("gate_file", None)
    ctx = click.get_current_context(silent=True)
    base = ctx.meta.get(CONFIG_GATES) if ctx is not None else None
    try:
        return resolve_thresholds(gate_opts, gate_file, base=base, safe=safe), exit_zero
    except GateFileError as exc:
        raise Usage(str(exc)) from None


def emit_json(json_path: str | None, document: dict) -> None:
    """Write the JSON report to stdout or a file: staged in the active Outputs, committed with the others."""
    if json_path is None:
        return
    text = report.to_json(document) + "\n"

    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    outs = _paths.active()
    if json_path == STDIO and outs is not None:
        outs.stage_stdout("--json", write)
    elif json_path == STDIO:
        click.echo(text, nl=False)
    else:
        _paths.atomic_write(json_path, write, what="cannot write JSON report")


def note_stale(console: Console, outs) -> None:
    """One line naming temporary files that an earlier, killed run left beside an output."""
    stale = _paths.stale_temporaries(outs.targets.values())
    if stale:
        names = ", ".join(str(p) for p in stale[:3]) + (f" and {len(stale) - 3} more" if len(stale) > 3 else "")
        if not console.quiet:  # one line, never wrapped
            click.echo(f"note: temporary file(s) left by an interrupted earlier run: {names} (safe to delete "
                       "once no other anglesmooth run writes the same output)", err=True)


def plain(console: Console, text: str) -> None:
    """Print text that holds file names or brackets as it is (rich would read ``[...]`` as markup)."""
    console.print(text, markup=False, highlight=False)


def note_fast(console: Console, topo, passes: int) -> None:
    if passes and would_help(topo):
        plain(console, f"note: {topo.n_free} free nodes and numba is not installed: "
                    "pip install 'anglesmooth[fast]' makes every pass 3-4x faster on meshes this size")


def warn_invalid(console: Console, name: str, summary: dict) -> None:
    """Warnings about the input of a smoothing run: inverted and degenerate cells, nothing to smooth."""
    if summary["inverted"]:
        first = ", ".join(map(str, summary["inverted_cells"]))
        console.print(f"[yellow]warning:[/] {escape(name)}: the input has {summary['inverted']} inverted cell(s) "
                      f"(first: {first}); guarded smoothing never adds inverted cells and takes moves that remove them")
    if summary.get("degenerate"):
        first = ", ".join(map(str, summary.get("degenerate_cells", [])))
        console.print(f"[yellow]warning:[/] {escape(name)}: the input has {summary['degenerate']} degenerate cell(s) "
                      f"(zero or nearly zero area; first: {first})")
    nodes = summary.get("nodes", 0)
    if nodes and summary.get("fixed_nodes") == nodes and summary.get("triangles", 0) + summary.get("quads", 0):
        console.print(f"[yellow]warning:[/] {escape(name)}: all {nodes} nodes are fixed (boundary, interface or "
                      "--fix-* nodes): nothing to smooth")


@contextlib.contextmanager
def progress_bar(console: Console, total: int, n_cells: int, wanted: bool | None, compiled: bool = False,
                 compiling: bool = False):
    auto = wanted is None and console.is_terminal and n_cells > PROGRESS_MIN_CELLS
    if not (wanted or auto) or console.quiet or total == 0:
        yield None
        return
    if not console.is_terminal:  # a CI log: a transient bar would never show; a plain line now and then
        yield _progress_lines(console, total, n_cells, compiled)
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


def _progress_lines(console: Console, total: int, n_cells: int, compiled: bool):
    """A pass callback printing one plain line at most every :data:`PROGRESS_EVERY_S` seconds, and at the last pass."""
    start = last = time.monotonic()
    note = " (the first pass loads the compiled kernels; the first run ever compiles them)" if compiled else ""
    plain(console, f"smoothing: up to {total} passes over {n_cells} cells{note}")

    def callback(k, points, displacement):
        nonlocal last
        now = time.monotonic()
        if now - last >= PROGRESS_EVERY_S or k == total:
            last = now
            plain(console, f"smoothing: pass {k}/{total}, displacement {displacement:.2e}, {now - start:.1f} s")

    return callback
