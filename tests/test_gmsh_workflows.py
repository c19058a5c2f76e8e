"""Real gmsh workflows (issue 14): meshes that gmsh writes here, smoothed and written back.

Boundary-layer quads and partial recombination (one surface entity holding
triangles and quads) in MSH 4.1, meshes in the x-z plane and in a tilted plane,
unnamed physical groups, format names, the encoding of VTU / XDMF outputs, the
rule for existing outputs, gmsh node tags for ``--fix-nodes`` and the meshio API.
Every MSH 4.1 output is reopened by gmsh itself and compared with the input:
physical groups (with names and entities), entities, element counts per entity
and type, node count.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest
from cli_runner import cli_runner, snapshot
from gmsh_check import gmsh_view, same_for_gmsh
from meshes import gmsh_files, gmsh_two_squares

import anglesmooth
from anglesmooth import io as asio
from anglesmooth.cli import cli
from anglesmooth.errors import MeshWriteError, UnsupportedMeshError
from anglesmooth.formats import UnknownFormatError

gmsh = pytest.importorskip("gmsh")

SRC = Path(__file__).resolve().parents[1] / "src"


# ---------------------------------------------------------------------------
# models (built once per session with the gmsh API)
# ---------------------------------------------------------------------------


def _boundary_layer():
    """A plate with a hole; BoundaryLayer field with Quads = 1 around the hole: triangles + quads in one surface."""
    occ = gmsh.model.occ
    plate = occ.addRectangle(0, 0, 0, 2, 1)
    hole = occ.addDisk(0.6, 0.5, 0, 0.2, 0.2)
    (surf,), _ = occ.cut([(2, plate)], [(2, hole)])
    occ.synchronize()
    curves = [t for _, t in gmsh.model.getBoundary([surf], oriented=False)]
    circle = [t for t in curves if abs(gmsh.model.occ.getCenterOfMass(1, t)[0] - 0.6) < 1e-6]
    f = gmsh.model.mesh.field.add("BoundaryLayer")
    gmsh.model.mesh.field.setNumbers(f, "CurvesList", circle)
    gmsh.model.mesh.field.setNumber(f, "Size", 0.01)
    gmsh.model.mesh.field.setNumber(f, "Ratio", 1.3)
    gmsh.model.mesh.field.setNumber(f, "Thickness", 0.08)
    gmsh.model.mesh.field.setNumber(f, "Quads", 1)
    gmsh.model.mesh.field.setAsBoundaryLayer(f)
    gmsh.model.addPhysicalGroup(2, [surf[1]], 11)  # unnamed, as in old .geo files
    gmsh.model.addPhysicalGroup(1, circle, 12)  # unnamed
    gmsh.model.addPhysicalGroup(1, [c for c in curves if c not in circle], 13, name="outer")
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.1)


def _partial_recombination():
    """Recombination that leaves some triangles (simple algorithm on an unstructured mesh)."""
    occ = gmsh.model.occ
    plate = occ.addRectangle(0, 0, 0, 1, 1)
    hole = occ.addDisk(0.5, 0.5, 0, 0.2, 0.2)
    (surf,), _ = occ.cut([(2, plate)], [(2, hole)])
    occ.synchronize()
    gmsh.model.mesh.setRecombine(2, surf[1])
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.08)
    gmsh.model.addPhysicalGroup(2, [surf[1]], 1, name="plate")
    gmsh.model.addPhysicalGroup(1, [t for _, t in gmsh.model.getBoundary([surf], oriented=False)], 11)


def _unnamed_two_dims():
    """Two squares, physical numbers without names, number 7 used in dimensions 1 and 2."""
    left, right = gmsh_two_squares()
    mid = [t for _, t in gmsh.model.getEntities(1) if abs(gmsh.model.occ.getCenterOfMass(1, t)[0] - 1) < 1e-9]
    gmsh.model.addPhysicalGroup(2, left, 7)
    gmsh.model.addPhysicalGroup(2, right, 8)
    gmsh.model.addPhysicalGroup(1, mid, 7)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.2)


def _plane(rotation):
    def build():
        occ = gmsh.model.occ
        s = occ.addRectangle(0, 0, 0, 2, 1)
        d = occ.addDisk(0.7, 0.5, 0, 0.2, 0.2)
        (surf,), _ = occ.cut([(2, s)], [(2, d)])
        if rotation is not None:
            occ.rotate([surf], 0, 0, 0, *rotation)
        occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [surf[1]], 3, name="sheet")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.12)

    return build


def _periodic():
    """A square whose right side is periodic with its left side ($Periodic)."""
    occ = gmsh.model.occ
    occ.addRectangle(0, 0, 0, 1, 1)
    occ.synchronize()
    left = [t for _, t in gmsh.model.getEntities(1) if abs(occ.getCenterOfMass(1, t)[0]) < 1e-9]
    right = [t for _, t in gmsh.model.getEntities(1) if abs(occ.getCenterOfMass(1, t)[0] - 1) < 1e-9]
    gmsh.model.mesh.setPeriodic(1, right, left, [1, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.1)


def _save_all():
    """Two squares, only the right one in a physical group, saved with Mesh.SaveAll = 1."""
    _, right = gmsh_two_squares()
    gmsh.model.addPhysicalGroup(2, right, 5, name="right")
    gmsh.option.setNumber("Mesh.SaveAll", 1)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.2)


def _two_groups_one_surface():
    """One surface in two physical groups: MSH 2.2 writes every triangle twice (once per group)."""
    occ = gmsh.model.occ
    s = occ.addRectangle(0, 0, 0, 1, 1)
    occ.synchronize()
    gmsh.model.addPhysicalGroup(2, [s], 1, name="domain")
    gmsh.model.addPhysicalGroup(2, [s], 2, name="all")
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.15)


def _rotation(axis, angle) -> np.ndarray:
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


ROT, SHIFT = _rotation((1, 2, 3), 0.7), np.array([0.3, -1.0, 2.0])


def _moved_by_gmsh():
    """The flat model's mesh, rotated and shifted by gmsh after meshing: the same mesh node for node."""
    gmsh.model.mesh.affineTransform(np.column_stack([ROT, SHIFT]).ravel().tolist())


