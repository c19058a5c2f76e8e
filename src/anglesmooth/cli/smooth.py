"""``anglesmooth smooth`` (the default command): smooth one mesh file and write the result."""

from __future__ import annotations

import os

import click

from .. import _paths, report
from .._memory import release_free_memory
from ..driver import smooth as run_smooth
from ..errors import MeshReadError
from ..fixing import fixed_mask
from ..gates import evaluate
from ..quality import summarize
from ..smoothers import SMOOTHERS
from ..smoothers._fast import active as fast_active
from ..smoothers._fast import compile_estimate, kernel_mode, set_threads
from ..smoothers._jitcache_warm import start as warm_start
from ..topology import build_topology
from . import formats
from .errors import EXIT_GATE, Usage, handle_errors
from .many import jobs_option, scheduler_option, smooth_many, wants_many
from .meshfiles import (STDIO, check_output, check_paths, display, fix_node_indices, prepare_output,
                        read_fix_nodes, read_mesh, write_mesh)
from .options import (FiniteFloat, binary_option, debug_option, gate_options, input_format_option, json_option,
                      no_guard_option, node_numbering_option, order_option, output_format_option,
                      quiet_option)
from .outputs import (PROGRESS_MIN_CELLS, emit_json, gate_thresholds, make_console, note_fast, note_stale, plain,
                      progress_bar, warn_invalid)


#: Fewest cells for which the output's cell arrays are compressed ahead (``io.prepare_write``): below
#: some 170k triangles no array has enough blocks to be compressed apart (``io._vtu.MIN_BLOCKS``).
PRECOMPRESS_MIN_CELLS = 100_000

#: The other commands' names: the INPUT of an implied ``smooth`` when options come before the command.
COMMANDS = ("check", "compare", "schema", "smooth")


@click.command("smooth")
@click.argument("input", metavar="INPUT")
@click.argument("output", metavar="[OUTPUT]", required=False)
@click.argument("more", nargs=-1, metavar="[INPUT]...")
@click.option("--method", "-m", type=click.Choice(list(SMOOTHERS)), default="angle", show_default=True,
              help="Smoothing method (from the registry).")
@click.option("--passes", "-n", type=click.IntRange(min=0), default=10, show_default=True, help="Maximum passes.")
@click.option("--tol", type=FiniteFloat(min=0), metavar="T",
              help="Stop once a pass moves no node by more than T x the mean edge length.")
@no_guard_option
@order_option
@click.option("--fix-group", multiple=True, metavar="GROUP",
              help="Also fix the nodes of this group: a name, or a gmsh physical number (11) or dim:number (2:11) "
                   "(repeatable).")
@click.option("--fix-nodes", type=click.Path(exists=True, dir_okay=False), metavar="FILE",
              help="Also fix these nodes: whitespace-separated numbers, '#' comments; 0-based indices unless "
                   "--node-numbering gmsh.")
@node_numbering_option
@click.option("--force", is_flag=True,
              help="Allow OUTPUT to be the input file (a path, symlink or hard link to it); see --in-place.")
@click.option("--in-place", is_flag=True, help="Overwrite INPUT (give no OUTPUT).")
@input_format_option
@output_format_option
@binary_option
@click.option("--output-dir", type=click.Path(file_okay=False), metavar="DIR",
              help="Several INPUTs (files, directories, globs): write each result to DIR under its own name.")
@click.option("--suffix", default="", metavar="SUFFIX", help="Several INPUTs: add SUFFIX to each output's stem.")
@jobs_option
@scheduler_option
@gate_options
@json_option
@formats.format_option
@formats.junit_option
@click.option("--plot", type=click.Path(dir_okay=False), metavar="PNG",
              help="Write a PNG: mesh before/after coloured by minimum angle (inverted cells black, "
                   "degenerate cyan), angle histograms.")
@click.option("--progress/--no-progress", default=None,
              help=f"Progress bar over passes [default: on a terminal with > {PROGRESS_MIN_CELLS} cells].")
@click.option("--threads", type=click.IntRange(min=1), metavar="N",
              help="At most N threads for the compiled kernels [default: the cores this process may use; "
                   "NUMBA_NUM_THREADS caps it too].")
