"""Tests of the seeded mesh generators and the named test meshes."""

from __future__ import annotations

import numpy as np
import pytest

import meshes
from anglesmooth import generate as gen
from anglesmooth.topology import build_topology, signed_areas

pytest.importorskip("scipy")


def _angles(points, cells):
    """Corner angles in degrees of counter-clockwise cells, the obvious way."""
    p = points[cells]
    u = np.roll(p, 1, axis=1) - p
    v = np.roll(p, -1, axis=1) - p
    cross = v[..., 0] * u[..., 1] - v[..., 1] * u[..., 0]
    dot = (u * v).sum(-1)
    return np.degrees(np.mod(np.arctan2(cross, dot), 2 * np.pi))


def assert_valid(m):
    """Counter-clockwise, no degenerate cell, quads strictly convex, every node used."""
    area = signed_areas(m.points, m.triangles, m.quads)
    assert (area > 0).all()
    if m.quads.shape[0]:
        ang = _angles(m.points, m.quads)
        assert (ang > 0).all() and (ang < 180).all()
        assert np.allclose(ang.sum(axis=1), 360)
    if m.triangles.shape[0]:
        assert np.allclose(_angles(m.points, m.triangles).sum(axis=1), 180)
    used = np.zeros(m.n_points, bool)
    used[m.triangles.ravel()] = True
    used[m.quads.ravel()] = True
    assert used.all()
    topo = build_topology(m)
    assert not topo.flipped.any()  # already counter-clockwise
    return topo


GENERATORS = {
    "paper_triangle": gen.paper_triangle_mesh,
    "paper_mixed": gen.paper_mixed_mesh,
    "graded": gen.graded_mesh,
    "paper_quad": gen.paper_quad_mesh,
    "random_delaunay": lambda seed: gen.random_delaunay(2000, seed=seed),
    "random_quad": lambda seed: gen.random_quad_mesh(900, seed=seed),
}


@pytest.mark.parametrize("name", sorted(GENERATORS))
@pytest.mark.parametrize("seed", [0, 1, 7])
def test_generated_meshes_valid(name, seed):
    assert_valid(GENERATORS[name](seed))


@pytest.mark.parametrize("name", sorted(GENERATORS))
def test_deterministic_by_seed(name):
    a, b, c = GENERATORS[name](3), GENERATORS[name](3), GENERATORS[name](4)
    assert np.array_equal(a.points, b.points)
    assert np.array_equal(a.triangles, b.triangles) and np.array_equal(a.quads, b.quads)
    assert not np.array_equal(a.points, c.points)


@pytest.mark.parametrize("seed", range(5))
def test_paper_triangle_counts(seed):
    m = gen.paper_triangle_mesh(seed)
    assert (m.n_points, m.triangles.shape[0], m.quads.shape[0]) == (580, 1078, 0)
    topo = build_topology(m)
    assert int(topo.fixed.sum()) == 80 and int(topo.boundary.sum()) == 80
    assert m.points.min() == 0.0 and m.points.max() <= 100.0
    # 20 equally spaced nodes per side, corners once
    bottom = np.sort(m.points[m.points[:, 1] == 0, 0])
    assert np.allclose(bottom, np.arange(21) * 5.0)
    # on the paper's scale: original areas 0.01 .. 60.36 in Table 3
    area = signed_areas(m.points, m.triangles, m.quads)
    assert np.isclose(area.sum(), 1e4) and 30 < area.max() < 100


@pytest.mark.parametrize("seed", range(5))
def test_paper_mixed_counts(seed):
    m = gen.paper_mixed_mesh(seed)
    nt, nq = m.triangles.shape[0], m.quads.shape[0]
    assert m.n_points == 580 and nt + 2 * nq == 1078
    assert 380 <= nq <= 430 and 220 <= nt <= 320  # paper: 408 quads, 262 triangles
    assert _angles(m.points, m.quads).max() < 160
    assert int(build_topology(m).fixed.sum()) == 80


def test_graded_counts():
    m = gen.graded_mesh(0)
    assert (m.n_points, m.triangles.shape[0]) == (348, 646)
    assert int(build_topology(m).fixed.sum()) == 48
    # graded: much smaller cells in the lower-left 1/16 than elsewhere
    area = signed_areas(m.points, m.triangles, m.quads)
    c = m.points[m.triangles].mean(axis=1)
    fine = (c < 25).all(axis=1)
    coarse = (c > 50).all(axis=1)
    assert np.median(area[fine]) * 10 < np.median(area[coarse])


@pytest.mark.parametrize("seed", range(3))
def test_paper_quad_counts(seed):
    m = gen.paper_quad_mesh(seed)
    assert (m.n_points, m.quads.shape[0], m.triangles.shape[0]) == (571, 530, 0)
    assert int(build_topology(m).fixed.sum()) == 80


