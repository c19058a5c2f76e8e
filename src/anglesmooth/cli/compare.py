"""``anglesmooth compare``: run every registered method on one mesh, one paper-style table."""

from __future__ import annotations

import time

import click
import numpy as np

from .. import report
from ..driver import smooth as run_smooth
from ..quality import cell_areas, cell_min_angles, summarize
from ..smoothers import SMOOTHERS
from ..smoothers._fast import kernel_mode
from ..topology import build_topology
from .errors import handle_errors
from .meshfiles import display, plan_outputs, read_mesh
from .options import debug_option, input_format_option, json_option, no_guard_option, order_option, quiet_option
from .outputs import emit_json, make_console, note_fast, note_stale, warn_invalid


@click.command("compare")
@click.argument("input", metavar="INPUT")
@click.option("--passes", "-n", type=click.IntRange(min=0), default=10, show_default=True, help="Passes per method.")
@no_guard_option
@order_option
@input_format_option
@json_option
@click.option("--plot", type=click.Path(dir_okay=False), metavar="PNG",
              help="Write a PNG with min angle and area ratio per pass for every method.")
@quiet_option
@debug_option
@handle_errors
def compare_cmd(input, passes, no_guard, order, input_format, json_path, plot, quiet, debug) -> None:
    """Run every registered method on INPUT and print one table (like the paper's Tables 1-2)."""
    console = make_console(quiet)
    outs = plan_outputs({"--json": json_path, "--plot": plot}, [("INPUT", input)])
    note_stale(console, outs)
    kernel_mode()  # a bad ANGLESMOOTH_KERNEL is a usage error before any work
    if plot:
        from ..plot import require_matplotlib

        require_matplotlib()
    name = display(input)
    with outs:
        mesh = read_mesh(input, input_format)
        topo = build_topology(mesh)
        before = summarize(mesh.points, topo)
        warn_invalid(console, name, before)
        note_fast(console, topo, passes)
        results = [_compare_one(mesh, topo, m, passes, not no_guard, order, before) for m in SMOOTHERS]
        guard = "guarded" if not no_guard else "no guard"
        emit_json(json_path, report.compare_json(input=name, passes_requested=passes, guard=not no_guard,
                                                 order=order, before=before, results=results))
        if plot:
            from ..plot import plot_compare

            plot_compare(plot, {r["method"]: r["history"] for r in results}, title=f"{name}: {guard}, {order}")
        outs.commit()
    console.print(report.compare_table(before, results, title=f"{name}: {passes} passes, {guard}, {order}"))


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
