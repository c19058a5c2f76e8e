"""Quality matrix (issue 12): mesh families x methods x seeds -> angles, sizes, validity, time.

Every family of :mod:`families` (gmsh meshes of toothed, curved, two-region and boundary-layer
domains, jittered or not, and the paper-style meshes of :mod:`anglesmooth.generate`) is
smoothed by every method of ``anglesmooth.smoothers.SMOOTHERS`` with the guard on, plus
``literal`` (``angle`` with the guard off, the paper's rule, ``--no-guard``), for ``--passes``
passes through :func:`anglesmooth.smooth`.  Per mesh it records (all from
:mod:`anglesmooth.quality`):

* ``min_angle`` / ``max_angle``: the extreme corner angles of the mesh (degrees);
* ``mean_min_angle`` / ``mean_max_angle``: the mean over cells of each cell's smallest /
  largest corner angle;
* ``below_20`` / ``above_150``: number of cell *corners* with angle < 20 / > 150 degrees;
* ``area_ratio``: largest over smallest absolute cell area (inf with a zero-area cell);
* ``l2_f1``: the paper's Table 5 surface-approximation error (bilinear patches, ``f1 =
  sin(2 pi x / l) sin(2 pi y / l)``, ``paper_experiments.bilinear_l2_error``), on the mesh
  scaled to the paper's [0, 100] box; over the quads of quad meshes (>= 95 % quads) only
  (``l2_f2``, ``l2_f3`` in the JSON);
* ``inverted`` (signed area <= 0), ``nonconvex`` (non-convex quads) and ``new_nonconvex``
  (non-convex now, valid -- convex with positive area -- in the input);
* ``s_per_pass``: median wall time of one pass.

The table gives, per family and method, the median over seeds and the [min-max] range.  The
verdict section judges the default ``angle`` per family, as issue 12's "Done means" reads: its
"mean minimum angle" is the mesh's minimum angle averaged over the seeds (the thresholds 24, 25
and 18 degrees are of that quantity), likewise the mean maximum angle:

1. mean min angle >= max(laplacian's, literal's);
2. mean max angle <= laplacian's;
3. distorted quad families: mean min angle >= optimization's;
4. paper-tri >= 24, paper-mixed >= 25, graded >= 18 degrees (mean min angle);
5. paper-style families: area ratio <= 1.25 x literal's on every seed;
6. 0 inverted cells and 0 new non-convex quads on every seed;
7. already-good families: min and max angle no worse than the input's on every seed.

Shown beside it but not part of PASS/FAIL: the extreme-angle comparisons seed by seed, the
means over cells of each cell's min / max angle against laplacian and literal (the measure
Laplacian's averaging favours), Table 5's error against the literal rule's (quad meshes), and
the time of a default pass over a literal pass (median over seeds of the per-seed ratio; same
run, but timings on a shared machine are noisy).

Usage::

    PYTHONPATH=src python benchmarks/quality_matrix.py                       # everything, 3 seeds, 10 passes
    PYTHONPATH=src python benchmarks/quality_matrix.py --families quad-distorted-toothed,paper-tri \\
        --methods angle,laplacian --seeds 2 --markdown m.md --json m.json
    PYTHONPATH=src python benchmarks/quality_matrix.py --compare benchmarks/results/quality_matrix_before.json
    PYTHONPATH=src python benchmarks/quality_matrix.py --tiny                # seconds; what the test runs

No number is asserted anywhere: the benchmark prints and judges, tests only check it runs.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

LITERAL = "literal"  # angle with guard=False
METRICS = ("min_angle", "max_angle", "mean_min_angle", "mean_max_angle", "below_20", "above_150", "area_ratio",
           "l2_f1", "inverted", "nonconvex", "new_nonconvex", "s_per_pass")
# (header, metric, format)
COLUMNS = (
    ("min°", "min_angle", ".1f"),
    ("max°", "max_angle", ".1f"),
    ("mean min°", "mean_min_angle", ".2f"),
    ("mean max°", "mean_max_angle", ".2f"),
    ("<20°", "below_20", ".0f"),
    (">150°", "above_150", ".0f"),
    ("area ratio", "area_ratio", ".3g"),
    ("L2 f1", "l2_f1", ".4g"),
    ("inv", "inverted", ".0f"),
    ("non-cvx (new)", "nonconvex", ".0f"),
    ("ms/pass", "s_per_pass", ".3g"),
)


def method_table() -> dict[str, tuple[str, bool]]:
    """name -> (library method, guard): every registered smoother guarded, plus the literal rule."""
    from anglesmooth.smoothers import SMOOTHERS

    out = {name: (name, True) for name in SMOOTHERS}
    out[LITERAL] = ("angle", False)
    return out


# --------------------------------------------------------------------------- metrics
def surface_errors(points: np.ndarray, topo) -> dict[str, float | None]:
    """Table 5's bilinear-patch L2 errors over the quads, on the mesh scaled to [0, 100].

    Only for quad meshes (at least 95 % quads: gmsh's recombination may leave a few triangles,
    which are left out of the sum); None otherwise.
    """
    import paper_experiments as pe

    if topo.n_quad == 0 or topo.n_tri > 0.05 * (topo.n_tri + topo.n_quad):
        return {f"l2_{k}": None for k in pe.FUNCTIONS}
    lo = points.min(axis=0)
    ext = float((points.max(axis=0) - lo).max())
    p = (points - lo) * (100.0 / ext)
    return {f"l2_{k}": pe.bilinear_l2_error(p, topo.quad, f, 100.0)[0] for k, f in pe.FUNCTIONS.items()}


def measure(points: np.ndarray, topo, input_nonconvex: np.ndarray | None) -> dict:
    from anglesmooth.quality import cell_max_angles, cell_min_angles, nonconvex_quads, summarize

    s = summarize(points, topo)
    ncv = nonconvex_quads(points, topo)
    new = ncv if input_nonconvex is None else np.setdiff1d(ncv, input_nonconvex)
    mn, mx = cell_min_angles(points, topo), cell_max_angles(points, topo)
    out = {
        "min_angle": s["min_angle"],
        "max_angle": s["max_angle"],
        "mean_min_angle": float(mn.mean()),
        "mean_max_angle": float(mx.mean()),
        "below_20": s["angles_below_20"],
        "above_150": s["angles_above_150"],
        "area_ratio": s["area_ratio"] if s["area_ratio"] is not None else math.inf,
        "inverted": s["inverted"],
        "degenerate": s["degenerate"],
        "nonconvex": s["nonconvex_quads"],
        "new_nonconvex": int(new.size) if input_nonconvex is not None else 0,
    }
    out.update(surface_errors(points, topo))
    return out


def run_one(mesh, topo, method: str, guard: bool, passes: int, input_ncv) -> dict:
    from anglesmooth import smooth

    stamps = [time.perf_counter()]
    res = smooth(mesh, method, passes, guard=guard, topology=topo,
                 callback=lambda k, p, d: stamps.append(time.perf_counter()))
    row = measure(res.points, topo, input_ncv)
    row["s_per_pass"] = float(np.median(np.diff(stamps))) if len(stamps) > 1 else 0.0
    row["passes"] = res.passes
    row["rejected"] = int(res.rejected)
    return row


# --------------------------------------------------------------------------- aggregation
def _finite(values):
    return [v for v in values if v is not None]


def summary(values) -> dict | None:
    """median / min / max over seeds (None dropped; inf kept)."""
    v = _finite(values)
    if not v:
        return None
    return {"median": float(statistics.median(v)), "min": float(min(v)), "max": float(max(v))}


def _fmt(x: float, spec: str) -> str:
    if x is None:
        return "—"
    if math.isinf(x):
        return "inf"
    if spec == ".3g" and abs(x) >= 1000:
        return f"{x:.0f}"
    return format(x, spec)


def cell(agg: dict | None, spec: str, scale: float = 1.0) -> str:
    if agg is None:
        return "—"
    med, lo, hi = (agg[k] * scale for k in ("median", "min", "max"))
    if lo == hi:
        return _fmt(med, spec)
    return f"{_fmt(med, spec)} [{_fmt(lo, spec)}–{_fmt(hi, spec)}]"


# --------------------------------------------------------------------------- verdict
TOL = 1e-9


def verdict(family, per_seed: dict[str, list[dict]]) -> dict:
    """Checks of the default ``angle`` against the others on every seed; PASS when all applicable ones hold."""
    a = per_seed.get("angle")
    checks: dict[str, dict] = {}
    if not a:
        return {"result": "n/a", "checks": checks}
    n = len(a)

    def check(name, ok_list, detail):
        checks[name] = {"ok": all(ok_list), "seeds_ok": int(sum(ok_list)), "seeds": n, "detail": detail}

    lap, lit, opt = per_seed.get("laplacian"), per_seed.get(LITERAL), per_seed.get("optimization")

    def mean(rows, key):
        return statistics.mean(r[key] for r in rows)

    def seed_mean(name, ok, detail):
        checks[name] = {"ok": bool(ok), "seeds_ok": None, "seeds": n, "detail": [detail]}

    # issue 12's "mean minimum angle" is the mesh's minimum angle averaged over the seeds
    # (its thresholds, 24/25/18 degrees, are of that quantity); likewise for the maximum angle
    if lap and lit:
        ref = max(mean(lap, "min_angle"), mean(lit, "min_angle"))
        seed_mean("mean min ≥ max(lap, literal)", mean(a, "min_angle") >= ref - TOL,
                  f"{mean(a, 'min_angle'):.2f} vs {ref:.2f}")
    if lap:
        seed_mean("mean max ≤ lap", mean(a, "max_angle") <= mean(lap, "max_angle") + TOL,
                  f"{mean(a, 'max_angle'):.2f} vs {mean(lap, 'max_angle'):.2f}")
    if family.distorted_quad and opt:
        seed_mean("mean min ≥ optimization", mean(a, "min_angle") >= mean(opt, "min_angle") - TOL,
                  f"{mean(a, 'min_angle'):.2f} vs {mean(opt, 'min_angle'):.2f}")
    if family.min_angle_target is not None:
        seed_mean(f"mean min ≥ {family.min_angle_target:g}", mean(a, "min_angle") >= family.min_angle_target,
                  f"{mean(a, 'min_angle'):.2f}")
    if family.paper and lit:
        check("area ratio ≤ 1.25 literal",
              [a[i]["area_ratio"] <= 1.25 * lit[i]["area_ratio"] for i in range(n)],
              [f"{a[i]['area_ratio']:.3g} vs 1.25*{lit[i]['area_ratio']:.3g}" for i in range(n)])
    check("0 inverted, 0 new non-convex",
          [a[i]["inverted"] == 0 and a[i]["new_nonconvex"] == 0 for i in range(n)],
          [f"inv {a[i]['inverted']}, new non-cvx {a[i]['new_nonconvex']}" for i in range(n)])
    inp = per_seed.get("input")
    if family.good and inp:
        check("no worse than input",
              [a[i]["min_angle"] >= inp[i]["min_angle"] - TOL and a[i]["max_angle"] <= inp[i]["max_angle"] + TOL
               for i in range(n)],
              [f"min {inp[i]['min_angle']:.1f}->{a[i]['min_angle']:.1f}, max {inp[i]['max_angle']:.1f}->"
               f"{a[i]['max_angle']:.1f}" for i in range(n)])
    # informational, not part of PASS/FAIL: the per-seed extremes, the means over cells of each
    # cell's min / max angle (Laplacian's own strength), and Table 5's error against the literal rule
    verdict_checks = dict(checks)
    checks.clear()
    if lap and lit:
        check("min ≥ max(lap, literal) per seed",
              [a[i]["min_angle"] >= max(lap[i]["min_angle"], lit[i]["min_angle"]) - TOL for i in range(n)],
              [f"{a[i]['min_angle']:.1f} vs {max(lap[i]['min_angle'], lit[i]['min_angle']):.1f}" for i in range(n)])
        check("cell-mean min ≥ max(lap, literal)",
              [a[i]["mean_min_angle"] >= max(lap[i]["mean_min_angle"], lit[i]["mean_min_angle"]) - TOL
               for i in range(n)],
              [f"{a[i]['mean_min_angle']:.2f} vs {max(lap[i]['mean_min_angle'], lit[i]['mean_min_angle']):.2f}"
               for i in range(n)])
    if lap:
        check("max ≤ lap per seed", [a[i]["max_angle"] <= lap[i]["max_angle"] + TOL for i in range(n)],
              [f"{a[i]['max_angle']:.1f} vs {lap[i]['max_angle']:.1f}" for i in range(n)])
        check("cell-mean max ≤ lap", [a[i]["mean_max_angle"] <= lap[i]["mean_max_angle"] + TOL for i in range(n)],
              [f"{a[i]['mean_max_angle']:.2f} vs {lap[i]['mean_max_angle']:.2f}" for i in range(n)])
    if lit and all(a[i].get("l2_f1") is not None for i in range(n)):
        check("L2 f1 ≤ literal", [a[i]["l2_f1"] <= lit[i]["l2_f1"] * (1 + 1e-12) for i in range(n)],
              [f"{a[i]['l2_f1']:.4g} vs {lit[i]['l2_f1']:.4g}" for i in range(n)])
    if lit and all(a[i].get("s_per_pass") and lit[i].get("s_per_pass") for i in range(n)):
        ratio = statistics.median(a[i]["s_per_pass"] / lit[i]["s_per_pass"] for i in range(n))
        checks["pass ≤ 2× literal"] = {"ok": ratio <= 2.0, "seeds_ok": None, "seeds": n, "detail": [f"{ratio:.1f}×"]}
    info = dict(checks)
    return {"result": "PASS" if all(c["ok"] for c in verdict_checks.values()) else "FAIL",
            "checks": verdict_checks, "info": info}


# --------------------------------------------------------------------------- output
def markdown(result: dict) -> str:
    cfg = result["config"]
    lines = [
        f"Quality matrix: {cfg['passes']} passes, seeds {cfg['seeds']}, kernel `{cfg['kernel']}`. "
        "Cells: median over seeds [min–max]. `<20°`/`>150°` count cell corners; `non-cvx (new)` is non-convex "
        "quads (new ones, valid in the input, in parentheses); `L2 f1` is Table 5's bilinear-patch error "
        "(all-quad meshes, scaled to [0, 100]²); `ms/pass` the median time of one pass.",
        "",
        "| family | method | " + " | ".join(c[0] for c in COLUMNS) + " |",
        "|---|---|" + "---:|" * len(COLUMNS),
    ]
    for fam, fres in result["families"].items():
        info = fres["info"]
        for method, agg in fres["aggregate"].items():
            cells = []
            for header, key, spec in COLUMNS:
                if key == "nonconvex":
                    c = cell(agg["nonconvex"], spec)
                    if method != "input" and agg["new_nonconvex"] and agg["new_nonconvex"]["max"] > 0:
                        c += f" ({cell(agg['new_nonconvex'], spec)})"
                    cells.append(c)
                elif key == "s_per_pass":
                    cells.append("" if method == "input" else cell(agg[key], spec, 1000.0))
                else:
                    cells.append(cell(agg.get(key), spec))
            label = f"{fam} ({info})" if method == "input" else fam
            lines.append(f"| {label} | {method} | " + " | ".join(cells) + " |")
    lines += ["", "Verdict for the default `angle` (every seed must pass; `k/n` = seeds passing):", "",
              "| family | verdict | checks | also (not in the verdict) |", "|---|---|---|---|"]

    def parts(checks):
        return "; ".join(f"{'✓' if c['ok'] else '✗'} {name}" + (f" {c['seeds_ok']}/{c['seeds']}" if c["seeds_ok"] is not None
                                                               else f" ({c['detail'][0]})")
                         for name, c in checks.items())

    for fam, fres in result["families"].items():
        v = fres["verdict"]
        lines.append(f"| {fam} | **{v['result']}** | {parts(v['checks'])} | {parts(v.get('info', {}))} |")
    fails = [(fam, name, c) for fam, fres in result["families"].items() for name, c in fres["verdict"]["checks"].items()
             if not c["ok"]]
    if fails:
        lines += ["", "Failed verdict checks, per seed (default vs reference):", ""]
        for fam, name, c in fails:
            lines.append(f"- {fam}: {name}: " + "; ".join(c["detail"]))
    lines += ["", f"Total {result['elapsed_s']:.0f} s."]
    return "\n".join(lines) + "\n"


COMPARE = (("min°", "min_angle", ".1f"), ("max°", "max_angle", ".1f"), ("mean min°", "mean_min_angle", ".2f"),
           ("mean max°", "mean_max_angle", ".2f"), ("area ratio", "area_ratio", ".3g"), ("L2 f1", "l2_f1", ".4g"),
           ("ms/pass", "s_per_pass", ".3g"))


def compare(result: dict, before: dict, method: str = "angle") -> str:
    """A markdown table: ``method``'s medians over seeds in ``before`` (a JSON of this script) and now, per family."""
    lines = [f"`{method}` before → after (medians over seeds; before: {before['config'].get('anglesmooth', '?')}, "
             f"seeds {before['config'].get('seeds')}, {before['config'].get('passes')} passes):", "",
             "| family | verdict | " + " | ".join(c[0] for c in COMPARE) + " |", "|---|---|" + "---:|" * len(COMPARE)]

    def med(fres, key):
        agg = fres["aggregate"].get(method, {}).get(key)
        if agg is None:
            return None
        v = agg["median"]
        return math.inf if v == "inf" else v

    for fam, now in result["families"].items():
        old = before["families"].get(fam)
        if old is None or method not in now["aggregate"] or method not in old["aggregate"]:
            continue
        cells = []
        for _, key, spec in COMPARE:
            scale = 1000.0 if key == "s_per_pass" else 1.0
            a, b = med(old, key), med(now, key)
            cells.append("—" if a is None or b is None else f"{_fmt(a * scale, spec)} → {_fmt(b * scale, spec)}")
        v = f"{old['verdict']['result']} → {now['verdict']['result']}"
        lines.append(f"| {fam} | {v} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _json_safe(o):
    if isinstance(o, float) and not math.isfinite(o):
        return None if math.isnan(o) else ("inf" if o > 0 else "-inf")
    if isinstance(o, dict):
        return {k: _json_safe(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_json_safe(v) for v in o]
    return o


# --------------------------------------------------------------------------- main
def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--families", help="comma-separated family names (default: all; 'good', 'paper' expand)")
    p.add_argument("--methods", help="comma-separated methods (default: every SMOOTHERS entry + literal)")
    p.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 per family (default 3)")
    p.add_argument("--passes", type=int, default=10)
    p.add_argument("--kernel", choices=("numpy", "numba", "auto"), default="numpy",
                   help="ANGLESMOOTH_KERNEL for the run (default numpy)")
    p.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "anglesmooth-quality-matrix",
                   help="directory of cached generated meshes (default: the system temp dir)")
    p.add_argument("--json", type=Path)
    p.add_argument("--markdown", type=Path)
    p.add_argument("--compare", type=Path, metavar="BEFORE_JSON",
                   help="also print the default's medians before (a --json of an earlier run) and now")
    p.add_argument("--tiny", action="store_true", help="coarse meshes, 1 seed, 2 passes (seconds; for the tests)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    os.environ["ANGLESMOOTH_KERNEL"] = args.kernel  # read by anglesmooth at every pass
    import families as fams
    from anglesmooth import __version__
    from anglesmooth.topology import build_topology

    if args.tiny:
        args.seeds, args.passes = 1, 2
    try:
        names = fams.resolve(args.families.split(",")) if args.families else list(fams.FAMILIES)
    except KeyError as e:
        print(f"error: {e.args[0]}", file=sys.stderr)
        return 2
    table = method_table()
    methods = args.methods.split(",") if args.methods else list(table)
    unknown = [m for m in methods if m not in table]
    if unknown:
        print(f"error: unknown method(s) {', '.join(unknown)}; known: {', '.join(table)}", file=sys.stderr)
        return 2
    log = (lambda *a: None) if args.quiet else (lambda *a: print(*a, file=sys.stderr, flush=True))
    seeds = list(range(args.seeds))
    t_all = time.perf_counter()
    result = {
        "config": {"passes": args.passes, "seeds": seeds, "kernel": args.kernel, "methods": methods,
                   "tiny": args.tiny, "anglesmooth": __version__, "python": platform.python_version(),
                   "numpy": np.__version__},
        "families": {},
    }
    for name in names:
        fam = fams.FAMILIES[name]
        t0 = time.perf_counter()
        per_seed: dict[str, list[dict]] = {"input": [], **{m: [] for m in methods}}
        meshes = []
        for seed in seeds:
            mesh = fams.get(name, seed, args.cache, tiny=args.tiny)
            topo = build_topology(mesh)
            inp = measure(mesh.points, topo, None)
            inp["s_per_pass"] = None
            per_seed["input"].append(inp)
            meshes.append({"seed": seed, "nodes": int(mesh.n_points), "triangles": int(topo.n_tri),
                           "quads": int(topo.n_quad), "free": int(topo.n_free)})
            from anglesmooth.quality import invalid_cells

            # quads invalid in the input (inverted, degenerate or non-convex): not "new" when non-convex later
            ncv0 = np.flatnonzero(invalid_cells(mesh.points, topo)[topo.n_tri:])
            for m in methods:
                lib, guard = table[m]
                try:
                    row = run_one(mesh, topo, lib, guard, args.passes, ncv0)
                except Exception as e:  # a method that fails is a finding, not a crash of the matrix
                    row = {k: None for k in METRICS} | {"error": f"{type(e).__name__}: {e}"}
                    log(f"  {name} seed {seed} {m}: {row['error']}")
                per_seed[m].append(row)
        keys = [*METRICS, "l2_f2", "l2_f3"]
        aggregate = {m: {k: summary([r.get(k) for r in rows]) for k in keys} for m, rows in per_seed.items()}
        nodes = statistics.median(x["nodes"] for x in meshes)
        kinds = [f"{int(statistics.median(x[k] for x in meshes))} {k[:4] if k != 'triangles' else 'tri'}"
                 for k in ("triangles", "quads") if any(x[k] for x in meshes)]
        info = f"{int(nodes)} nodes, " + ", ".join(kinds)
        result["families"][name] = {
            "description": fam.description, "kind": fam.kind, "info": info, "meshes": meshes,
            "per_seed": per_seed, "aggregate": aggregate, "verdict": verdict(fam, per_seed),
            "elapsed_s": time.perf_counter() - t0,
        }
        log(f"{name:24s} {info:34s} {time.perf_counter() - t0:6.1f} s  {result['families'][name]['verdict']['result']}")
    result["elapsed_s"] = time.perf_counter() - t_all
    md = markdown(result)
    if args.compare:
        md += "\n" + compare(result, json.loads(args.compare.read_text()))
    sys.stdout.write(md)
    if args.markdown:
        args.markdown.write_text(md)
    if args.json:
        args.json.write_text(json.dumps(_json_safe(result), indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