MODELS = {
    "bl": _boundary_layer,
    "partial": _partial_recombination,
    "unnamed": _unnamed_two_dims,
    "xy": _plane(None),
    "xz": _plane((1, 0, 0, math.pi / 2)),  # the x-z plane of axisymmetric r-z models
    "tilted": _plane((1, 2, 3, 0.7)),
    "moved": _plane(None),  # + _moved_by_gmsh after meshing
    "periodic": _periodic,
    "saveall": _save_all,
    "twogroups": _two_groups_one_surface,
}
VARIANTS = {"41a": (4.1, 0), "41b": (4.1, 1), "22a": (2.2, 0)}


@pytest.fixture(scope="session")
def msh(tmp_path_factory):
    return gmsh_files(tmp_path_factory.mktemp("gmsh_workflows"), MODELS, VARIANTS, {"moved": _moved_by_gmsh})


def run(*args):
    return cli_runner().invoke(cli, [str(a) for a in args])


def one_error(result) -> str:
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("anglesmooth: error: "), result.stderr
    return lines[0]


# ---------------------------------------------------------------------------
# 1. MSH 4.1 with triangles and quads in one entity
# ---------------------------------------------------------------------------


def test_models_hold_what_they_claim(msh):
    for name in ("bl", "partial"):
        m = meshio.read(msh[name, "41a"])
        two_d = [(c.type, int(g[0])) for c, g in zip(m.cells, m.cell_data["gmsh:geometrical"]) if c.dim == 2]
        assert {t for t, _ in two_d} == {"triangle", "quad"} and len({g for _, g in two_d}) == 1, two_d
    with pytest.raises(ValueError, match="non-unique CellBlock dim_tag"):  # why anglesmooth writes 4.1 itself
        meshio.gmsh.write(str(msh["bl", "41a"].with_suffix(".meshio.msh")), meshio.read(msh["bl", "41a"]),
                          fmt_version="4.1", binary=False)


@pytest.mark.parametrize("var", ["41a", "41b"])
@pytest.mark.parametrize("name", ["bl", "partial", "unnamed", "tilted"])
def test_smoothed_msh41_reopens_in_gmsh(msh, tmp_path, name, var):
    out = tmp_path / "out.msh"
    r = run(msh[name, var], out, "-q")
    assert r.exit_code == 0, r.stderr
    head = out.read_bytes()[:40]
    assert head.startswith(b"$MeshFormat\n4.1 " + (b"1" if var == "41b" else b"0"))
    same_for_gmsh(msh[name, var], out)
    src, got = gmsh_view(msh[name, var]), gmsh_view(out)
    moved = [t for t, x in got["xyz"].items() if x != src["xyz"][t]]
    assert moved, "nothing was smoothed"
    # node tags are kept: every boundary node (fixed) has its coordinates under the same tag
    m = anglesmooth.read(msh[name, var])
    fixed = anglesmooth.build_topology(m).fixed
    for tag in asio.node_tags(m)[fixed].tolist():
        assert got["xyz"][tag] == src["xyz"][tag]


