"""Regenerate the sample meshes of this directory with gmsh (and meshio for the VTU).

    python sample_meshes/make_samples.py            # writes next to this script
    python sample_meshes/make_samples.py --out DIR

Deterministic: gmsh runs single-threaded with fixed options, and the node
jitter that makes each mesh worth smoothing uses ``numpy.random.default_rng``
with a fixed seed.  A jittered node is moved only when every cell around it
stays valid (triangles: no angle below 1°; quads: convex, no angle above 170°),
so every file is a valid mesh with some bad angles.  Prints a table of node
count, 2D cell count and minimum angle per file (the numbers in README.md).

Needs gmsh (``pip install gmsh``), meshio and numpy.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import gmsh
import meshio
import numpy as np

HERE = Path(__file__).resolve().parent


# --------------------------------------------------------------------------
# geometry helpers (numpy only; anglesmooth.quality is deliberately not used)
# --------------------------------------------------------------------------
def corner_angles(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Corner angles (degrees) of polygons ``cells`` (m, k), orientation taken from each cell's signed area."""
    p = points[cells][..., :2]
    x, y = p[..., 0], p[..., 1]
    area = 0.5 * (x * np.roll(y, -1, 1) - np.roll(x, -1, 1) * y).sum(1)
    u = np.roll(p, 1, axis=1) - p
    v = np.roll(p, -1, axis=1) - p
    cross = (v[..., 0] * u[..., 1] - v[..., 1] * u[..., 0]) * np.sign(area)[:, None]
    return np.degrees(np.mod(np.arctan2(cross, (u * v).sum(-1)), 2 * np.pi))


def signed_area(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    p = points[cells][..., :2]
    x, y = p[..., 0], p[..., 1]
    return 0.5 * (x * np.roll(y, -1, 1) - np.roll(x, -1, 1) * y).sum(1)


def cells_ok(points: np.ndarray, cells: np.ndarray, sign: np.ndarray) -> np.ndarray:
    """Per cell: valid (same orientation ``sign`` as gmsh wrote it; triangle angles >= 1°; quad convex, angles in [5°, 170°])."""
    ang = corner_angles(points, cells)
    same = signed_area(points, cells) * sign > 0
    if cells.shape[1] == 3:
        return same & (ang.min(1) >= 1.0)
    return same & (ang.min(1) >= 5.0) & (ang.max(1) <= 170.0)


def jitter(points, cell_blocks, movable, amplitude, rng, rounds=6):
    """Move ``movable`` nodes by up to ``amplitude`` x their shortest incident edge, keeping every cell valid."""
    pts = points.copy()
    n = pts.shape[0]
    h = np.full(n, np.inf)
    for c in cell_blocks:
        a, b = c.ravel(), np.roll(c, -1, 1).ravel()
        e = np.linalg.norm(pts[a] - pts[b], axis=1)
        np.minimum.at(h, a, e)
        np.minimum.at(h, b, e)
    delta = rng.uniform(-1.0, 1.0, size=(n, 2)) * (amplitude * np.where(np.isfinite(h), h, 0.0))[:, None]
    delta[~movable] = 0.0
    sign0 = [np.sign(signed_area(pts, c)) for c in cell_blocks]
    ok0 = [cells_ok(pts, c, s) for c, s in zip(cell_blocks, sign0)]
    for c, ok in zip(cell_blocks, ok0):  # cells gmsh already made worse than the limits: leave them alone
        delta[c[~ok].ravel()] = 0.0
    for k in range(rounds + 1):
        trial = pts.copy()
        trial[:, :2] += delta
        bad = np.zeros(n, bool)
        for c, ok, s in zip(cell_blocks, ok0, sign0):
            bad[c[ok & ~cells_ok(trial, c, s)].ravel()] = True
        if not bad.any():
            return trial
        # halve the moves around invalid cells; cancel them in the last round
        delta[bad] *= 0.5 if k < rounds - 1 else 0.0
    raise RuntimeError("jitter did not converge")  # unreachable: all bad moves are cancelled


# --------------------------------------------------------------------------
# gmsh helpers
# --------------------------------------------------------------------------
def _start():
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)
    gmsh.option.setNumber("Mesh.Optimize", 0)
    gmsh.option.setNumber("Mesh.Smoothing", 0)