@pytest.mark.parametrize("n", [1000, 5000])
def test_random_delaunay_counts(n):
    m = gen.random_delaunay(n, seed=1)
    assert m.triangles.shape[0] == n
    assert np.isclose(signed_areas(m.points, m.triangles, m.quads).sum(), 1.0)


def test_random_quad_mesh():
    m = gen.random_quad_mesh(2500, seed=2)
    assert m.quads.shape[0] == 2500 and m.n_points == 51 * 51
    ang = _angles(m.points, m.quads)
    assert ang.min() > 20 and ang.max() < 170  # jitter 0.24 h: never worse than 1 - 4 * 0.24 in cross product


def test_structured():
    t = gen.structured_triangles(5, 4)
    assert np.allclose(_angles(t.points, t.triangles), 60)
    topo = assert_valid(t)
    assert topo.n_free == 4 * 3
    r = gen.structured_triangles(5, 4, equilateral=False)
    assert_valid(r)
    q = gen.structured_quads(5, 4)
    assert np.allclose(_angles(q.points, q.quads), 90)
    assert build_topology(q).n_free == 4 * 3


def test_split_and_pair_roundtrip():
    m = gen.random_delaunay(200, seed=5)
    t, q = gen.pair_triangles(m.points, m.triangles)
    assert t.shape[0] + 2 * q.shape[0] == 200 and q.shape[0] > 50
    assert np.isclose(signed_areas(m.points, t, q).sum(), 1.0)
    p2, quads = gen.split_to_quads(m.points, t, q)
    assert quads.shape[0] == 3 * t.shape[0] + 4 * q.shape[0]
    assert_valid(meshes.compact(p2, quads=quads))


def _angle_step_single(ring, c):
    """The literal angle-based step for one node with a closed ring (slow reference)."""
    k = len(ring)
    new = []
    for j in range(k):
        pj, a, b = ring[j], ring[j - 1], ring[(j + 1) % k]
        tha = np.arctan2(*(a - pj)[::-1])
        thb = np.arctan2(*(b - pj)[::-1])
        th = thb + np.mod(tha - thb, 2 * np.pi) / 2
        new.append(pj + np.linalg.norm(c - pj) * np.array([np.cos(th), np.sin(th)]))
    return np.mean(new, axis=0)


def _with_centre(m, c):
    p = m.points.copy()
    p[-1] = c
    return p


def test_five_element_polygon():
    starts = gen.five_element_starts()
    finals = []
    for s in starts:
        m = gen.five_element_polygon(s)
        topo = assert_valid(m)
        assert topo.free_nodes.tolist() == [5]
        ring, c = m.points[:5], m.points[5].copy()
        disp = []
        for _ in range(10):
            new = _angle_step_single(ring, c)
            disp.append(np.linalg.norm(new - c))
            c = new
        assert disp[9] < 0.02 * disp[0]
        finals.append(c)
    finals = np.array(finals)
    assert np.ptp(finals, axis=0).max() < 0.01  # same position from every start
    centroid = m.points[:5].mean(axis=0)
    assert np.linalg.norm(finals[0] - centroid) > 0.5  # Laplacian and angle optima differ visibly
    mlap = _angles(_with_centre(m, centroid), m.triangles).min()
    mang = _angles(_with_centre(m, finals[0]), m.triangles).min()
    assert mang > mlap + 3


def test_distorted_mesh_inverts_under_laplacian():
    m = gen.distorted_mesh()
    topo = assert_valid(m)
    assert topo.free_nodes.tolist() == [m.n_points - 1]
    ring = m.points[:-1]
    lap = _with_centre(m, ring.mean(axis=0))
    assert (signed_areas(lap, m.triangles, m.quads) < 0).sum() >= 1
    # the literal angle step never inverts it and improves the minimum angle
    c = m.points[-1].copy()
    for _ in range(10):
        c = _angle_step_single(ring, c)
        assert (signed_areas(_with_centre(m, c), m.triangles, m.quads) > 0).all()
    assert _angles(_with_centre(m, c), m.triangles).min() > 5 * _angles(m.points, m.triangles).min()


def test_named_meshes():
    for m in (meshes.regular_triangles(), meshes.regular_quads(), meshes.with_hole(), meshes.with_hole("triangle"),
              meshes.two_regions(), meshes.mixed_small(), meshes.five_element(), meshes.distorted()):
        assert_valid(m)
    for kind in ("triangle", "quad"):
        m, node, orig = meshes.single_displaced(kind)
        assert_valid(m)
        topo = build_topology(m)
        assert not topo.fixed[node] and not np.allclose(m.points[node], orig)
    hole = build_topology(meshes.with_hole())
    assert hole.fixed.sum() == 24 + 8 and hole.n_free == 48 - 32  # centre node (3, 3) dropped
    tr = build_topology(meshes.two_regions())
    assert tr.fixed_reasons["region interfaces"] == 3
    mixed = build_topology(meshes.mixed_small())
    assert mixed.n_free == 15 and (mixed.spoke_frac != 0.5).any()
