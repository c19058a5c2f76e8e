"""Time ``anglesmooth.plot.plot_smooth`` on large meshes (figure build and PNG write, peak memory).

    PYTHONPATH=src python benchmarks/bench_plot.py                    # 100k and 1M triangles and quads
    PYTHONPATH=src python benchmarks/bench_plot.py --sizes 100k --repeat 3 --out /tmp/plots

Meshes: ``generate.random_delaunay`` / ``random_quad_mesh`` (seed 0); "after" is the same mesh with
its interior nodes jittered by 10 % of the cell size (the plot's cost does not depend on how the
coordinates were obtained).  Each case runs in its own subprocess (``RSS MB`` is that process's peak:
mesh, topology and figure); the median of ``--repeat`` runs in that process is reported.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

SIZES = {"100k": 100_000, "1M": 1_000_000}


def _case(kind: str, n: int, repeat: int, out: str) -> dict:
    import numpy as np

    from anglesmooth import generate
    from anglesmooth.plot import _save, smooth_figure
    from anglesmooth.quality import cell_areas
    from anglesmooth.topology import build_cell_topology

    mesh = generate.random_delaunay(n, seed=0) if kind == "tri" else generate.random_quad_mesh(n, seed=0)
    topo = build_cell_topology(mesh)
    h = float(np.sqrt(np.abs(cell_areas(mesh.points, topo)).mean()))
    after = mesh.points.copy()
    free = ~topo.fixed
    after[free] += np.random.default_rng(0).uniform(-0.1 * h, 0.1 * h, size=(int(free.sum()), 2))
    build, save = [], []
    for i in range(repeat):
        t0 = time.perf_counter()
        fig = smooth_figure(topo, mesh.points, after, title=f"{kind} {n}")
        t1 = time.perf_counter()
        _save(fig, os.path.join(out, f"bench_{kind}_{n}.png"))
        save.append(time.perf_counter() - t1)
        build.append(t1 - t0)
        del fig
    return {"mesh": kind, "cells": topo.n_tri + topo.n_quad, "build_s": statistics.median(build),
            "save_s": statistics.median(save), "total_s": statistics.median(b + s for b, s in zip(build, save)),
            "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100k,1M")
    ap.add_argument("--kinds", default="tri,quad")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--out", default=".", help="directory for the PNGs")
    ap.add_argument("--json")
    ap.add_argument("--case", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.case:
        kind, n = args.case.split(":")
        print(json.dumps(_case(kind, int(n), args.repeat, args.out)))
        return
    rows = []
    print(f"{'mesh':6} {'cells':>9} {'build s':>8} {'save s':>7} {'total s':>8} {'RSS MB':>7}")
    for size in args.sizes.split(","):
        for kind in args.kinds.split(","):
            res = subprocess.run([sys.executable, __file__, "--case", f"{kind}:{SIZES[size]}", "--repeat",
                                  str(args.repeat), "--out", args.out], capture_output=True, text=True)
            if res.returncode:
                print(f"{kind} {size}: failed\n{res.stderr}", file=sys.stderr)
                continue
            r = json.loads(res.stdout.strip().splitlines()[-1])
            rows.append(r)
            print(f"{r['mesh']:6} {r['cells']:9d} {r['build_s']:8.2f} {r['save_s']:7.2f} {r['total_s']:8.2f} "
                  f"{r['rss_mb']:7.0f}", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
