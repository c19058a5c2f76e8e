"""Reproduce Zhou & Shimada (2000), Tables 1-5 and Figures 8-13 and 15, with anglesmooth.

    python benchmarks/paper/reproduce.py --seeds 10 --out docs/paper     # full (a few minutes at most)
    python benchmarks/paper/reproduce.py --smoke --out /tmp/paper        # 1 seed, 2 passes, tiny cost mesh

Writes ``README.md`` (tables over seeds beside the paper's values, with the
discussion), ``results.json`` (every number, per seed and aggregated) and the PNG
figures into ``--out``.  Seeds are 0 .. n-1 for every mesh kind.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import paper_experiments as ex  # noqa: E402
import paper_figures as fg  # noqa: E402
import paper_report as rp  # noqa: E402
import paper_values as pv  # noqa: E402

from anglesmooth import __version__  # noqa: E402
from anglesmooth import generate as gen  # noqa: E402

LABELS = {"original": "Original", **{k: v[3] for k, v in ex.METHODS.items()}}
FIG_METHODS = ["original", "laplacian", "smart-laplacian", "angle-literal", "angle-default", "optimization"]
FIGURES = {  # kind -> (file, title)
    "triangle": ("fig09_triangle.png", "Figure 9: triangle mesh (seed 0), {passes} passes"),
    "mixed": ("fig10_mixed.png", "Figure 10: tri-quad mixed mesh (seed 0), {passes} passes"),
    "graded": ("fig11_graded.png", "Figure 11: graded mesh (seed 0), {passes} passes"),
    "quad": ("fig15_quad.png", "Figure 15: quadrilateral mesh (seed 0), {passes} passes"),
}


def _clean(obj):
    """JSON-safe: numpy scalars to Python, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return float(f"{f:.7g}") if math.isfinite(f) else None
    return obj


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=10, help="number of seeds (0 .. n-1) per mesh kind")
    ap.add_argument("--passes", type=int, default=10, help="smoothing passes (the paper's setting: 10)")
    ap.add_argument("--out", type=Path, default=Path("docs/paper"))
    ap.add_argument("--cost-triangles", type=int, default=100_000, help="size of the large cost mesh")
    ap.add_argument("--smoke", action="store_true", help="1 seed, 2 passes, 2000-triangle cost mesh (for tests)")
    args = ap.parse_args(argv)
    if args.smoke:
        args.seeds, args.passes, args.cost_triangles = 1, 2, 2000
    # the paper's Section 5.2 compares the methods' vectorized (numpy) forms; pinning the kernel also
    # keeps docs/paper the same with and without the 'fast' extra (ANGLESMOOTH_KERNEL=auto overrides)
    os.environ.setdefault("ANGLESMOOTH_KERNEL", "numpy")
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    seeds = list(range(args.seeds))
    t_start = time.perf_counter()
    log = lambda *a: print(*a, flush=True)  # noqa: E731

    log(f"quality tables: {len(seeds)} seeds, {args.passes} passes")
    quality, keep = ex.quality_tables(seeds, args.passes, log)
    log("figure 12 / figure 8")
    fe = ex.five_element(args.passes)
    dist, dist_keep = ex.distorted(args.passes)
    log("table 5: surface approximation")
    surf = ex.surface_errors(seeds, args.passes)
    log("cost per pass")
    cost_small = ex.cost(gen.paper_triangle_mesh(seed=0), passes=args.passes, repeats=1 if args.smoke else 5)
    cost_large = ex.cost(gen.random_delaunay(args.cost_triangles, seed=0, size=100.0), passes=2 if args.smoke else 5)

    log("figures")
    figures = {}
    for kind, (fname, title) in FIGURES.items():
        k = keep[kind]
        panels = [(m, k["points"][m]) for m in FIG_METHODS if m in k["points"]]
        fg.mesh_panels(out / fname, k["topo"], panels, title.format(passes=args.passes), LABELS)
        figures[kind] = fname
    dpanels = [(m, dist_keep["points"][m]) for m in ("original", "laplacian-1pass", "smart-laplacian", "angle-literal",
                                                       "angle-default", "optimization")]
    dlabels = {**LABELS, "laplacian-1pass": "Laplacian, 1 pass (unguarded)"}
    fg.mesh_panels(out / "fig08_distorted.png", dist_keep["topo"], dpanels,
                   f"Figure 8: severely distorted mesh, {args.passes} passes (1 for the first Laplacian panel)",
                   dlabels)
    figures["distorted"] = "fig08_distorted.png"
    fg.figure12(out / "fig12_convergence.png", fe)
    figures["fig12"] = "fig12_convergence.png"
    t4 = {k: quality["triangle"]["per_pass"][k] for k in ("laplacian", "angle-literal", "angle-default")}
    fg.figure13(out / "fig13_passes.png", t4, pv.TABLE4, LABELS)
    figures["fig13"] = "fig13_passes.png"

    runtime = time.perf_counter() - t_start
    results = {
        "meta": {
            "command": " ".join(["python", "benchmarks/paper/reproduce.py", *(argv if argv is not None else sys.argv[1:])]),
            "seeds": seeds,
            "passes": args.passes,
            "smoke": args.smoke,
            "anglesmooth": __version__,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "machine": platform.machine(),
            "runtime_s": runtime,
            "labels": LABELS,
        },
        "quality": {k: {kk: vv for kk, vv in v.items()} for k, v in quality.items()},
        "five_element": fe,
        "distorted": dist,
        "surface": surf,
        "cost": {"paper_triangle": cost_small, "large": cost_large},
        "figures": figures,
        "paper": {
            "table1": pv.TABLE1, "table2": pv.TABLE2, "table3": pv.TABLE3, "table4": pv.TABLE4,
            "table5": pv.TABLE5, "fig12_ratio_pct": pv.FIG12_RATIO_PCT, "cost_claims": pv.COST_CLAIMS,
        },
    }
    results = _clean(results)
    (out / "results.json").write_text(json.dumps(results, indent=1) + "\n")
    (out / "README.md").write_text(rp.render(results))
    log(f"wrote {out}/README.md, results.json and {len(figures)} figures in {runtime:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