@quiet_option
@debug_option
@handle_errors
def smooth_cmd(input, output, more, method, passes, tol, no_guard, order, fix_group, fix_nodes, node_numbering, force,
               in_place, input_format, output_format, binary, output_dir, suffix, jobs, scheduler, json_path,
               report_format, junit_path, plot, progress, threads, quiet, debug, **gate_opts) -> None:
    """Smooth INPUT and write OUTPUT ('-' for stdin/stdout); gates apply to the result, after writing it.

    An existing OUTPUT is replaced (atomically, keeping its owner and mode), as gmsh -o and cp do; OUTPUT
    may be the input file itself only with --force or --in-place (exit 2 otherwise).  Two mesh files alone
    mean INPUT OUTPUT, also when a shell glob gives them ('anglesmooth *.msh'): give several files with
    --output-dir or --suffix.

    Several INPUTs (files, directories, globs) with --output-dir DIR, --suffix or --in-place smooth each
    file (--jobs N in parallel processes, --scheduler on a Dask cluster) and end with a summary table.
    """
    console = make_console(quiet)
    if input in COMMANDS and not os.path.lexists(input):  # 'anglesmooth --quiet check a.msh': options came first
        raise Usage(f"no mesh file '{input}': to run the {input} command, give the options after its name "
                    f"('anglesmooth {input} ARGS... [OPTIONS]')")
    if wants_many(input, output, more, output_dir=output_dir, suffix=suffix, jobs=jobs, scheduler=scheduler,
                  in_place=in_place):
        one_file_only = {"--node-numbering gmsh": node_numbering != "index", "--binary/--ascii": binary is not None,
                         "--threads": threads is not None}
        if any(one_file_only.values()):
            raise Usage(f"{next(k for k, v in one_file_only.items() if v)} works with one INPUT only (not yet with several)")
        thresholds, exit_zero = gate_thresholds(gate_opts)
        kernel_mode()
        return smooth_many(console, [input, output, *more], output_dir=output_dir, suffix=suffix,
                           output_format=output_format, in_place=in_place, jobs=jobs, scheduler=scheduler,
                           json_path=json_path, report_format=report_format, junit_path=junit_path,
                           thresholds=thresholds, exit_zero=exit_zero, progress=progress,
                           debug=debug, fix_nodes=read_fix_nodes(fix_nodes) if fix_nodes else None, plot=plot,
                           method=method, passes=passes, tol=tol, guard=not no_guard, order=order,
                           fix_groups=fix_group, input_format=input_format)
    formats.check_junit_path(junit_path)
    if output is not None and input != STDIO and os.path.isdir(input):  # before OUTPUT's checks: the cause
        raise MeshReadError(f"cannot read '{input}': is a directory (to smooth every mesh file in it, give "
                            f"--output-dir DIR: anglesmooth smooth '{input}' --output-dir DIR)")
    output, outs = check_paths(input, output, force=force, in_place=in_place, input_format=input_format,
                               output_format=output_format, json_path=json_path, plot=plot, fix_nodes=fix_nodes,
                               gate_file=gate_opts.get("gate_file"), junit_path=junit_path)
    note_stale(console, outs)
    thresholds, exit_zero = gate_thresholds(gate_opts)
    kernel_mode()  # a bad ANGLESMOOTH_KERNEL is a usage error before any work
    set_threads(threads)
    if plot:
        from ..plot import require_matplotlib

        require_matplotlib()
    user_nodes = read_fix_nodes(fix_nodes, node_numbering) if fix_nodes else None
    name, out_name = display(input), "<stdout>" if output == STDIO else output
    # every output is staged and committed together at the end: an error or a signal
    # before that leaves none of them (see README "Rules")
    with outs:
        mesh = read_mesh(input, input_format)
        if passes:  # a compile of the kernels (cold cache) overlaps the set-up below
            warm_start(method, mesh.n_points, only_cold=True)
        check_output(mesh, output, output_format, binary)  # the output format can hold the mesh: fail before smoothing
        if mesh.n_cells >= PRECOMPRESS_MIN_CELLS:  # the output's cell arrays compress during the set-up
            prepare_output(mesh, output, output_format, binary)
        user_nodes = fix_node_indices(mesh, user_nodes, node_numbering) if user_nodes is not None else None
        topo = build_topology(mesh, fixed_mask(mesh, fix_group, user_nodes))
        before = summarize(mesh.points, topo)
        release_free_memory()  # the build's and the summary's freed temporaries (1M triangles: 30 MB of peak)
        warn_invalid(console, name, before)
        note_fast(console, topo, passes)
        compiled = bool(passes) and fast_active(topo)
        compiling = compile_estimate(method) if compiled else 0.0
        if compiling:  # the first run ever (or after an upgrade): say so, whatever stderr is
            plain(console, f"compiling kernels once, about {max(1, round(compiling))} s")
        with progress_bar(console, passes, mesh.n_cells, progress, compiled=compiled,
                          compiling=bool(compiling)) as callback:
            result = run_smooth(mesh, method, passes, tol=tol, guard=not no_guard, order=order, topology=topo,
                                callback=callback)
        release_free_memory()  # the passes' freed temporaries, before the summary's
        after = summarize(result.points, topo)
        gates = evaluate(after, thresholds, result.points, topo)
        document = report.smooth_json(
            input=name, output=out_name, method=method, guard=not no_guard, order=order, passes=result.passes,
            passes_requested=passes, tol=tol, displacements=result.displacements, rejected=result.rejected,
            before=before, after=after, elapsed_s=result.elapsed_s, gates=gates,
            passed=all(g.passed for g in gates), compile_s=result.compile_s)
        outcomes = [formats.Outcome(out_name, gates)]
        write_mesh(mesh, output, result.points, output_format, binary)
        emit_json(json_path, document)
        if junit_path:
            formats.stage_text(junit_path, formats.junit_xml(outcomes, "anglesmooth smooth"))
        if plot:
            from ..plot import plot_smooth

            plot_smooth(plot, topo, mesh.points, result.points, title=f"{name}: {method}, {result.passes} passes")
        outs.commit()
    run = {"passes performed": f"{result.passes} / {passes}", "rejected moves": result.rejected,
           "last displacement": f"{result.displacements[-1] if result.displacements else 0:.3g} x mean edge",
           "time": f"{result.elapsed_s:.3f} s"}
    if result.compile_s:
        run["kernel compile / load"] = f"{result.compile_s:.3f} s"
    guard = "guarded" if not no_guard else "no guard"
    console.print(report.smooth_table(before, after, run, title=f"{name} -> {out_name}: {method}, {guard}, {order}"))
    if gates:  # without gates there is nothing to report
        formats.report(report_format, outcomes, lambda text: plain(console, text),
                       data_on_stdout=_paths.carries_stdout(output, json_path, junit_path, plot))
    passed = all(g.passed for g in gates)
    if not passed and not exit_zero:
        raise click.exceptions.Exit(EXIT_GATE)
