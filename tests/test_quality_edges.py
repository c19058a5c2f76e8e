"""Edge cases of the quality measures: inverted vs degenerate cells, and meshes of any size."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from anglesmooth import quality as q
from anglesmooth.errors import InvalidMeshError
from anglesmooth.gates import evaluate, worst_cell
from anglesmooth.generate import paper_mixed_mesh, paper_quad_mesh, structured_triangles
from anglesmooth.mesh import MAX_COORD, MIN_SIZE, Mesh2D
from anglesmooth.topology import build_topology

# --------------------------------------------------------------------------- inverted / degenerate: disjoint


def _exact_area(p: np.ndarray, cell) -> Fraction:
    """Shoelace area of one cell in exact rational arithmetic (the slow per-cell reference)."""
    xy = [(Fraction(float(p[v, 0])), Fraction(float(p[v, 1]))) for v in cell]
    return sum(xy[k][0] * xy[(k + 1) % len(xy)][1] - xy[(k + 1) % len(xy)][0] * xy[k][1]
               for k in range(len(xy))) / 2


def _moved_grid(seed: int):
    """A right-triangle grid whose free nodes jump to other grid positions: on integer coordinates,
    so that the float areas are exact and cells are inverted, collapsed or valid beyond doubt."""
    m = structured_triangles(7, 6, equilateral=False)
    topo = build_topology(m)
    rng = np.random.default_rng(seed)
    p = m.points.copy()
    free = np.flatnonzero(~np.asarray(topo.fixed))
    p[free] += rng.integers(-1, 2, size=(free.size, 2))  # some land on a neighbour, some across it
    return p, topo


@pytest.mark.parametrize("seed", range(6))
def test_inverted_and_degenerate_are_disjoint_and_match_the_exact_reference(seed):
    p, topo = _moved_grid(seed)
    cells = [c for c in topo.tri] + [c for c in topo.quad]
    exact = [_exact_area(p, c) for c in cells]
    span = p.max(axis=0) - p.min(axis=0)
    tol = Fraction(q.DEGENERATE_REL) * (Fraction(float(span[0])) ** 2 + Fraction(float(span[1])) ** 2)
    want_inv = [i for i, a in enumerate(exact) if a < 0]
    want_deg = [i for i, a in enumerate(exact) if 0 <= a <= tol]
    inv, deg = q.inverted_cells(p, topo).tolist(), q.degenerate_cells(p, topo).tolist()
    assert inv == want_inv and deg == want_deg
    assert not set(inv) & set(deg)
    s = q.summarize(p, topo)
    assert (s["inverted"], s["degenerate"]) == (len(want_inv), len(want_deg))
    assert s["inverted_cells"] == want_inv[:10] and s["degenerate_cells"] == want_deg[:10]
    valid = sum(1 for a in exact if a > tol)
    assert s["inverted"] + s["degenerate"] + valid == len(cells)  # every cell is exactly one of the three


def test_the_generated_corpus_has_both_kinds():
    """The parametrized test above is not vacuous: its meshes hold inverted and zero-area cells."""
    counts = [q.summarize(*_moved_grid(seed)) for seed in range(6)]
    assert sum(c["inverted"] for c in counts) > 0 and sum(c["degenerate"] for c in counts) > 0


def test_gates_name_the_first_inverted_and_the_first_degenerate_cell():
    pts = np.array([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1]], float)
    m = Mesh2D.from_arrays(pts, triangles=[[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]])
    topo = build_topology(m)
    moved = pts.copy()
    moved[4] = [0.5, 0.0]  # cell 0 collapses onto the x axis (degenerate)
    moved[5] = [2.0, -1.0]  # cells 2 (1, 2, 5) and 3 (1, 5, 4) flip (inverted)
    s = q.summarize(moved, topo)
    assert (s["inverted_cells"], s["degenerate_cells"]) == ([2, 3], [0])
    gates = {g.name: g for g in evaluate(s, {"max_inverted": 0, "max_degenerate": 0}, moved, topo)}
    assert (gates["max_inverted"].value, gates["max_inverted"].cell) == (2, 2)
    assert (gates["max_degenerate"].value, gates["max_degenerate"].cell) == (1, 0)
    assert worst_cell(pts, topo, "max_degenerate") is None


def test_guard_validity_still_counts_zero_area_as_invalid():
    """invalid_cells (what the smoothers' guard refuses) is unchanged: zero area is invalid there."""
    pts = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], float)
    m = Mesh2D.from_arrays(pts, triangles=[[0, 1, 2], [1, 3, 2]])
    moved = pts.copy()
    moved[2] = [0.5, 0.0]
    assert q.invalid_cells(moved, build_topology(m)).tolist() == [True, False]


