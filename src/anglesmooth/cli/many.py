"""Many files in one run: the options (``--jobs``, ``--scheduler``, ``--exclude``), which files a run means,
where their results go, the per-file lines, the summary table and the exit code.

The work itself is :mod:`anglesmooth.batch` (one task per file, in this
process, a process pool or a Dask cluster); this module only turns options
into its arguments and its results into lines.  Lines are printed in input
order as soon as every earlier file is done, so the output of ``--jobs N``
is that of ``--jobs 1`` (times aside).  Exit code: the worst of the files'
(4 internal error over 3 unreadable / unwritable over 2 an option that does
not fit a file over 1 a gate failed over 0).
"""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path

import click
from rich.table import Table

from .. import _paths, batch, filesets, report
from ..errors import AngleSmoothError
from ..gates import Gate
from . import formats
from .errors import EXIT_GATE, Usage, error
from .meshfiles import STDIO, _suffix, check_in_place_format, plan_outputs
from .outputs import emit_json, plain, warn_invalid

DASK_EXTRA = "pip install 'anglesmooth[dask]'"


class _Jobs(click.ParamType):
    name = "N"

    def convert(self, value, param, ctx):
        if isinstance(value, int):
            return value
        text = str(value).strip().lower()
        if text == "auto":
            return 0
        if text.isdigit():
            return int(text)
        self.fail(f"{value!r} is not a number of processes (an integer >= 0, or 'auto')", param, ctx)


jobs_option = click.option(
    "--jobs", "-j", type=_Jobs(), default="1", show_default=True,
    help="Files in N parallel processes; 0 or 'auto': one per core this process may use.")
scheduler_option = click.option(
    "--scheduler", metavar="ADDRESS",
    help="Send the files to this Dask scheduler (tcp://host:8786); the workers must see the same paths "
         f"(needs {DASK_EXTRA}).")
exclude_option = click.option(
    "--exclude", multiple=True, metavar="GLOB",
    help="Leave out files matching GLOB (a name like '*.vtk', a trailing part like 'build/*', or the path); "
         "repeatable.")


class SchedulerError(AngleSmoothError):
    """The Dask scheduler cannot be reached (exit 3)."""


@contextlib.contextmanager
def executor(scheduler: str | None, jobs: int):
    """The Dask client of ``--scheduler`` (None without it), closed at the end."""
    if scheduler is None:
        yield None
        return
    if jobs != 1:
        raise Usage("--jobs and --scheduler exclude each other (the scheduler's workers decide the parallelism)")
    try:
        from distributed import Client
    except ImportError:
        raise Usage(f"--scheduler needs Dask: {DASK_EXTRA}") from None
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise SchedulerError(f"cannot connect to the Dask scheduler at '{scheduler}': {exc}") from None
    try:
        yield client
    finally:
        with contextlib.suppress(Exception):
            client.close()


def _pattern(path: str) -> bool:
    import glob

    return path != STDIO and (os.path.isdir(path) or (not os.path.exists(path) and glob.has_magic(path)))


def wants_many(input, output, more, *, output_dir, suffix, jobs, scheduler, in_place) -> bool:
    """Whether ``smooth``'s arguments mean many files (otherwise: ``INPUT [OUTPUT]`` as always)."""
    return bool(more or output_dir is not None or suffix or scheduler or jobs != 1
                or (in_place and output is not None) or (output is None and _pattern(input)))


def expand_inputs(inputs, exclude=()) -> list[tuple[str, str]]:
    """(path, name relative to its directory) of every file the arguments name.

    No file at all is a usage error; no file left after ``exclude`` is an empty list.
    """
    found = filesets.expand([i for i in inputs if i is not None], exclude)
    if not found and not (exclude and filesets.expand([i for i in inputs if i is not None])):
        raise Usage("no mesh files found in " + ", ".join(f"'{i}'" for i in inputs if i is not None)
                    + f" (suffixes searched: {' '.join(filesets.MESH_SUFFIXES)})")
    return found


def _outputs(found, *, output_dir, suffix, output_format, in_place) -> list[str]:
    if in_place:
        if output_dir is not None or suffix:
            raise Usage("--in-place rewrites each INPUT; do not give --output-dir or --suffix")
        for p, _ in found:
            check_in_place_format(p, None, output_format)
        return [p for p, _ in found]
    if output_dir is None and not suffix:
        raise Usage("several INPUTs need --output-dir DIR, --suffix SUFFIX or --in-place "
                    "(two files alone mean INPUT OUTPUT)")
    ext = _suffix(output_format) if output_format else None
    return [filesets.output_name(p, output_dir=output_dir, suffix=suffix, extension=ext,
                              relative=rel if output_dir is not None else None) for p, rel in found]


def _progress_line(i: int, n: int, r: batch.FileResult) -> str:
    doc = r.report
    before, after = report.fmt(doc["before"]["min_angle"], "angle"), report.fmt(doc["after"]["min_angle"], "angle")
    return (f"[{i + 1}/{n}] {r.input} -> {r.output}: min angle {before}° -> {after}°, "
            f"{doc['passes']} passes, {r.elapsed_s:.2f} s")


