"""Where the set-up CPU time goes: the topology build's stages, the input floors and the two summaries.

The set-up is what the CLI does before its first pass and after its last: ``build_topology`` (plus
the per-colour blocks), ``input_floors`` for the guarded methods, and the quality summary before and
after.  Each stage is timed with ``time.process_time`` (CPU time: usable on a loaded machine) by
wrapping the build's helper functions; medians over ``--repeat`` builds of one mesh in one process.
Nested stages are indented (``_HalfEdges`` etc. are part of ``_cell_topology``); ``rest of build``
is what no listed helper accounts for (the gathers in ``build_topology`` itself).  ``first`` is the
first repeat: it runs on fresh memory (page faults that later repeats reuse), as the CLI's one build.

Usage::

    PYTHONPATH=src python benchmarks/profile_setup.py --kind tri --size 1M --repeat 5
    PYTHONPATH=src python benchmarks/profile_setup.py --kind quad --size 1M

It prints; nothing is asserted.  The mesh is ``anglesmooth.generate.random_delaunay`` /
``random_quad_mesh`` (seed 0), as in ``bench_speed.py``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

BUILD = ["_cell_topology", "_rings", "_colour", "_rows", "_edge_spokes", "_with_diagonals", "_incidence"]
CELLS = ["_HalfEdges", "_orient", "_pairing", "_region_interfaces"]


def _size(text: str) -> int:
    text = text.strip().lower()
    mult = {"k": 1_000, "m": 1_000_000}.get(text[-1:], 1)
    return int(float(text.rstrip("km")) * mult)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", choices=("tri", "quad"), default="tri")
    ap.add_argument("--size", default="1M", help="cells, e.g. 200k or 1M")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)

    from anglesmooth import generate
    from anglesmooth.quality import summarize
    from anglesmooth.smoothers._floors import input_floors
    from anglesmooth.topology import build as B
    from anglesmooth.topology import cells as C

    n = _size(args.size)
    mesh = generate.random_delaunay(n, 0) if args.kind == "tri" else generate.random_quad_mesh(n, 0)
    times: dict[str, list[float]] = {}

    def wrap(mod, name):
        fn = getattr(mod, name, None)
        if fn is None:
            return

        def timed(*a, **k):
            c0 = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                times.setdefault(name, [0.0] * (rep + 1))
                times[name].extend([0.0] * (rep + 1 - len(times[name])))
                times[name][rep] += time.process_time() - c0

        setattr(mod, name, timed)

    for name in BUILD:
        wrap(B, name)
    for name in CELLS:
        wrap(C, name)
    totals: dict[str, list[float]] = {}
    for rep in range(args.repeat):
        c0 = time.process_time()
        topo = B.build_topology(mesh)
        c1 = time.process_time()
        topo.blocks()
        c2 = time.process_time()
        input_floors(np.array(mesh.points), topo)
        c3 = time.process_time()
        summarize(mesh.points, topo)
        c4 = time.process_time()
        summarize(mesh.points, topo)
        c5 = time.process_time()
        for key, v in (("build_topology", c1 - c0), ("blocks", c2 - c1), ("input_floors", c3 - c2),
                       ("summary (before)", c4 - c3), ("summary (after)", c5 - c4), ("set-up total", c5 - c0)):
            totals.setdefault(key, []).append(v)
        del topo

    def med(v):
        return statistics.median(v + [0.0] * (args.repeat - len(v)))

    listed = sum(med(times.get(k, [])) for k in BUILD)
    print(f"{args.kind} {n} cells, {mesh.n_points} nodes; CPU s, median of {args.repeat} (min-max)")
    for key in ["build_topology", *BUILD, "rest of build", "blocks", "input_floors", "summary (before)",
                "summary (after)", "set-up total"]:
        if key == "rest of build":
            print(f"  {key:22s} {med(totals['build_topology']) - listed:7.3f}")
            continue
        v = totals.get(key) or times.get(key)
        if v is None or not any(v):
            continue
        indent = "  " if key in BUILD else ""
        # the first build runs on fresh memory (page faults the later ones reuse): the CLI's case
        print(f"{indent}{key:24s} {med(v):7.3f}  ({min(v):.3f}-{max(v):.3f}, first {v[0]:.3f})")
        if key == "_cell_topology":
            for sub in CELLS:
                if any(times.get(sub, [])):
                    print(f"      {sub:20s} {med(times[sub]):7.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
