"""Second-order meshes end to end: corners smoothed, mid-edge and centre nodes placed after."""

from __future__ import annotations

import gmsh
import numpy as np
import pytest

from anglesmooth import read, smooth, write
from anglesmooth.topology import build_topology


def _plate_with_hole(path, recombine: bool):
    gmsh.initialize(["", "-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        plate = occ.addRectangle(0, 0, 0, 4, 2)
        hole = occ.addDisk(2, 1, 0, 0.5, 0.5)
        occ.cut([(2, plate)], [(2, hole)])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
        gmsh.option.setNumber("Mesh.Optimize", 0)
        if recombine:
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
            gmsh.option.setNumber("Mesh.Algorithm", 8)
        gmsh.option.setNumber("Mesh.ElementOrder", 2)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("recombine", [False, True], ids=["triangle6", "quad9"])
def test_second_order_nodes_follow_their_corners(tmp_path, recombine):
    src = tmp_path / "in.msh"
    _plate_with_hole(src, recombine)
    mesh = read(src)
    assert len(mesh.midside) > 0
    # disturb the free corner nodes so that smoothing has to move them
    topo = build_topology(mesh)
    rng = np.random.default_rng(0)
    p = mesh.points.copy()
    p[topo.free_nodes] += rng.uniform(-0.03, 0.03, (topo.n_free, 2))
    mesh = mesh.with_points(p)
    r = smooth(mesh, "angle", passes=5, topology=topo)
    q = r.points
    mid, a, b = mesh.midside.T
    on_fixed_edge = topo.fixed[a] & topo.fixed[b]
    assert on_fixed_edge.any() and (~on_fixed_edge).any()
    # interior mid-edge nodes of edges that moved sit at the midpoint of the moved edge; those of
    # edges whose ends did not move are left alone, bit for bit
    moved = (q != p).any(axis=1)
    follow = ~on_fixed_edge & (moved[a] | moved[b])
    assert follow.any()
    np.testing.assert_allclose(q[mid[follow]], 0.5 * (q[a[follow]] + q[b[follow]]), atol=1e-12)
    still = ~on_fixed_edge & ~follow
    assert np.array_equal(q[mid[still]], p[mid[still]])
    # mid-edge nodes of boundary edges keep the curved boundary, bit for bit
    assert np.array_equal(q[mid[on_fixed_edge]], p[mid[on_fixed_edge]])
    hole = np.abs(np.hypot(q[mid[on_fixed_edge], 0] - 2, q[mid[on_fixed_edge], 1] - 1) - 0.5) < 1e-9
    assert hole.any()  # some of them lie on the circle, not on the chords
    if recombine:
        c = mesh.centres
        assert len(c) > 0
        cm = moved[c[:, 1:]].any(axis=1)
        np.testing.assert_allclose(q[c[cm, 0]], q[c[cm, 1:]].mean(axis=1), atol=1e-12)
        assert np.array_equal(q[c[~cm, 0]], p[c[~cm, 0]])
    assert r.points[topo.free_nodes].tolist() != p[topo.free_nodes].tolist()
    # no pass moves nothing, mid-side and centre nodes included (a curved interior edge stays curved)
    assert np.array_equal(smooth(mesh, "angle", passes=0, topology=topo).points, p)
    # and the written file keeps the second-order cells
    out = tmp_path / "out.vtu"
    write(mesh, out, points=q)
    back = read(out)
    assert np.array_equal(back.midside, mesh.midside)
    np.testing.assert_allclose(back.points, q)