@pytest.mark.parametrize("name", ["bl", "partial", "unnamed", "xz"])
@pytest.mark.parametrize("target,binary", [("gmsh41", False), ("gmsh41", True), ("gmsh22", False)])
def test_library_writes_every_version_gmsh_reopens(msh, tmp_path, name, target, binary):
    for var in ("41a", "22a"):
        m = anglesmooth.read(msh[name, var])
        out = tmp_path / f"{var}.msh"
        anglesmooth.write(m, out, file_format=target, binary=binary)
        same_for_gmsh(msh[name, var], out, entities=target == "gmsh41")
        back = anglesmooth.read(out)
        assert back.n_points == m.n_points and back.n_cells == m.n_cells
        assert np.array_equal(back.points, m.points)  # unsmoothed: bit-identical, node order kept


def _periodic_pairs(path) -> set:
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        out = set()
        for _, t in gmsh.model.getEntities(1):
            master, nodes, masters, affine = gmsh.model.mesh.getPeriodicNodes(1, t)
            out |= {(t, master, int(a), int(b), tuple(affine)) for a, b in zip(nodes, masters)}
        return out
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("var", ["41a", "41b"])
def test_msh41_keeps_periodic_links(msh, tmp_path, var):
    r = run(msh["periodic", var], tmp_path / "o.msh", "-q")
    assert r.exit_code == 0, r.stderr
    want = _periodic_pairs(msh["periodic", var])
    assert len(want) > 5 and _periodic_pairs(tmp_path / "o.msh") == want
    same_for_gmsh(msh["periodic", var], tmp_path / "o.msh")


def test_elements_outside_every_physical_group(msh, tmp_path):
    """meshio alone refuses such MSH 4.1 files ("Incompatible cell data"); the left square is region 0."""
    m = anglesmooth.read(msh["saveall", "41a"])
    assert set(m.physical) == {(2, 5)} and sorted(np.unique(m.triangle_region).tolist()) == [0, 5]
    r = run(msh["saveall", "41a"], tmp_path / "o.msh", "-q")
    assert r.exit_code == 0, r.stderr
    same_for_gmsh(msh["saveall", "41a"], tmp_path / "o.msh")
    topo = anglesmooth.build_topology(m)
    interface = np.intersect1d(m.triangles[m.triangle_region == 0], m.triangles[m.triangle_region == 5])
    assert interface.size > 3 and topo.fixed[interface].all()  # the region interface stays fixed


def test_msh22_element_in_two_groups_is_one_cell(msh, tmp_path):
    """Without this, every node looked non-manifold (each triangle twice) and nothing was smoothed."""
    raw = meshio.read(msh["twogroups", "22a"])
    assert sum(len(c) for c in raw.cells if c.type == "triangle") == 2 * anglesmooth.read(msh["twogroups", "41a"]).n_cells
    m = anglesmooth.read(msh["twogroups", "22a"])
    assert m.n_cells == anglesmooth.read(msh["twogroups", "41a"]).n_cells
    assert sorted(m.groups) == ["all", "domain"] and sorted(m.physical) == [(2, 1), (2, 2)]
    fixed = anglesmooth.build_topology(m).fixed
    assert (~fixed).sum() > 10
    r = run(msh["twogroups", "22a"], tmp_path / "o.msh", "-q")
    assert r.exit_code == 0, r.stderr
    same_for_gmsh(msh["twogroups", "22a"], tmp_path / "o.msh")
    assert not np.array_equal(meshio.read(tmp_path / "o.msh").points, raw.points)


def test_msh40_output_is_refused_before_smoothing(msh, tmp_path):
    r = run(msh["bl", "41a"], tmp_path / "o.msh", "--output-format", "msh40")
    assert r.exit_code == 3 and "MSH 4.0 output is not supported" in one_error(r) and "gmsh41" in one_error(r)
    assert os.listdir(tmp_path) == []


def test_msh41_from_per_element_regions(tmp_path):
    """Regions per cell and interleaved nodes (not a gmsh file): one entity per region, tags keep the nodes."""
    from anglesmooth.generate import random_delaunay

    base = random_delaunay(3000, seed=2)
    region = (np.arange(base.n_cells) * 7) % 30 + 1  # 30 regions, cells of every region everywhere
    src = meshio.Mesh(np.column_stack([base.points, np.zeros(base.n_points)]), [("triangle", base.triangles)],
                      point_data={"T": np.arange(base.n_points, dtype=float)}, cell_data={"gmsh:physical": [region]})
    out = tmp_path / "r.msh"
    anglesmooth.write(src, out, file_format="gmsh41")
    view = gmsh_view(out)
    assert [(d, t) for d, t, _, _ in view["groups"]] == [(2, r) for r in range(1, 31)]
    assert all(len(ents) == 1 for *_, ents in view["groups"])  # MSH 4: a physical group per entity
    per_entity = {t: c for (d, t, _), c in view["counts"].items() if d == 2}
    assert sorted(per_entity.values()) == sorted(np.bincount(region)[1:].tolist())
    assert view["nodes"] == base.n_points
    back = anglesmooth.read(out)
    tags = asio.node_tags(back)
    assert np.array_equal(back.points, base.points[tags - 1])  # node tag = 1 + the source's node index
    assert np.array_equal(back.source.mesh.point_data["T"], tags - 1.0)  # node data follows its node
    assert sorted(np.unique(back.triangle_region).tolist()) == list(range(1, 31))


