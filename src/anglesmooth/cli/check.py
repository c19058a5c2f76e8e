"""``anglesmooth check``: report the quality of mesh files and gate on it, changing nothing."""

from __future__ import annotations

import sys

import click

from .. import _paths, report
from ..batch import FileResult, check_files
from . import formats
from .errors import Usage, error, handle_errors
from .many import exclude_option, executor, expand_inputs, finish, jobs_option, scheduler_option, worst_exit
from .meshfiles import STDIO, display, plan_outputs, read_mesh
from .options import debug_option, gate_options, input_format_option, json_option, quiet_option
from .outputs import gate_thresholds, make_console, note_stale, plain


@click.command("check")
@click.argument("inputs", nargs=-1, required=True, metavar="INPUT...")
@input_format_option
@gate_options
@exclude_option
@jobs_option
@scheduler_option
@json_option
@formats.format_option
@formats.junit_option
@quiet_option
@debug_option
@handle_errors
def check_cmd(inputs, input_format, exclude, jobs, scheduler, json_path, report_format, junit_path, quiet, debug,
              **gate_opts) -> None:
    """Report the quality of meshes without changing them.

    An INPUT may be a directory (searched for mesh files by suffix) or a glob.
    Exit 0 when every file passes every gate, 1 when a gate fails, 3 when a file
    cannot be read (the others are still checked; 3 wins over 1).  A file with
    inverted or degenerate cells fails even without thresholds (--max-inverted N
    and --max-degenerate N relax it).
    """
    console = make_console(quiet)
    formats.check_junit_path(junit_path)
    paths = [p for p, _ in expand_inputs(inputs, exclude)]
    read = [*(("INPUT", p) for p in paths), ("--gate-file", gate_opts.get("gate_file"))]
    outs = plan_outputs({"--json": json_path, "--junit-xml": junit_path}, read)
    note_stale(console, outs)
    thresholds, exit_zero = gate_thresholds(gate_opts, safe=True)
    if STDIO in paths and (jobs != 1 or scheduler):
        raise Usage("'-' (stdin) cannot be checked with --jobs or --scheduler")
    entries = []
    with executor(scheduler, jobs) as client:
        results = check_files(paths, input_format=input_format, thresholds=thresholds, jobs=jobs, client=client,
                              on_result=lambda i, r: entries.append(_entry(r, debug)[0]),
                              names=[display(p) for p in paths], reader=read_mesh if STDIO in paths else None)
    if not paths:
        plain(console, "no files to check: every file matches --exclude")
    elif len(entries) == 1 and entries[0]["report"] is not None:
        console.print(report.check_table(entries[0]["report"], title=display(paths[0])))
    elif len(entries) > 1:
        console.print(report.files_table(entries, with_gates=bool(thresholds)))
    outcomes = [formats.outcome(e) for e in entries]
    formats.report(report_format, outcomes, lambda text: plain(console, text), data_on_stdout=_paths.carries_stdout(json_path, junit_path))
    errors = any(e["error"] for e in entries)
    passed = not errors and all(e["passed"] for e in entries)
    finish(outs, json_path, report.check_json(entries, passed), junit_path, outcomes, "anglesmooth check",
           worst_exit(results, exit_zero))


def _entry(result: FileResult, debug: bool) -> tuple[dict, list[str]]:
    """A file's JSON entry and failed-gate lines; an error gets its one line here (in input order)."""
    if result.error is not None:
        if debug and result.traceback:
            sys.stderr.write(result.traceback)
        error(result.error_line)
    return result.entry, list(result.messages)

