"""The default ``angle`` pass hands the next pass the cells' area range at its points (``StepResult.area_range``).

Stage 5's screen reads every cell anyway, so it gives the range of the next pass's ``area_limits`` with
it, per chunk, and the chunks of the cells that stage 5 then moved are computed again: with the numpy
kernels as with the compiled ones.  The range must be exactly ``signed_areas``' minimum and maximum at
the points the pass returns, and a pass given it must return what a pass that computes it returns.
"""

from __future__ import annotations

import numpy as np
import pytest

from anglesmooth import generate as gen
from anglesmooth.smoothers import SMOOTHERS, _patch
from anglesmooth.smoothers._floors import input_floors
from anglesmooth.topology import build_topology, signed_areas

MESHES = {
    "triangles": lambda: gen.random_delaunay(3000, 1),
    "quads": lambda: gen.random_quad_mesh(1500, 2),
    "mixed": lambda: gen.paper_mixed_mesh(0),
}


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
@pytest.mark.parametrize("name", sorted(MESHES))
def test_carried_area_range_is_the_exact_range_and_changes_nothing(monkeypatch, kernel, name):
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", kernel)
    mesh = MESHES[name]()
    topo = build_topology(mesh)
    floors = input_floors(np.array(mesh.points), topo)
    step = SMOOTHERS["angle"].step
    carried = fresh = np.array(mesh.points)
    rng, moved_some = None, False
    for _ in range(4):
        res = step(carried, topo, floors=floors, area_range=rng)
        assert res.area_range is not None  # the screen ran (patch_below 30 deg): a range is given
        a = signed_areas(res.points, topo.tri, topo.quad)
        assert res.area_range == (float(a.min()), float(a.max()))
        ref = step(fresh, topo, floors=floors)  # computes the range itself
        assert np.array_equal(res.points, ref.points)
        moved_some |= not np.array_equal(res.points, carried)
        carried, fresh, rng = res.points, ref.points, res.area_range
    assert moved_some


def test_numpy_range_recomputes_the_chunks_of_moved_cells():
    """:func:`_patch._area_range_np` from a stale screen: only the chunks of ``moved_cells`` are read
    again, so the range is exact when they cover the cells that changed, stale otherwise."""
    mesh = gen.random_delaunay(4000, 3)
    topo = build_topology(mesh)
    p = np.array(mesh.points)
    ranges = []
    _patch._maybe_below(p, topo.tri, 30.0, False, ranges)
    _patch._maybe_below(p, topo.quad, 30.0, False, ranges)
    assert len(ranges[0][0]) == -(-topo.n_tri // _patch._RANGE_CHUNK) > 2
    a = signed_areas(p, topo.tri, topo.quad)
    assert _patch._area_range_np(p, topo, ranges) == (float(a.min()), float(a.max()))
    # shrink the cell of the smallest area further (a free corner moved halfway to the opposite edge's midpoint)
    c = int(np.argmin(a))
    free = np.asarray(topo.fixed, bool)
    v = next(int(x) for x in topo.tri[c] if not free[x])
    others = [int(x) for x in topo.tri[c] if int(x) != v]
    q = p.copy()
    q[v] = 0.5 * (q[v] + 0.5 * (q[others[0]] + q[others[1]]))
    cells = np.flatnonzero((topo.tri == v).any(axis=1))
    b = signed_areas(q, topo.tri, topo.quad)
    assert b.min() < a.min()
    stale = [(r[0].copy(), r[1].copy()) for r in ranges]
    assert _patch._area_range_np(q, topo, stale) == (float(a.min()), float(a.max())) != (float(b.min()), float(b.max()))
    assert _patch._area_range_np(q, topo, ranges, cells) == (float(b.min()), float(b.max()))