def test_msh41_keeps_node_data_and_element_data(msh, tmp_path):
    m = anglesmooth.read(msh["bl", "41a"])
    src = m.source.mesh
    src.point_data["T"] = np.arange(m.n_points, dtype=float)
    src.cell_data["q"] = [np.arange(len(c), dtype=float) + 0.5 for c in src.cells]
    out = tmp_path / "d.msh"
    anglesmooth.write(m, out)
    got = meshio.read(out)
    assert np.array_equal(got.point_data["T"], np.arange(m.n_points, dtype=float))
    for a, b in zip(got.cell_data["q"], src.cell_data["q"]):
        assert np.array_equal(np.asarray(a).ravel(), b)


def test_output_format_checked_before_smoothing(msh, tmp_path, monkeypatch):
    from anglesmooth.cli import smooth as smooth_module

    calls = []
    monkeypatch.setattr(smooth_module, "run_smooth", lambda *a, **k: calls.append(1))
    out = tmp_path / "out.wkt"  # WKT holds triangles only
    r = run(msh["bl", "41a"], out, "--json", tmp_path / "r.json")
    assert r.exit_code == 3
    line = one_error(r)
    assert "the wkt format cannot hold this mesh" in line and str(out) in line
    assert calls == [] and os.listdir(tmp_path) == []
    with pytest.raises(MeshWriteError, match="cannot hold this mesh"):
        asio.check_output(anglesmooth.read(msh["bl", "41a"]), out)
    assert asio.check_output(anglesmooth.read(msh["bl", "41a"]), tmp_path / "x.msh") == "gmsh"


# ---------------------------------------------------------------------------
# 2. planes other than z = const
# ---------------------------------------------------------------------------


def _smooth_file(path, out, *args):
    r = run(path, out, "-q", "--method", "laplacian", "--passes", "3", *args)
    assert r.exit_code == 0, r.stderr
    return meshio.read(out)


@pytest.mark.parametrize("name", ["xz", "tilted"])
def test_plane_meshes_smooth_in_their_plane(msh, tmp_path, name):
    src = meshio.read(msh[name, "41a"])
    m = anglesmooth.read(msh[name, "41a"])
    assert m.frame is not None and m.points.shape == (m.n_points, 2)
    got = _smooth_file(msh[name, "41a"], tmp_path / "o.msh")
    fixed = anglesmooth.build_topology(m).fixed
    assert np.array_equal(got.points[fixed], src.points[fixed])  # bit-identical in x, y and z
    moved = (got.points != src.points).any(axis=1)
    assert moved.sum() > 0.5 * (~fixed).sum()
    normal = m.frame.normal
    dist = np.abs((got.points - src.points[fixed][0]) @ normal)
    assert dist.max() < 1e-12
    if name == "xz":  # an axis plane: y untouched for every node, x and z are the plane coordinates
        assert m.frame.columns == (0, 2)
        assert np.array_equal(got.points[:, 1], src.points[:, 1])


def test_tilted_result_equals_the_flat_one(msh, tmp_path):
    """Smoothing in the fitted plane is smoothing the flat mesh, up to the rotation (laplacian: exact maths)."""
    flat = _smooth_file(msh["xy", "41a"], tmp_path / "flat.msh")
    moved = _smooth_file(msh["moved", "41a"], tmp_path / "moved.msh")
    src_flat, src_moved = meshio.read(msh["xy", "41a"]), meshio.read(msh["moved", "41a"])
    assert np.abs(src_flat.points @ ROT.T + SHIFT - src_moved.points).max() < 1e-12  # gmsh moved every node
    assert anglesmooth.read(msh["moved", "41a"]).frame.columns is None  # a general plane
    assert np.abs(flat.points @ ROT.T + SHIFT - moved.points).max() < 1e-9
    assert (flat.points != src_flat.points).any(axis=1).sum() > 100


