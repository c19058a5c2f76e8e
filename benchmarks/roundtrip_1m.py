"""A mesh of about a million cells read and written without loss (issue: large sizes).

Builds a seeded mixed mesh of ~1M cells (random Delaunay triangles with part of
them merged into quads, a line block on the boundary, a region tag per cell, a
point data array and a named cell group), writes it with meshio to each format
below, then for each file:

1. ``anglesmooth.io.read`` + ``anglesmooth.io.write`` with the coordinates
   unchanged, to the same format, and checks that points, cell blocks (types,
   order, connectivity), the region tags, the point data and the group survive
   exactly;
2. the command line ``anglesmooth IN OUT --passes 0`` (read, topology, quality
   report, write) and the same checks on its output.

Prints the time of every step.  Not part of the test suite (it takes a minute or
two and about 3 GB of memory).

Usage::

    python benchmarks/roundtrip_1m.py                    # ~1M cells, msh41 binary, msh22 binary, vtu
    python benchmarks/roundtrip_1m.py --cells 100000 --formats vtu
"""

from __future__ import annotations

import argparse
import contextlib
import io as _stdio
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import meshio
import numpy as np

from anglesmooth import io as asio
from anglesmooth.generate import pair_triangles, random_delaunay

FORMATS = {"msh41-binary": ("msh", "gmsh41", True), "msh22-binary": ("msh", "gmsh22", True), "vtu": ("vtu", None, None),
           "msh41-ascii": ("msh", "gmsh41", False), "xdmf": ("xdmf", None, None)}


def build(n_cells: int) -> meshio.Mesh:
    n_tri = int(round(n_cells / 0.9))
    base = random_delaunay(n_tri, seed=11)
    # merge one triangle pair in ten into a quad: n_tri - n_tri / 10 = n_cells 2D cells
    tri, quad = pair_triangles(base.points, base.triangles, max_angle=150.0, max_pairs=n_tri // 10)
    pts = np.column_stack([base.points, np.zeros(base.n_points)])
    bnd = np.flatnonzero((base.points[:, 1] == 0.0))
    bnd = bnd[np.argsort(base.points[bnd, 0])]
    lines = np.column_stack([bnd[:-1], bnd[1:]])
    cells = [("line", lines), ("triangle", tri), ("quad", quad)]
    centre = lambda c: pts[c].mean(axis=1)  # noqa: E731
    phys = [np.full(len(lines), 3, np.int32), 1 + (centre(tri)[:, 0] > 0.5).astype(np.int32),
            1 + (centre(quad)[:, 0] > 0.5).astype(np.int32)]
    group = [np.zeros(len(lines), np.int32), (centre(tri)[:, 1] < 0.25).astype(np.int32),
             (centre(quad)[:, 1] < 0.25).astype(np.int32)]
    return meshio.Mesh(pts, cells, point_data={"temperature": np.hypot(*base.points.T)},
                       cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys, "set:low": group})


def mread(path: Path) -> meshio.Mesh:
    with contextlib.redirect_stdout(_stdio.StringIO()):  # meshio prints blank lines
        return meshio.read(path)


def compare(ref: meshio.Mesh, got: meshio.Mesh, label: str) -> None:
    assert np.array_equal(ref.points[:, :2], got.points[:, :2]), f"{label}: points differ"
    assert [c.type for c in ref.cells] == [c.type for c in got.cells], f"{label}: cell block types differ"
    for a, b in zip(ref.cells, got.cells):
        assert np.array_equal(a.data, b.data), f"{label}: {a.type} connectivity differs"
    for key in ("gmsh:physical",):
        for a, b in zip(ref.cell_data[key], got.cell_data[key]):
            assert np.array_equal(np.asarray(a).ravel(), np.asarray(b).ravel()), f"{label}: {key} differs"
    assert np.array_equal(np.asarray(ref.point_data["temperature"]).ravel(),
                          np.asarray(got.point_data["temperature"]).ravel()), f"{label}: point data differs"


def groups_equal(a_path: Path, b_path: Path, label: str) -> None:
    a, b = asio.read(a_path), asio.read(b_path)
    assert set(a.groups) == set(b.groups), f"{label}: groups {sorted(a.groups)} vs {sorted(b.groups)}"
    for k in a.groups:
        assert np.array_equal(a.groups[k], b.groups[k]), f"{label}: group {k} differs"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=1_000_000)
    ap.add_argument("--formats", default="msh41-binary,msh22-binary,vtu")
    args = ap.parse_args()
    t0 = time.perf_counter()
    ref = build(args.cells)
    ncells = sum(len(c.data) for c in ref.cells if c.type != "line")
    print(f"built {len(ref.points)} nodes, {ncells} 2D cells "
          f"({len(ref.cells[1].data)} triangles, {len(ref.cells[2].data)} quads) in {time.perf_counter() - t0:.1f} s")
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for name in args.formats.split(","):
            ext, fmt, binary = FORMATS[name]
            src, out, cli_out = d / f"in-{name}.{ext}", d / f"out-{name}.{ext}", d / f"cli-{name}.{ext}"
            t = time.perf_counter()
            if ext == "msh":
                # write the reference through io.write from a meshio source so that gmsh entities are generated
                tmp_vtu = d / "ref.vtu"
                meshio.write(tmp_vtu, ref)
                asio.write(asio.read(tmp_vtu), src, file_format=fmt, binary=binary)
                tmp_vtu.unlink()
            elif ext == "xdmf":
                meshio.xdmf.write(src, ref, data_format="XML")
            else:
                meshio.write(src, ref)
            t_ref = time.perf_counter() - t
            t = time.perf_counter()
            m = asio.read(src)
            t_read = time.perf_counter() - t
            t = time.perf_counter()
            asio.write(m, out)
            t_write = time.perf_counter() - t
            src_mesh = mread(src)
            compare(src_mesh, mread(out), f"{name} io")
            groups_equal(src, out, f"{name} io")
            t = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "anglesmooth", str(src), str(cli_out), "--passes", "0", "-q"],
                                  capture_output=True, text=True)
            t_cli = time.perf_counter() - t
            assert proc.returncode == 0, proc.stderr
            compare(src_mesh, mread(cli_out), f"{name} cli")
            print(f"{name:13s} file {src.stat().st_size / 1e6:7.1f} MB  reference write {t_ref:5.1f} s  "
                  f"io.read {t_read:5.1f} s  io.write {t_write:5.1f} s  CLI --passes 0 {t_cli:5.1f} s  lossless: yes")
            for p in (src, out, cli_out):
                p.unlink()
    print(f"total {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