def _mesh_arrays():
    """All nodes (tag-indexed array) and the 2D element blocks of the current gmsh model."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    pts = np.zeros((int(tags.max()) + 1, 3))
    pts[tags.astype(np.int64)] = coords.reshape(-1, 3)
    blocks = []
    for etype in gmsh.model.mesh.getElementTypes(dim=2):
        _, enodes = gmsh.model.mesh.getElementsByType(etype)
        k = {2: 3, 3: 4}[int(etype)]
        blocks.append(enodes.astype(np.int64).reshape(-1, k))
    return pts, blocks


def _surface_interior_nodes():
    out = []
    for _, s in gmsh.model.getEntities(2):
        tags, _, _ = gmsh.model.mesh.getNodes(2, s, includeBoundary=False)
        out.append(tags.astype(np.int64))
    return np.concatenate(out)


def _jitter_model(amplitude, seed):
    pts, blocks = _mesh_arrays()
    movable = np.zeros(pts.shape[0], bool)
    inner = _surface_interior_nodes()
    movable[inner] = True
    new = jitter(pts, blocks, movable, amplitude, np.random.default_rng(seed))
    for t in np.flatnonzero((new != pts).any(axis=1)):
        gmsh.model.mesh.setNode(int(t), new[t].tolist(), [])


def _stats():
    pts, blocks = _mesh_arrays()
    used = np.unique(np.concatenate([b.ravel() for b in blocks]))
    tags, _, _ = gmsh.model.mesh.getNodes()
    angles = np.concatenate([corner_angles(pts, b).ravel() for b in blocks])
    kinds = {3: "tri", 4: "quad"}
    return {
        "nodes": int(tags.shape[0]),
        "cells": {kinds[b.shape[1]]: int(b.shape[0]) for b in blocks},
        "min_angle": float(angles.min()),
        "max_angle": float(angles.max()),
        "used": int(used.shape[0]),
    }


# --------------------------------------------------------------------------
# the samples
# --------------------------------------------------------------------------
def _finish(path: Path, *, jitter: float, seed: int, msh_version: float):
    """Jitter the interior nodes, write the model as ASCII MSH of the given version, return its statistics."""
    _jitter_model(jitter, seed=seed)
    gmsh.option.setNumber("Mesh.MshFileVersion", msh_version)
    gmsh.option.setNumber("Mesh.Binary", 0)
    st = _stats()
    gmsh.write(str(path))
    gmsh.finalize()
    return st


def plate_with_hole_tri(out: Path):
    """(a) MSH 2.2 ASCII, triangles: a 10 x 5 plate with an off-centre hole, strongly graded, jittered."""
    _start()
    gmsh.model.add("plate_with_hole")
    occ = gmsh.model.occ
    rect = occ.addRectangle(0, 0, 0, 10, 5)
    hole = occ.addDisk(3.5, 2.5, 0, 1.0, 1.0)
    occ.cut([(2, rect)], [(2, hole)])
    occ.synchronize()
    curves = [c for _, c in gmsh.model.getEntities(1)]
    circle = [c for c in curves if gmsh.model.getType(1, c) in ("Circle", "Ellipse")]
    left, right, other = [], [], []
    for c in curves:
        if c in circle:
            continue
        x0, _, _, x1, _, _ = gmsh.model.getBoundingBox(1, c)
        (left if x1 < 1e-6 else right if x0 > 10 - 1e-6 else other).append(c)
    surf = gmsh.model.getEntities(2)[0][1]
    gmsh.model.addPhysicalGroup(2, [surf], 1, "plate")
    gmsh.model.addPhysicalGroup(1, circle, 2, "hole")
    gmsh.model.addPhysicalGroup(1, left, 3, "clamped")
    gmsh.model.addPhysicalGroup(1, right, 4, "load")
    gmsh.model.addPhysicalGroup(1, other, 5, "free_edges")
    f = gmsh.model.mesh.field
    d = f.add("Distance")
    f.setNumbers(d, "CurvesList", circle)
    f.setNumber(d, "Sampling", 100)
    th = f.add("Threshold")
    f.setNumber(th, "InField", d)
    f.setNumber(th, "SizeMin", 0.06)
    f.setNumber(th, "SizeMax", 0.5)
    f.setNumber(th, "DistMin", 0.05)
    f.setNumber(th, "DistMax", 2.5)
    f.setAsBackgroundMesh(th)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.Algorithm", 5)  # Delaunay
    gmsh.model.mesh.generate(2)
    return _finish(out / "plate_with_hole_tri.msh", jitter=0.35, seed=1, msh_version=2.2)


def bracket_quads(out: Path):
    """(b) MSH 4.1, all quads: an L-shaped bracket with a bolt hole and a fillet, recombined, jittered."""
    _start()
    gmsh.model.add("bracket")
    occ = gmsh.model.occ
    a = occ.addRectangle(0, 0, 0, 8, 2)
    b = occ.addRectangle(0, 0, 0, 2, 6)
    occ.fuse([(2, a)], [(2, b)])
    occ.synchronize()
    hole1 = occ.addDisk(6.5, 1.0, 0, 0.45, 0.45)
    hole2 = occ.addDisk(1.0, 4.8, 0, 0.45, 0.45)
    surf = occ.getEntities(2)
    occ.cut(surf, [(2, hole1), (2, hole2)])
    occ.synchronize()
    s = gmsh.model.getEntities(2)[0][1]
    gmsh.model.addPhysicalGroup(2, [s], 1, "bracket")
    curves = [c for _, c in gmsh.model.getEntities(1)]
    holes = [c for c in curves if gmsh.model.getType(1, c) in ("Circle", "Ellipse")]
    gmsh.model.addPhysicalGroup(1, holes, 2, "bolt_holes")
    gmsh.model.addPhysicalGroup(1, [c for c in curves if c not in holes], 3, "outline")
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.08)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.2)
    gmsh.option.setNumber("Mesh.Algorithm", 8)  # Frontal-Delaunay for quads
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)  # blossom full-quad
    gmsh.model.mesh.generate(2)
    return _finish(out / "bracket_quads.msh", jitter=0.3, seed=2, msh_version=4.1)


def two_regions_mixed(out: Path):
    """(c) MSH 4.1, tri-quad mixed: two surfaces sharing an interface curve, left recombined to quads."""
    _start()
    gmsh.model.add("two_regions")
    occ = gmsh.model.occ
    left = occ.addRectangle(0, 0, 0, 3, 2)
    right = occ.addRectangle(3, 0, 0, 3, 2)
    occ.fragment([(2, left)], [(2, right)])
    occ.synchronize()
    surfs = [s for _, s in gmsh.model.getEntities(2)]
    xs = {s: gmsh.model.getBoundingBox(2, s)[0] for s in surfs}
    sl = min(surfs, key=xs.get)
    sr = max(surfs, key=xs.get)
    gmsh.model.addPhysicalGroup(2, [sl], 1, "quad_region")
    gmsh.model.addPhysicalGroup(2, [sr], 2, "tri_region")
    groups = {"inlet": [], "outlet": [], "interface": [], "walls": []}
    for _, c in gmsh.model.getEntities(1):
        x0, _, _, x1, _, _ = gmsh.model.getBoundingBox(1, c)
        if x1 < 1e-6:
            groups["inlet"].append(c)
        elif x0 > 6 - 1e-6:
            groups["outlet"].append(c)
        elif abs(x0 - 3) < 1e-6 and abs(x1 - 3) < 1e-6:
            groups["interface"].append(c)
        else:
            groups["walls"].append(c)
    for k, (name, cs) in enumerate(groups.items(), start=3):
        gmsh.model.addPhysicalGroup(1, cs, k, name)
    # size grows towards the top right, finest at the bottom left corner
    f = gmsh.model.mesh.field
    m = f.add("MathEval")
    f.setString(m, "F", "0.03 + 0.035 * (x + 1.5 * y)")
    f.setAsBackgroundMesh(m)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.Algorithm", 8)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)  # blossom (may leave a few triangles)
    gmsh.model.mesh.setRecombine(2, sl)
    gmsh.model.mesh.generate(2)
    return _finish(out / "two_regions_mixed.msh", jitter=0.3, seed=3, msh_version=4.1)


def channel_tri(out: Path):
    """(d) VTU triangles: a channel with a cylinder and a bump, meshed by gmsh, written by meshio."""
    _start()
    gmsh.model.add("channel")
    occ = gmsh.model.occ
    rect = occ.addRectangle(0, 0, 0, 12, 3)
    cyl = occ.addDisk(3, 1.6, 0, 0.5, 0.5)
    bump = occ.addDisk(8, -0.6, 0, 1.2, 1.2)
    occ.cut([(2, rect)], [(2, cyl), (2, bump)])
    occ.synchronize()
    s = gmsh.model.getEntities(2)[0][1]
    gmsh.model.addPhysicalGroup(2, [s], 1, "fluid")
    inlet, outlet, walls, obstacle = [], [], [], []
    for _, c in gmsh.model.getEntities(1):
        x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, c)
        if x1 < 1e-6:
            inlet.append(c)
        elif x0 > 12 - 1e-6:
            outlet.append(c)
        elif gmsh.model.getType(1, c) in ("Circle", "Ellipse") and y1 > 1.0 and y0 > 0.5:
            obstacle.append(c)
        else:
            walls.append(c)
    gmsh.model.addPhysicalGroup(1, inlet, 2, "inlet")
    gmsh.model.addPhysicalGroup(1, outlet, 3, "outlet")
    gmsh.model.addPhysicalGroup(1, walls, 4, "walls")
    gmsh.model.addPhysicalGroup(1, obstacle, 5, "cylinder")
    f = gmsh.model.mesh.field
    d = f.add("Distance")
    f.setNumbers(d, "CurvesList", obstacle)
    th = f.add("Threshold")
    f.setNumber(th, "InField", d)
    f.setNumber(th, "SizeMin", 0.06)
    f.setNumber(th, "SizeMax", 0.35)
    f.setNumber(th, "DistMin", 0.0)
    f.setNumber(th, "DistMax", 2.0)
    f.setAsBackgroundMesh(th)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.Algorithm", 1)  # MeshAdapt
    gmsh.model.mesh.generate(2)
    _jitter_model(0.5, seed=4)
    st = _stats()
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    with tempfile.TemporaryDirectory() as tmp:
        msh = os.path.join(tmp, "channel.msh")
        gmsh.write(msh)
        gmsh.finalize()
        m = meshio.read(msh)
    keep = [i for i, c in enumerate(m.cells) if c.type in ("line", "triangle")]
    cells = [m.cells[i] for i in keep]
    cell_data = {"gmsh:physical": [m.cell_data["gmsh:physical"][i] for i in keep]}
    used = np.unique(np.concatenate([c.data.ravel() for c in cells]))
    remap = np.full(m.points.shape[0], -1)
    remap[used] = np.arange(used.shape[0])
    cells = [meshio.CellBlock(c.type, remap[c.data]) for c in cells]
    meshio.write(
        str(out / "channel_tri.vtu"),
        meshio.Mesh(m.points[used], cells, cell_data=cell_data),
    )
    return st


SAMPLES = {
    "plate_with_hole_tri.msh": ("MSH 2.2 ASCII", plate_with_hole_tri),
    "bracket_quads.msh": ("MSH 4.1 ASCII", bracket_quads),
    "two_regions_mixed.msh": ("MSH 4.1 ASCII", two_regions_mixed),
    "channel_tri.vtu": ("VTU (zlib)", channel_tri),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=HERE)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"{'file':26} {'format':14} {'nodes':>6} {'cells':>16} {'min angle':>10} {'max angle':>10} {'KB':>6}")
    for name, (fmt, make) in SAMPLES.items():
        st = make(args.out)
        cells = " + ".join(f"{v} {k}" for k, v in st["cells"].items())
        kb = (args.out / name).stat().st_size / 1024
        print(f"{name:26} {fmt:14} {st['nodes']:6d} {cells:>16} {st['min_angle']:9.2f}° {st['max_angle']:9.2f}° {kb:6.0f}")


if __name__ == "__main__":
    main()