def test_z_const_is_unchanged_bit_for_bit(msh, tmp_path):
    m = anglesmooth.read(msh["xy", "41a"])
    assert m.frame.columns == (0, 1)
    pts = meshio.read(msh["xy", "41a"]).points
    assert np.array_equal(m.points, pts[:, :2])
    got = _smooth_file(msh["xy", "41a"], tmp_path / "o.msh")
    assert np.array_equal(got.points[:, 2], pts[:, 2])


def test_not_coplanar_is_refused_honestly(tmp_path):
    pts = np.array([[0, 0, 0], [1, 0, 1], [1, 1, 1], [0, 1, 0], [0.5, 0.5, 0.5 + 1e-3]])
    meshio.write(tmp_path / "bent.vtu", meshio.Mesh(pts, [("triangle", [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])]))
    with pytest.raises(UnsupportedMeshError, match=r"mesh is not planar: node 4 lies 0.000\d+ from the best-fit plane"):
        anglesmooth.read(tmp_path / "bent.vtu")
    pts[4, 2] = 0.5 + 1e-12  # rounding-level noise on a tilted plane: accepted
    meshio.write(tmp_path / "ok.vtu", meshio.Mesh(pts, [("triangle", [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])]))
    assert anglesmooth.read(tmp_path / "ok.vtu").frame.columns is None


# ---------------------------------------------------------------------------
# 3. unnamed physical groups
# ---------------------------------------------------------------------------


def _fixed_count(path, *args):
    r = run(path, "-", "--output-format", "vtu", "--json", os.devnull, "-q", *args)
    assert r.exit_code == 0, r.stderr
    return r


@pytest.mark.parametrize("var", ["41a", "22a"])
def test_fix_group_by_number(msh, tmp_path, var):
    m = anglesmooth.read(msh["unnamed", var])
    assert m.groups == {} and set(m.physical) == {(1, 7), (2, 7), (2, 8)}
    out = tmp_path / "o.vtu"
    r = run(msh["unnamed", var], out, "-q", "--fix-group", "8")
    assert r.exit_code == 0, r.stderr
    got = meshio.read(out).points
    src = meshio.read(msh["unnamed", var]).points
    right = m.physical[2, 8]
    assert np.array_equal(got[right], src[right])
    assert not np.array_equal(got, src)
    r = run(msh["unnamed", var], tmp_path / "p.vtu", "-q", "--fix-group", "2:7")
    assert r.exit_code == 0, r.stderr
    assert np.array_equal(meshio.read(tmp_path / "p.vtu").points[m.physical[2, 7]], src[m.physical[2, 7]])


def test_many_files_find_groups_by_number_as_one_file_does(msh, tmp_path):
    """--fix-group 1:7 / 8 in a many-file run (--output-dir) fixes what it fixes in a one-file run, bit for bit."""
    inputs = [msh["unnamed", "41a"], msh["unnamed", "22a"]]
    r = run(*inputs, "--output-dir", tmp_path / "many", "-q", "--fix-group", "1:7", "--output-format", "vtu")
    assert r.exit_code == 0, r.stderr
    m = anglesmooth.read(inputs[0])
    mid = m.physical[1, 7]
    for path in inputs:
        one = tmp_path / f"one_{path.stem}.vtu"
        assert run(path, one, "-q", "--fix-group", "1:7").exit_code == 0
        got = meshio.read(tmp_path / "many" / f"{path.stem}.vtu").points
        assert np.array_equal(got, meshio.read(one).points)
        assert np.array_equal(got[mid], meshio.read(path).points[mid])
    r = run(*inputs, "--output-dir", tmp_path / "bad", "--fix-group", "7")
    assert r.exit_code == 2
    lines = [line for line in r.stderr.splitlines() if "error" in line]
    assert len(lines) == 2 and all("write 1:7 or 2:7" in line for line in lines), r.stderr


def test_fix_group_errors_list_names_and_numbers(msh, tmp_path):
    r = run(msh["unnamed", "41a"], tmp_path / "o.vtu", "--fix-group", "7")
    assert r.exit_code == 2 and "write 1:7 or 2:7" in one_error(r)
    r = run(msh["bl", "41a"], tmp_path / "o.vtu", "--fix-group", "99")
    line = one_error(r)
    assert r.exit_code == 2
    assert "names: 'outer'; physical numbers (dim:number): 1:12, 1:13, 2:11" in line
    assert not (tmp_path / "o.vtu").exists()
    r = run(msh["bl", "41a"], tmp_path / "o.vtu", "-q", "--fix-group", "12", "--fix-group", "outer")
    assert r.exit_code == 0, r.stderr


# ---------------------------------------------------------------------------
# 4. format names
# ---------------------------------------------------------------------------


