"""``anglesmooth check``: report the quality of mesh files and gate on it, changing nothing."""

from __future__ import annotations

import sys
import traceback

import click

from .. import report
from ..errors import AngleSmoothError
from ..gates import evaluate
from ..quality import summarize
from ..topology import build_cell_topology
from . import formats
from .errors import EXIT_GATE, EXIT_INPUT, classify, error, handle_errors
from .meshfiles import STDIO, display, plan_outputs, read_mesh
from .options import debug_option, gate_options, input_format_option, json_option, quiet_option
from .outputs import emit_json, gate_thresholds, make_console, note_stale, plain


@click.command("check")
@click.argument("inputs", nargs=-1, required=True, metavar="INPUT...")
@input_format_option
@gate_options
@json_option
@formats.format_option
@formats.junit_option
@quiet_option
@debug_option
@handle_errors
def check_cmd(inputs, input_format, json_path, report_format, junit_path, quiet, debug, **gate_opts) -> None:
    """Report the quality of meshes without changing them.

    Exit 0 when every file passes every gate, 1 when a gate fails, 3 when a file
    cannot be read (the others are still checked; 3 wins over 1).  A file with
    inverted or degenerate cells fails even without thresholds (--max-inverted N
    and --max-degenerate N relax it).
    """
    console = make_console(quiet)
    formats.check_junit_path(junit_path)
    read = [*(("INPUT", p) for p in inputs), ("--gate-file", gate_opts.get("gate_file"))]
    outs = plan_outputs({"--json": json_path, "--junit-xml": junit_path}, read)
    note_stale(console, outs)
    thresholds, exit_zero = gate_thresholds(gate_opts, safe=True)
    entries = [check_one(path, input_format, thresholds, debug)[0] for path in inputs]
    if len(entries) == 1 and entries[0]["report"] is not None:
        console.print(report.check_table(entries[0]["report"], title=display(inputs[0])))
    elif len(entries) > 1:
        console.print(report.files_table(entries, with_gates=bool(thresholds)))
    outcomes = [formats.outcome(e) for e in entries]
    formats.report(report_format, outcomes, lambda text: plain(console, text), data_on_stdout=json_path == STDIO)
    errors = any(e["error"] for e in entries)
    passed = not errors and all(e["passed"] for e in entries)
    with outs:
        emit_json(json_path, report.check_json(entries, passed))
        if junit_path:
            formats.stage_text(junit_path, formats.junit_xml(outcomes, "anglesmooth check"))
        outs.commit()
    if errors:
        raise click.exceptions.Exit(EXIT_INPUT)
    if not passed and not exit_zero:
        raise click.exceptions.Exit(EXIT_GATE)


def check_one(path: str, input_format, thresholds: dict, debug: bool) -> tuple[dict, list[str]]:
    """Read and measure one file: its JSON entry and its failed-gate lines (an unreadable file: an error entry)."""
    name = display(path)
    entry = {"input": name, "report": None, "gates": [], "passed": None, "error": None}
    try:
        mesh = read_mesh(path, input_format)
        topo = build_cell_topology(mesh)  # no smoothing tables needed
        summary = summarize(mesh.points, topo)
    except (AngleSmoothError, MemoryError) as exc:
        if debug:
            traceback.print_exc(file=sys.stderr)
        entry["error"] = classify(exc)[1]
        error(f"{name}: {entry['error']}" if name not in entry["error"] else entry["error"])
        return entry, []
    gates = evaluate(summary, thresholds, mesh.points, topo)
    entry.update(report=summary, gates=[g.to_dict() for g in gates], passed=all(g.passed for g in gates))
    return entry, [g.message(name) for g in gates if not g.passed]