def summary_table(results, with_gates: bool, elapsed: float) -> Table:
    """files | smoothed | failed | gates passed | time."""
    done = [r for r in results if r.error is None]
    table = Table(title="summary", title_justify="left")
    for name in ("files", "smoothed", "failed", "gates passed", "time"):
        table.add_column(name, justify="right")
    gates = f"{sum(1 for r in done if r.passed)} / {len(done)}" if with_gates else "–"
    table.add_row(str(len(results)), str(len(done)), str(len(results) - len(done)), gates, f"{elapsed:.2f} s")
    return table


def files_json(results, elapsed: float) -> dict:
    """``--json`` of a many-file run: one entry per file (the smoothing document, or input/output/error)."""
    entries = []
    for r in results:
        if r.error is None:
            entry = {k: v for k, v in r.report.items() if k not in ("schema_version", "anglesmooth_version")}
            entries.append({**entry, "error": None})
        else:
            entries.append({"input": r.input, "output": r.output, "passed": None, "error": r.error})
    done = [r for r in results if r.error is None]
    document = report.check_json(entries, passed=len(done) == len(results) and all(r.passed for r in done))
    document["summary"] = {"files": len(results), "smoothed": len(done), "failed": len(results) - len(done),
                           "gates_passed": sum(1 for r in done if r.passed), "elapsed_s": elapsed}
    return document


def worst_exit(results, exit_zero: bool) -> int:
    """The worst code of the files; ``--exit-zero`` turns a failed gate (1) into 0."""
    codes = [0 if (r.exit_code == EXIT_GATE and exit_zero) else r.exit_code for r in results]
    return max(codes, default=0)


def finish(outs, json_path: str | None, document: dict, junit_path: str | None, outcomes, suite: str,
           code: int) -> None:
    """The tail of a many-file run: the JSON report and the JUnit XML staged in ``outs`` and committed together,
    then exit ``code`` (nothing when 0)."""
    with outs:
        emit_json(json_path, document)
        if junit_path:
            formats.stage_text(junit_path, formats.junit_xml(outcomes, suite))
        outs.commit()
    if code:
        raise click.exceptions.Exit(code)


def _outcome(r: batch.FileResult) -> formats.Outcome:
    return formats.Outcome(r.input if r.error is not None else r.output, [Gate(**g) for g in r.gates], r.error)


def smooth_many(console, inputs, *, output_dir, suffix, output_format, in_place, jobs, scheduler, json_path,
                report_format, junit_path, thresholds, exit_zero, progress, debug, fix_nodes, plot, **options) -> None:
    """``anglesmooth smooth A B C ... --output-dir DIR | --suffix S | --in-place``."""
    if STDIO in inputs:
        raise Usage("'-' (stdin / stdout) works with one file only")
    if plot:
        raise Usage("--plot draws one file; give one INPUT and OUTPUT")
    formats.check_junit_path(junit_path)
    found = expand_inputs(inputs)
    outputs = _outputs(found, output_dir=output_dir, suffix=suffix, output_format=output_format, in_place=in_place)
    paths = [p for p, _ in found]
    try:
        filesets.plan_outputs(paths, outputs, in_place)
    except filesets.BatchError as exc:
        raise Usage(str(exc)) from None
    if json_path not in (None, STDIO):
        h5 = [h for h in map(filesets.hdf5_sibling, outputs) if h is not None]  # an XDMF output's data
        if os.path.realpath(json_path) in {os.path.realpath(o) for o in outputs + paths + h5}:
            raise Usage(f"--json '{json_path}' is one of the mesh files")
    reports = plan_outputs({"--json": json_path, "--junit-xml": junit_path}, [("INPUT", p) for p in paths],
                           created=[str(Path(o).parent) for o in outputs])  # --json out/r.json with --output-dir out
    n = len(paths)

    def on_result(i: int, r: batch.FileResult) -> None:
        if r.error is not None:
            if debug and r.traceback:
                click.echo(r.traceback, err=True, nl=False)
            error(r.error_line)
            return
        warn_invalid(console, r.input, r.report["before"])
        if progress is not False:
            plain(console, _progress_line(i, n, r))
        if report_format == "table":  # other formats report every file at the end
            formats.report(report_format, [_outcome(r)], lambda text: plain(console, text))

    t0 = time.perf_counter()
    with executor(scheduler, jobs) as client:
        filesets.make_dirs(str(Path(o).parent) for o in outputs)  # once everything else is known to work
        results = batch.smooth_files(paths, outputs, in_place=in_place, output_format=output_format,
                                     thresholds=thresholds, fix_nodes=fix_nodes, jobs=jobs, client=client,
                                     on_result=on_result, **options)
    elapsed = time.perf_counter() - t0
    console.print(summary_table(results, bool(thresholds), elapsed))
    outcomes = [_outcome(r) for r in results]
    if report_format != "table":
        formats.report(report_format, outcomes, lambda text: plain(console, text), data_on_stdout=_paths.carries_stdout(json_path, junit_path))
    finish(reports, json_path, files_json(results, elapsed), junit_path, outcomes, "anglesmooth smooth",
           worst_exit(results, exit_zero))