def test_output_format_aliases(msh, tmp_path):
    r = cli_runner().invoke(cli, [str(msh["bl", "41a"]), "-", "--output-format", "msh", "-q"])
    assert r.exit_code == 0, r.stderr
    (tmp_path / "o.msh").write_bytes(r.stdout_bytes)
    assert r.stdout_bytes.startswith(b"$MeshFormat\n4.1 0")  # the input's version and mode
    same_for_gmsh(msh["bl", "41a"], tmp_path / "o.msh")
    for alias, head in (("msh22", b"$MeshFormat\n2.2"), ("xmf", b"<Xdmf"), ("VTU", b"<?xml")):
        r = cli_runner().invoke(cli, [str(msh["bl", "41a"]), "-", "--output-format", alias, "-q"])
        assert r.exit_code == 0 and r.stdout_bytes.startswith(head), (alias, r.stderr)


def test_unknown_format_is_a_usage_error_listing_every_name(msh, tmp_path):
    for opt in ("--output-format", "--input-format"):
        r = run(msh["bl", "41a"], tmp_path / "o.vtu", opt, "nope")
        line = one_error(r)
        assert r.exit_code == 2 and f"{opt}: unknown format 'nope'" in line
        names = re.search(r"formats: (.*); aliases: (.*)$", line)
        listed = names.group(1).split(", ") + [a.split("=")[0] for a in names.group(2).split(", ")]
        for name in ("abaqus", "gmsh41", "vtu", "xdmf", "wkt", "msh", "xmf", "inp", "vol.gz", "xml"):
            assert name in listed
        assert os.listdir(tmp_path) == []
    with pytest.raises(UnknownFormatError):
        asio.output_format("x.vtu", "nope")


# ---------------------------------------------------------------------------
# 5. representation kept
# ---------------------------------------------------------------------------


def _vtu_encoding(path) -> set[str]:
    return set(re.findall(r'format="(\w+)"', Path(path).read_text(errors="replace")))


def test_vtu_encoding_kept_and_chosen(msh, tmp_path):
    m = anglesmooth.read(msh["bl", "41a"])
    asio.write(m, tmp_path / "ascii.vtu", binary=False)
    asio.write(m, tmp_path / "bin.vtu", binary=True)
    assert _vtu_encoding(tmp_path / "ascii.vtu") == {"ascii"} and _vtu_encoding(tmp_path / "bin.vtu") == {"binary"}
    for name, want in (("ascii", {"ascii"}), ("bin", {"binary"})):
        r = run(tmp_path / f"{name}.vtu", tmp_path / f"{name}_out.vtu", "-q")
        assert r.exit_code == 0, r.stderr
        assert _vtu_encoding(tmp_path / f"{name}_out.vtu") == want
    r = run(tmp_path / "ascii.vtu", tmp_path / "forced.vtu", "-q", "--binary")
    assert r.exit_code == 0 and _vtu_encoding(tmp_path / "forced.vtu") == {"binary"}
    r = run(tmp_path / "bin.vtu", tmp_path / "forced2.vtu", "-q", "--ascii")
    assert r.exit_code == 0 and _vtu_encoding(tmp_path / "forced2.vtu") == {"ascii"}
    r = run(msh["bl", "41a"], tmp_path / "o.msh", "-q", "--binary")
    assert r.exit_code == 0 and (tmp_path / "o.msh").read_bytes().startswith(b"$MeshFormat\n4.1 1")
    same_for_gmsh(msh["bl", "41a"], tmp_path / "o.msh")
    r = run(msh["bl", "41a"], tmp_path / "o.inp", "--ascii")
    assert r.exit_code == 3 and "format abaqus has no ASCII/binary choice" in one_error(r)


def test_vtk_encoding_kept(msh, tmp_path):
    m = anglesmooth.read(msh["partial", "41a"])
    for binary, word in ((False, b"ASCII"), (True, b"BINARY")):
        asio.write(m, tmp_path / "in.vtk", binary=binary)
        r = run(tmp_path / "in.vtk", tmp_path / "out.vtk", "-q")
        assert r.exit_code == 0, r.stderr
        assert (tmp_path / "out.vtk").read_bytes().split(b"\n")[2].strip() == word


def test_reads_in_threads_keep_their_own_node_tags(msh):
    from concurrent.futures import ThreadPoolExecutor

    paths = [msh[name, "41b"] for name in ("bl", "partial", "unnamed", "xy")] * 3
    with ThreadPoolExecutor(4) as pool:
        meshes = list(pool.map(anglesmooth.read, paths))
    for path, m in zip(paths, meshes):
        assert np.array_equal(asio.node_tags(m), np.sort(gmsh_view(path)["tags"]))


