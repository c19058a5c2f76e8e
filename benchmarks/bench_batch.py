"""Batch benchmark: files per second for many meshes, four ways.

Generates seeded random Delaunay meshes (``.vtu``) into a temporary directory
(never committed) and smooths all of them (10 default ``angle`` passes) with

(a) a shell loop over the single-file command, one process per file
    (``for f in in/*.vtu; do python -m anglesmooth "$f" "out/${f##*/}" -q; done``);
(b) one run over the directory with ``--jobs 1`` (one process, one file after another);
(c) one run with ``--jobs N`` (N = the cores this process may use, or ``--jobs``);
(d) one run with ``--scheduler`` on a ``dask.distributed.LocalCluster`` of N worker
    processes with one thread each, started beforehand (its start-up is reported
    apart, not counted).

Every way must write the same files bit for bit (sha256 compared; a mismatch is
reported and the exit status is 1).  Two sets: 200 meshes of ~20k cells and 12 of
~60k cells; ``--small`` makes them 40 and 6, ``--tiny`` 3 meshes of ~300 cells and
2 of ~600 (seconds; what the test runs).  Times are wall times of one run each
(``--repeat R``: the median of R).

Usage::

    PYTHONPATH=src python benchmarks/bench_batch.py              # the full sets
    PYTHONPATH=src python benchmarks/bench_batch.py --small --json out.json
    PYTHONPATH=src python benchmarks/bench_batch.py --tiny

No number is asserted anywhere: the benchmark prints, it does not judge.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = str(ROOT / "src")


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")]))


def _make(d: Path, count: int, cells: int, seed0: int) -> None:
    from anglesmooth.generate import random_delaunay
    from anglesmooth.io import write

    d.mkdir(parents=True)
    for i in range(count):
        write(random_delaunay(cells, seed=seed0 + i), d / f"m{i:03d}.vtu")


def _tree(d: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.iterdir())}


def _timed(argv: list[str], out: Path, shell: bool = False) -> float:
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    t0 = time.perf_counter()
    res = subprocess.run(argv, env=_env(), capture_output=True, text=True, shell=shell)
    elapsed = time.perf_counter() - t0
    if res.returncode != 0:
        raise RuntimeError(f"{argv if not shell else argv[:200]} exited {res.returncode}: {res.stderr[-2000:]}")
    return elapsed


def _ways(indir: Path, work: Path, jobs: int, scheduler: str | None) -> dict:
    py = sys.executable
    cli = [py, "-m", "anglesmooth"]
    loop = (f'for f in "{indir}"/*.vtu; do "{py}" -m anglesmooth "$f" "{work}/a/${{f##*/}}" -q || exit 1; done')
    ways = {
        "(a) shell loop, one process per file": (loop, work / "a", True),
        "(b) --jobs 1": ([*cli, str(indir), "--output-dir", str(work / "b"), "--jobs", "1", "-q"], work / "b", False),
        f"(c) --jobs {jobs}": ([*cli, str(indir), "--output-dir", str(work / "c"), "--jobs", str(jobs), "-q"],
                               work / "c", False),
    }
    if scheduler:
        ways[f"(d) LocalCluster, {jobs} workers"] = (
            [*cli, str(indir), "--output-dir", str(work / "d"), "--scheduler", scheduler, "-q"], work / "d", False)
    return ways


def run_set(name: str, count: int, cells: int, tmp: Path, jobs: int, scheduler: str | None, repeat: int,
            seed0: int, letters: list[str]) -> list[dict]:
    indir = tmp / name / "in"
    _make(indir, count, cells, seed0)
    from anglesmooth import read

    real_cells = statistics.median(read(p).n_cells for p in sorted(indir.iterdir())[:3])
    rows, reference = [], None
    ways = _ways(indir, tmp / name, jobs, scheduler)
    for letter in letters:
        way = next((w for w in ways if w.startswith(f"({letter})")), None)
        if way is None:
            continue
        argv, out, shell = ways[way]
        times = [_timed(argv, out, shell) for _ in range(repeat)]
        wall = statistics.median(times)
        tree = _tree(out)
        reference = reference or tree
        rows.append({"set": name, "files": count, "cells": int(real_cells), "way": way, "wall_s": wall,
                     "files_per_s": count / wall, "identical": tree == reference and len(tree) == count})
        print(f"  {name}: {way}: {wall:.2f} s", file=sys.stderr, flush=True)
    base = next((r["wall_s"] for r in rows if r["way"] == "(b) --jobs 1"), None)
    for r in rows:
        r["x_jobs1"] = r["wall_s"] / base if base else None
    return sorted(rows, key=lambda r: r["way"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--small", action="store_true", help="40 and 6 meshes instead of 200 and 12")
    ap.add_argument("--tiny", action="store_true", help="a few tiny meshes (seconds; for the test)")
    ap.add_argument("--jobs", type=int, default=0, help="N for (c) and (d); 0: the cores this process may use")
    ap.add_argument("--no-dask", action="store_true", help="skip (d)")
    ap.add_argument("--sets", metavar="NAMES", help="comma-separated subset (and order) of the sets, e.g. 60k")
    ap.add_argument("--ways", metavar="LETTERS", default="a,b,c,d",
                    help="which ways to run, in this order (e.g. b,c,d,a: the slow shell loop last)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per way (median)")
    ap.add_argument("--json", metavar="PATH", help="also write the rows as JSON")
    args = ap.parse_args(argv)
    sys.path.insert(0, SRC)
    from anglesmooth.batch import cores

    jobs = args.jobs or cores()
    if args.tiny:
        sets = [("tiny", 3, 300), ("tiny-large", 2, 600)]
    elif args.small:
        sets = [("20k", 40, 20_000), ("60k", 6, 60_000)]
    else:
        sets = [("20k", 200, 20_000), ("60k", 12, 60_000)]
    if args.sets:
        by_name = {s[0]: s for s in sets}
        sets = [by_name[n] for n in args.sets.split(",")]
    cluster = client = None
    cluster_s = None
    if not args.no_dask:
        os.environ["PYTHONPATH"] = _env()["PYTHONPATH"]  # the workers import this checkout's src
        from distributed import Client, LocalCluster

        t0 = time.perf_counter()
        cluster = LocalCluster(n_workers=jobs, processes=True, threads_per_worker=1, dashboard_address=":0",
                               silence_logs=40)
        client = Client(cluster)
        cluster_s = time.perf_counter() - t0
    rows = []
    try:
        with tempfile.TemporaryDirectory(prefix="anglesmooth-bench-batch-") as tmp:
            for i, (name, count, cells) in enumerate(sets):
                rows += run_set(name, count, cells, Path(tmp), jobs, cluster.scheduler_address if cluster else None,
                                args.repeat, seed0=1000 * i, letters=args.ways.split(","))
    finally:
        if client is not None:
            client.close()
            cluster.close()
    print(f"{len(os.sched_getaffinity(0))} cores, N = {jobs}; 10 default angle passes per file; "
          f"wall time of {'the median of %d runs' % args.repeat if args.repeat > 1 else 'one run'} per way"
          + (f"; LocalCluster start-up {cluster_s:.1f} s (not counted)" if cluster_s is not None else ""))
    print()
    print("| meshes | way | wall (s) | files/s | × `--jobs 1` | same files |")
    print("|---|---|---:|---:|---:|---|")
    for r in rows:
        ratio = f"{r['x_jobs1']:.2f}" if r["x_jobs1"] is not None else "–"
        print(f"| {r['files']} × {r['cells']} cells | {r['way']} | {r['wall_s']:.2f} | {r['files_per_s']:.2f} | "
              f"{ratio} | {'yes' if r['identical'] else 'NO'} |")
    if args.json:
        Path(args.json).write_text(json.dumps({"jobs": jobs, "cluster_start_s": cluster_s, "rows": rows}, indent=2))
    return 0 if all(r["identical"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
