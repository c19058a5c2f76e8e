"""The default ``angle`` never makes a mesh's minimum angle worse than its input's (issue 12: "already-good
meshes never get worse").

Two rules do it (see ``anglesmooth.smoothers.angle``): stages 1-2 accept no position below the input's
smallest local score (``keep_min``, ``floors.score_min``), and stage 4's strict search (quad corners
scored on the triangles' scale) keeps its result only where the node's own local score is no lower than
at its stage 1-2 choice.  The second is what the four committed gmsh boundary-layer realizations of
``benchmarks/meshes/bl-min-angle-drops`` needed (39.20 -> 38.28-39.07 deg before).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from anglesmooth import generate
from anglesmooth.driver import smooth
from anglesmooth.io import read
from anglesmooth.quality import summarize
from anglesmooth.smoothers import get_smoother
from anglesmooth.smoothers._floors import input_floors
from anglesmooth.topology import build_topology
from reference import free_corner_degrees, reference_input_min, reference_keep, reference_pass

DROPS = Path(__file__).resolve().parent.parent / "benchmarks" / "meshes" / "bl-min-angle-drops"


def _free_min_deg(points, topo) -> float:
    """The smallest corner quality (degrees; quad corners min(angle, 180 - angle)) of the cells of a free node."""
    return min((float((np.minimum(a, 180.0 - a) if k == 4 else a).min(initial=180.0))
                for k, a in free_corner_degrees(points, topo)), default=180.0)


@pytest.mark.parametrize("gen_name", ["paper_triangle_mesh", "paper_mixed_mesh", "paper_quad_mesh"])
def test_keep_min_matches_the_per_node_reference(gen_name):
    """Stages 1-2 with the acceptance threshold max(accept_above, the input's smallest local quality), against
    the reference, on an already smoothed mesh (smoothing a result again: its minimum, 20-37 deg, is above
    ``accept_above``, so the rule changes moves)."""
    m0 = getattr(generate, gen_name)(seed=1)
    mesh = m0.with_points(smooth(m0, "angle", 10).points)
    topo = build_topology(mesh)
    floors = input_floors(np.array(mesh.points), topo)
    s_in = reference_input_min(mesh.points, topo)
    assert s_in > 25.0
    assert np.degrees(np.arccos(-floors.score_min)) == pytest.approx(s_in, abs=1e-9)
    rule = floors._replace(packed=np.zeros((0, 0)))  # the rules alone (the reference has no area floors)
    keep = reference_keep(mesh.points, topo)
    p = q = former = mesh.points
    for _ in range(2):
        p = get_smoother("angle").step(p, topo, opt_iterations=0, patch_cells=0, floors=rule).points
        q = reference_pass(q, topo, "angle", keep=keep, input_min=s_in)
        former = reference_pass(former, topo, "angle", keep=keep)
    tol = 1e-9 * np.ptp(mesh.points)
    np.testing.assert_allclose(p, q, rtol=0, atol=tol)
    assert np.abs(q - former).max() > 1e3 * tol  # the rule changed moves
    off = get_smoother("angle").step(mesh.points, topo, opt_iterations=0, patch_cells=0, floors=rule, keep_min=False)
    np.testing.assert_allclose(off.points, reference_pass(mesh.points, topo, "angle", keep=keep), rtol=0, atol=tol)


def test_score_min_is_the_free_nodes_worst_and_off_with_an_invalid_cell():
    mesh = generate.structured_quads(5, 4)
    topo = build_topology(mesh)
    assert np.degrees(np.arccos(-input_floors(mesh.points, topo).score_min)) == pytest.approx(90.0)
    p = mesh.points.copy()
    i = int(topo.free_nodes[0])
    p[i] = p[i] + 2.0 * (p[int(topo.free_nodes[1])] - p[i])  # beyond a neighbour: an invalid quad
    assert input_floors(p, topo).score_min == -np.inf


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
@pytest.mark.parametrize("name", ["r9", "r10", "r11", "r61"])
def test_boundary_layer_realizations_keep_their_minimum_angle(name, kernel, monkeypatch):
    """On these four gmsh realizations the default lowered the minimum angle 39.20 -> 38.28-39.07 deg (stage 4's
    strict search trading the triangles' angles for the quads'); now no pass ends below the input's, with
    either kernel, and both give the same points."""
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", kernel)
    mesh = read(DROPS / f"gmsh_bl_41b_{name}.msh")
    topo = build_topology(mesh)
    s0 = _free_min_deg(mesh.points, topo)
    trace = []
    r = smooth(mesh, "angle", 10, topology=topo, callback=lambda k, p, d: trace.append(_free_min_deg(p, topo)))
    assert min(trace) >= s0 - 1e-9, trace
    before, after = summarize(mesh.points, topo), summarize(r.points, topo)
    assert after["min_angle"] >= before["min_angle"] - 1e-9
    assert after["max_angle"] < 120.0  # (the input's 103.9; Laplacian's ~ 150)
    if kernel == "numba":
        monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")
        np.testing.assert_array_equal(r.points, smooth(mesh, "angle", 10).points)


@pytest.mark.parametrize("kind", ["triangles", "quads", "mixed"])
def test_kernels_agree_when_the_input_minimum_is_above_the_optimization_threshold(kind, monkeypatch):
    """An input whose worst local quality is above ``opt_below`` (40 deg) / ``opt_below_quad`` (60): the
    acceptance threshold then rises above the compiled ``angle_choose``'s ``certify`` score, so no node may take
    its angle position unscored (``lazy``); the default pass is the same with either kernel."""
    from test_smoothers import half_triangles, valid_jitter

    if kind == "triangles":
        mesh, need = valid_jitter(generate.structured_triangles(12, 9), 0.12, 1), 40.0
    elif kind == "quads":
        mesh, need = valid_jitter(generate.structured_quads(12, 9), 0.12, 0), 60.0
    else:
        mesh, need = half_triangles(seed=2), 20.0
    topo = build_topology(mesh)
    s_in = reference_input_min(mesh.points, topo)
    assert s_in > need
    out = {}
    for kernel in ("numpy", "numba"):
        monkeypatch.setenv("ANGLESMOOTH_KERNEL", kernel)
        out[kernel] = smooth(mesh, "angle", 4).points
    np.testing.assert_array_equal(out["numpy"], out["numba"])
    assert _free_min_deg(out["numpy"], topo) >= s_in - 1e-9


def test_both_kernels_hold_stage_4_at_the_input_minimum_the_same_way():
    """Stage 4's ``keep_min`` hold, compiled inside ``angle_optimize`` (after keep_max's) and in numpy in
    ``_worst.hold`` (after ``hold_max``): every node of each block optimized from where it is, with a floor
    ``s_in`` high enough that some strict nodes (both triangles and quads) end below it.  Both kernels put the
    same nodes back to their start, bit for bit, with keep_max on and off; without the floor they do not."""
    from anglesmooth.smoothers import _worst
    from anglesmooth.smoothers._fastcalls import FastGeometry
    from anglesmooth.smoothers._local import BlockGeometry

    mesh = read(DROPS / "gmsh_bl_41b_r9.msh")
    topo = build_topology(mesh)
    pts = np.array(mesh.points)
    floors = input_floors(pts, topo)
    m_cap = max(float(floors.largest_max), 0.0)
    opts = dict(floors=floors, any_keep=True, limits=None, opt_fraction=1.0, opt_iterations=4, opt_below=180.0,
                opt_below_quad=180.0, area_band=0.8, strict_quads=True, strict_above=None, resume_iterations=0,
                resume_radius=0.0625, resume_above=45.0)
    held = 0
    for blk in topo.blocks():
        cur = pts[topo.free_nodes[blk.nodes]]
        best = BlockGeometry(pts, topo, blk, floors=floors).score(cur)
        mixed = (np.bincount(topo.tri_loc[blk.tris] - blk.nodes.start, minlength=blk.size) > 0) & (
            np.bincount(topo.quad_loc[blk.quads] - blk.nodes.start, minlength=blk.size) > 0)
        strict = mixed & floors.keep[blk.nodes]
        if not strict.any():
            continue
        s_in = float(np.median(best[strict]))  # (-cos) some strict nodes below it, some above
        for m_in in (np.inf, m_cap):
            out = {}
            for fast in (False, True):
                geom = (FastGeometry if fast else BlockGeometry)(pts, topo, blk, floors=floors)
                for s in (-np.inf, s_in):
                    stage4 = _worst.worst_optimizer(topo, fast=fast, s_in=s, m_in=m_in, **opts)
                    out[fast, s] = stage4(pts, blk, cur, geom, cur.copy(), best.copy(), None)
            for s in (-np.inf, s_in):
                np.testing.assert_array_equal(out[False, s], out[True, s])
            # the strict nodes whose result (keep_max's, where it acts) is below the floor keep their start,
            # every other node its result
            after = BlockGeometry(pts, topo, blk, floors=floors).score(out[False, -np.inf])
            low = strict & (after < s_in)
            np.testing.assert_array_equal(out[False, s_in][low], cur[low])
            np.testing.assert_array_equal(out[False, s_in][~low], out[False, -np.inf][~low])
            held += int((out[False, s_in] != out[False, -np.inf]).any(axis=1).sum())
    assert held > 0