def test_xdmf_heavy_data_in_hdf5(msh, tmp_path):
    out = tmp_path / "o.xdmf"
    r = run(msh["bl", "41a"], out, "-q")
    assert r.exit_code == 0, r.stderr
    assert sorted(os.listdir(tmp_path)) == ["o.h5", "o.xdmf"]
    text = out.read_text()
    assert 'Format="HDF"' in text and "o.h5:/" in text and ".tmp" not in text
    back = anglesmooth.read(out)
    assert back.n_cells == anglesmooth.read(msh["bl", "41a"]).n_cells
    r = run(out, tmp_path / "x.xdmf", "-q", "--ascii")  # inline XML on request: one file
    assert r.exit_code == 0 and 'Format="XML"' in (tmp_path / "x.xdmf").read_text()
    assert not (tmp_path / "x.h5").exists()
    r = run(tmp_path / "x.xdmf", tmp_path / "y.xdmf", "-q")  # an XML input stays XML
    assert r.exit_code == 0 and not (tmp_path / "y.h5").exists()


def test_msh_vtu_msh_brings_physical_names_back(msh, tmp_path):
    r = run(msh["bl", "41a"], tmp_path / "a.vtu", "-q")
    assert r.exit_code == 0, r.stderr
    r = run(tmp_path / "a.vtu", tmp_path / "b.msh", "-q")
    assert r.exit_code == 0, r.stderr
    got = meshio.read(tmp_path / "b.msh")
    assert {k: v.tolist() for k, v in got.field_data.items()} == {"outer": [13, 1]}
    assert not any(k.startswith("set:") for k in got.cell_data)
    groups = [(d, t, name) for d, t, name, _ in gmsh_view(tmp_path / "b.msh")["groups"]]
    assert groups == [(d, t, name) for d, t, name, _ in gmsh_view(msh["bl", "41a"])["groups"]]


# ---------------------------------------------------------------------------
# 6. existing outputs
# ---------------------------------------------------------------------------


def test_an_existing_output_is_replaced_the_input_never(msh, tmp_path):
    """An existing OUTPUT of the input's format is replaced, as gmsh -o and cp do (a re-run, a Makefile rule);
    the input itself (by name, symlink or hard link) needs --force; nothing else in the directory changes."""
    a, b = tmp_path / "a.msh", tmp_path / "b.msh"
    a.write_bytes(msh["bl", "41a"].read_bytes())
    b.write_bytes(msh["partial", "41a"].read_bytes())
    os.chmod(b, 0o640)
    (tmp_path / "sym.msh").symlink_to(a)
    os.link(a, tmp_path / "hard.msh")
    before = snapshot(tmp_path)
    r = run(a, b, "-q")
    assert r.exit_code == 0, r.stderr
    after = snapshot(tmp_path)
    assert after["b.msh"] != before["b.msh"]
    assert {k: v for k, v in after.items() if k != "b.msh"} == {k: v for k, v in before.items() if k != "b.msh"}
    assert os.stat(b).st_mode & 0o777 == 0o640
    assert anglesmooth.read(b).n_cells == anglesmooth.read(a).n_cells  # a's mesh, smoothed
    first = b.read_bytes()
    r = run(a, b, "-q")  # run again: the same result replaces the previous one
    assert r.exit_code == 0 and b.read_bytes() == first
    for name in ("a.msh", "sym.msh", "hard.msh"):
        r = run(a, tmp_path / name)
        assert r.exit_code == 2 and "is the input file; pass --force or --in-place" in one_error(r)
    assert snapshot(tmp_path) == after
    help_text = " ".join(cli_runner().invoke(cli, ["smooth", "--help"]).stdout.split())
    assert "An existing OUTPUT is replaced" in help_text


# ---------------------------------------------------------------------------
# 7. gmsh node tags for --fix-nodes
# ---------------------------------------------------------------------------