# --------------------------------------------------------------------------- scale invariance


SCALE_FREE = ("min_area", "max_area", "min_edge")


@pytest.mark.parametrize("k", [-1000, -330, -60, 7, 60, 330, 900])
@pytest.mark.parametrize("make", [paper_mixed_mesh, paper_quad_mesh], ids=["mixed", "quad"])
def test_summary_is_scale_invariant_bit_for_bit(make, k):
    m = make(seed=1)
    topo = build_topology(m)
    rng = np.random.default_rng(k % 7)
    p = m.points.copy()
    free = np.flatnonzero(~np.asarray(topo.fixed))
    p[free] += rng.normal(0, 2.0, (free.size, 2))  # distorted: inverted and non-convex cells too
    ref = q.summarize(p, topo)
    got = q.summarize(np.ldexp(p, k), topo)
    assert {key: got[key] for key in ref if key not in SCALE_FREE} == {key: ref[key] for key in ref if key not in SCALE_FREE}
    with np.errstate(over="ignore", under="ignore"):
        assert got["min_area"] == float(np.ldexp(ref["min_area"], 2 * k))
        assert got["max_area"] == float(np.ldexp(ref["max_area"], 2 * k))
        assert got["min_edge"] == float(np.ldexp(ref["min_edge"], k))
    assert ref["inverted"] > 0
    for fn in (q.cell_min_angles, q.cell_max_angles, q.tri_aspect_ratio, q.tri_radius_ratio, q.quad_condition,
               q.quad_scaled_jacobian, q.quad_aspect_ratio, q.inverted_cells, q.degenerate_cells, q.nonconvex_quads):
        assert np.array_equal(fn(np.ldexp(p, k), topo), fn(p, topo)), fn.__name__


@pytest.mark.parametrize("scale", [1e-300, 1e-90, 1e-20, 1e80, 1e300])
def test_no_underflow_or_overflow_in_the_measures(scale):
    """Before: at 1e-300 every cell was inverted and degenerate, at 1e-20 every quad had condition 5e29,
    at 1e80 the radius ratio was NaN.  Now the measures are those of the unscaled mesh (to round-off)."""
    m = paper_mixed_mesh(seed=0)
    topo = build_topology(m)
    ref, got = q.summarize(m.points, topo), q.summarize(m.points * scale, topo)
    assert (got["inverted"], got["degenerate"]) == (ref["inverted"], ref["degenerate"]) == (0, 0)
    for key in ("min_angle", "max_angle", "area_ratio", "edge_ratio"):
        assert got[key] == pytest.approx(ref[key], rel=1e-12)
    for key in ("tri_radius_ratio", "quad_condition", "tri_aspect_ratio", "quad_scaled_jacobian"):
        assert got[key]["max"] == pytest.approx(ref[key]["max"], rel=1e-12), key
    assert np.isfinite(got["tri_radius_ratio"]["mean"])


def test_coincident_nodes_are_degenerate_not_refused():
    m = Mesh2D.from_arrays([[1.0, 1.0]] * 3, triangles=[[0, 1, 2]])
    s = q.summarize(m.points, build_topology(m))
    assert (s["inverted"], s["degenerate"], s["min_area"]) == (0, 1, 0.0)


# --------------------------------------------------------------------------- meshes too small / too large


def test_mesh_smaller_than_min_size_is_refused():
    pts = structured_triangles(3, 3).points
    tri = structured_triangles(3, 3).triangles
    with pytest.raises(InvalidMeshError, match=r"too small to compute with: its bounding-box diagonal is 4.36e-300, below 1e-100"):
        Mesh2D.from_arrays(pts * 1e-300, triangles=tri)
    size = float(np.hypot(*(pts.max(axis=0) - pts.min(axis=0))))
    Mesh2D.from_arrays(pts * (MIN_SIZE / size) * 1.01, triangles=tri)  # just above the limit: accepted
    with pytest.raises(InvalidMeshError, match="too small"):
        Mesh2D.from_arrays(pts * (MIN_SIZE / size) * 0.99, triangles=tri)


def test_coordinates_beyond_max_coord_are_refused():
    pts = structured_triangles(3, 3).points.copy()
    tri = structured_triangles(3, 3).triangles
    Mesh2D.from_arrays(pts * (MAX_COORD / pts.max()), triangles=tri)  # at the limit: accepted
    with pytest.raises(InvalidMeshError, match=r"node \d+ has an absurd coordinate .* \(limit 1e\+150\)"):
        Mesh2D.from_arrays(pts * 1e300, triangles=tri)
