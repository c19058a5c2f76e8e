"""MSH 4.1 writing: anglesmooth's own writer against meshio's, and the cost of the output check.

    python benchmarks/bench_msh41.py [N_TRIANGLES] [--repeat R]

A random Delaunay mesh of N triangles (default 1M) is written once as MSH 4.1
(ASCII and binary) and read back, so that it carries gmsh entities and node
tags like a gmsh file; then, R times each, the same meshio mesh is written by
``anglesmooth.gmshfile.write`` and by ``meshio.gmsh.write(fmt_version="4.1")``
(meshio can write this mesh: one entity per cell block), and
``anglesmooth.io.check_output`` (the dry run before smoothing) is timed.
Medians in seconds; file sizes in bytes.  Scratch files go to a temporary
directory.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import meshio

from anglesmooth import generate, gmshfile
from anglesmooth import io as asio
from anglesmooth.meshconv import out_mesh


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("n", type=int, nargs="?", default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    m = generate.random_delaunay(args.n, seed=1)
    print("| encoding | nodes | triangles | anglesmooth write (s) | meshio write (s) | check_output (s) | size ours / meshio |")
    print("|---|---:|---:|---:|---:|---:|---|")
    with tempfile.TemporaryDirectory() as d:
        for binary in (True, False):
            src_path = os.path.join(d, "src.msh")
            asio.write(m, src_path, file_format="gmsh41", binary=binary)
            src = asio.read(src_path)
            times: dict[str, list[float]] = {"ours": [], "meshio": [], "check": []}
            for _ in range(args.repeat):
                out = out_mesh(src, src.source, src.points, "gmsh41")
                gmshfile.gmsh_tags(out)
                gmshfile.gmsh_data(out, ascii_=not binary)
                t = time.perf_counter()
                gmshfile.write(os.path.join(d, "ours.msh"), out, binary=binary,
                               entities=src.source.gmsh_entities, node_tags=src.source.node_tags)
                times["ours"].append(time.perf_counter() - t)
                t = time.perf_counter()
                meshio.gmsh.write(os.path.join(d, "meshio.msh"), out, fmt_version="4.1", binary=binary)
                times["meshio"].append(time.perf_counter() - t)
                t = time.perf_counter()
                asio.check_output(src, os.path.join(d, "checked.msh"))
                times["check"].append(time.perf_counter() - t)
            med = {k: statistics.median(v) for k, v in times.items()}
            sizes = f"{os.path.getsize(os.path.join(d, 'ours.msh'))} / {os.path.getsize(os.path.join(d, 'meshio.msh'))}"
            print(f"| {'binary' if binary else 'ASCII'} | {src.n_points} | {src.n_cells} | {med['ours']:.3f} | "
                  f"{med['meshio']:.3f} | {med['check']:.3f} | {sizes} |")


if __name__ == "__main__":
    main()