def test_fix_nodes_with_gmsh_tags(msh, tmp_path):
    m = anglesmooth.read(msh["partial", "22a"])
    tags = asio.node_tags(m)
    free = np.flatnonzero(~anglesmooth.build_topology(m).fixed)[:6]
    (tmp_path / "tags.txt").write_text(" ".join(map(str, tags[free])) + "\n")
    (tmp_path / "idx.txt").write_text(" ".join(map(str, free)) + "\n")
    r1 = run(msh["partial", "22a"], tmp_path / "t.vtu", "-q", "--fix-nodes", tmp_path / "tags.txt",
             "--node-numbering", "gmsh")
    r2 = run(msh["partial", "22a"], tmp_path / "i.vtu", "-q", "--fix-nodes", tmp_path / "idx.txt")
    assert r1.exit_code == 0 and r2.exit_code == 0, (r1.stderr, r2.stderr)
    t, i = meshio.read(tmp_path / "t.vtu").points, meshio.read(tmp_path / "i.vtu").points
    assert np.array_equal(t, i)
    assert np.array_equal(t[free], meshio.read(msh["partial", "22a"]).points[free])
    # the messages say which numbering is expected
    (tmp_path / "big.txt").write_text(str(int(tags.max()) + 5))
    r = run(msh["partial", "22a"], tmp_path / "o.vtu", "--fix-nodes", tmp_path / "big.txt", "--node-numbering", "gmsh")
    assert r.exit_code == 2 and "gmsh node tag" in one_error(r) and "1-based" in one_error(r)
    (tmp_path / "n.txt").write_text(str(m.n_points))
    r = run(msh["partial", "22a"], tmp_path / "o.vtu", "--fix-nodes", tmp_path / "n.txt")
    assert r.exit_code == 2 and "0-based node indices" in one_error(r) and "--node-numbering gmsh" in one_error(r)
    r = run(tmp_path / "i.vtu", tmp_path / "o.vtu", "--fix-nodes", tmp_path / "idx.txt", "--node-numbering", "gmsh")
    assert r.exit_code == 2 and "no gmsh node tags" in one_error(r)


# ---------------------------------------------------------------------------
# 8. the Python API from a meshio user's hands
# ---------------------------------------------------------------------------


def test_meshio_mesh_in_and_out(msh):
    src = meshio.read(msh["bl", "41a"])
    result = anglesmooth.smooth(src, "angle", passes=3)
    out = result.to_meshio()
    assert isinstance(out, meshio.Mesh)
    assert [c.type for c in out.cells] == [c.type for c in src.cells]
    for key in src.cell_data:
        assert all(np.array_equal(a, b) for a, b in zip(out.cell_data[key], src.cell_data[key]))
    assert out.field_data.keys() == src.field_data.keys()
    assert np.array_equal(out.point_data["gmsh:dim_tags"], src.point_data["gmsh:dim_tags"])
    assert not np.array_equal(out.points, src.points) and out.points is not src.points
    assert np.array_equal(src.points, meshio.read(msh["bl", "41a"]).points)  # the input is never modified
    topo = anglesmooth.build_topology(src)
    assert np.array_equal(out.points[topo.fixed], src.points[topo.fixed])
    tilted = meshio.read(msh["tilted", "41a"])
    t_out = anglesmooth.smooth(tilted, "laplacian", passes=2).to_meshio()
    assert t_out.points.shape == tilted.points.shape and not np.array_equal(t_out.points, tilted.points)


#: One gmsh 4.15 realization of ``_boundary_layer`` (binary MSH 4.1), committed: gmsh does not mesh that model
#: the same way twice (every process gives other node positions, with the same minimum angle of 39.2 deg), and
#: on about 1 realization in 80 the default lowers the mesh's minimum angle a little (39.20 -> 38.3-39.1 deg,
#: Laplacian 33.2; four of them in benchmarks/meshes/bl-min-angle-drops/, issue 12), which made this test fail
#: at random.  On this one the default gives 42.5 deg.
BL_41B = Path(__file__).resolve().parent / "data" / "gmsh_boundary_layer_41b.msh"


def test_cli_subprocess_on_boundary_layer(tmp_path):
    """The whole path in a real process: default MSH 4.1 output of a boundary-layer mesh, JSON report."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    out = tmp_path / "out.msh"
    p = subprocess.run([sys.executable, "-m", "anglesmooth", str(BL_41B), str(out), "--json", "-", "-q"],
                       capture_output=True, env=env, timeout=120)
    assert p.returncode == 0, p.stderr.decode()
    report = json.loads(p.stdout)
    assert report["before"]["triangles"] > 400 and report["before"]["quads"] > 40  # the layer mesh: both kinds
    assert report["after"]["min_angle"] >= report["before"]["min_angle"]
    same_for_gmsh(BL_41B, out)


def test_msh41_benchmark_script_runs_tiny():
    """benchmarks/bench_msh41.py (the figures in benchmarks/README.md) on a tiny mesh: its table comes out."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    script = SRC.parent / "benchmarks" / "bench_msh41.py"
    p = subprocess.run([sys.executable, str(script), "2000", "--repeat", "1"], capture_output=True, env=env,
                       timeout=300, text=True)
    assert p.returncode == 0, p.stderr
    rows = [ln for ln in p.stdout.splitlines() if ln.startswith("| binary") or ln.startswith("| ASCII")]
    assert len(rows) == 2 and all(len(r.split("|")) == 9 for r in rows)
