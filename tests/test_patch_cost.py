"""Stage 5's cheaper paths (issue 12 item 3) give the numbers of the paths they replace, bit for bit.

* The compiled screen (``_fastcalls.screen_cells``) hands over the kept cells' largest corner
  cotangent (``_patch._cell_cot``), so that stage 5 does not gather those cells again.
* ``_patchascent._setdiff`` stands in for ``np.setdiff1d`` in a patch's set-up.
* Stage 5 gives the same points and area range with the numpy and the compiled kernels (the compiled
  screen's cotangents, the numpy screen's ``_cell_cot``).
"""

from __future__ import annotations

import numpy as np
import pytest

from anglesmooth import generate as gen
from anglesmooth.smoothers import _fastcalls, _patch
from anglesmooth.smoothers._floors import input_floors
from anglesmooth.smoothers._patchascent import _setdiff
from anglesmooth.topology import build_topology

MESHES = {
    "triangles": lambda: gen.random_delaunay(3000, 1),
    "quads": lambda: gen.random_quad_mesh(1500, 2),
    "mixed": lambda: gen.paper_mixed_mesh(0),
}


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


@pytest.mark.parametrize("name", sorted(MESHES))
def test_compiled_screen_cotangents_are_cell_cot(name):
    """Kept cells and their cotangents from the compiled screen = the numpy screen's cells and
    ``_cell_cot`` of them, to the bit (NaN, infinities and the sign of zero included), on jittered,
    tangled and degenerate (NaN, coincident, overflowing corners) points."""
    mesh = MESHES[name]()
    topo = build_topology(mesh)
    rng = np.random.default_rng(0)
    h = np.ptp(mesh.points) / np.sqrt(mesh.points.shape[0])
    kinds = [c for c in (topo.tri, topo.quad) if c.shape[0]]
    some_fin = some_inf = False
    for jitter in (0.0, 0.3, 1.5):
        P = np.array(mesh.points, dtype=np.float64) + rng.normal(scale=jitter * h, size=mesh.points.shape)
        if jitter > 1.0:
            P[rng.integers(0, P.shape[0], 4)] = np.nan
            P[rng.integers(0, P.shape[0], 4)] = P[rng.integers(0, P.shape[0], 4)]
            with np.errstate(over="ignore"):
                P[rng.integers(0, P.shape[0], 4)] *= 1e308  # overflowing edges: infinite and NaN products
        for cells in kinds:
            for below in (30.0, 60.0):
                t = np.tan(np.radians(below)) * (1.0 + 1e-6)
                ids, _, cot = _fastcalls.screen_cells(P, cells, t)
                with np.errstate(all="ignore"):  # (the overflowing points)
                    np.testing.assert_array_equal(ids, _patch._maybe_below(P, cells, below, False))
                    want = _patch._cell_cot(P, cells[ids])
                np.testing.assert_array_equal(_bits(cot), _bits(want))
                some_fin |= bool(np.isfinite(want).any())
                some_inf |= bool(np.isinf(want).any())
    assert some_fin and some_inf  # valid kept cells and invalid ones


def test_setdiff_is_numpy_setdiff1d():
    rng = np.random.default_rng(1)
    for _ in range(500):
        a = rng.integers(0, int(rng.integers(1, 300)), int(rng.integers(0, 80)))
        b = rng.integers(0, 300, int(rng.integers(0, 40)))
        got, want = _setdiff(a, b), np.setdiff1d(a, b)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("name", ["triangles", "mixed"])
def test_stage5_same_bits_with_either_kernel(monkeypatch, name):
    """``patch_moves`` after a few passes: the same points and area range with the numpy kernels (numpy
    screen, ``_cell_cot``) and the compiled ones (the compiled screen's cotangents)."""
    mesh = MESHES[name]()
    topo = build_topology(mesh)
    floors = input_floors(np.array(mesh.points), topo)
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")
    from anglesmooth import smooth

    p = smooth(mesh, "angle", 2, topology=topo, patch_cells=0).points
    out = {}
    for kernel in ("numpy", "numba"):
        monkeypatch.setenv("ANGLESMOOTH_KERNEL", kernel)
        t = build_topology(mesh)
        out[kernel] = _patch.patch_moves(p, t, floors, with_range=True)
    (a, ra), (b, rb) = out["numpy"], out["numba"]
    assert np.abs(a - p).max() > 0  # some patch moved
    np.testing.assert_array_equal(_bits(a), _bits(b))
    assert ra == rb


def test_overwrite_moves_the_given_points():
    """``patch_moves(..., overwrite=True)`` (``angle.step``'s call, on its pass result): the same numbers as
    a copy, in the array given."""
    mesh = MESHES["mixed"]()
    topo = build_topology(mesh)
    floors = input_floors(np.array(mesh.points), topo)
    from anglesmooth import smooth

    p = smooth(mesh, "angle", 2, topology=topo, patch_cells=0).points
    want, rw = _patch.patch_moves(p, topo, floors, with_range=True)
    given = np.array(p)
    got, rg = _patch.patch_moves(given, topo, floors, with_range=True, overwrite=True)
    assert got is given and np.abs(want - p).max() > 0
    np.testing.assert_array_equal(_bits(got), _bits(want))
    assert rg == rw
