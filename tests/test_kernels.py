"""The compiled (numba) kernels give the same numbers as the numpy ones.

``ANGLESMOOTH_KERNEL=numba`` forces the compiled kernels on small meshes (the
``auto`` default uses them only from ``AUTO_MIN_FREE`` free nodes on).  numba
is in the test extra, so these tests always run.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest
from cli_runner import cli_runner

from anglesmooth import generate as gen
from anglesmooth.cli import cli
from anglesmooth.errors import ConfigurationError
from anglesmooth.mesh import Mesh2D
from anglesmooth.smoothers import SMOOTHERS, _fast, _fastcalls
from anglesmooth.smoothers._local import BlockGeometry, angle_target, laplacian_target, local_scale, optimize
from anglesmooth.topology import build_topology, signed_areas

def flat_quad() -> Mesh2D:
    """A quad flattened onto the boundary with its free corners almost touching: every full or half
    move of either is invalid, so the default ``angle`` takes the halved Laplacian move (its stage 3)."""
    m = gen.structured_quads(5, 4)
    p = m.points.copy()
    for (x, y), new in (((2, 1), (2.45, 0.02)), ((3, 1), (2.55, 0.021))):
        p[int(np.flatnonzero(np.hypot(p[:, 0] - x, p[:, 1] - y) < 1e-9)[0])] = new
    return m.with_points(p)


def thin_layers() -> Mesh2D:
    """Quads graded towards the bottom (y -> y^3): the lowest rows have edge ratios far above 4, so
    the driver's input floors (``_floors.input_floors``) apply to them."""
    m = gen.structured_quads(8, 6)
    p = m.points.copy()
    h = p[:, 1].max()
    p[:, 1] = h * (p[:, 1] / h) ** 3
    topo = build_topology(m)
    rng = np.random.default_rng(1)
    p[topo.free_nodes, 0] += rng.uniform(-0.3, 0.3, topo.n_free) * (p[:, 0].max() / 8)
    return m.with_points(p)


MESHES = {
    "triangles": lambda: gen.paper_triangle_mesh(3, n_interior=150, per_side=10),
    "flat-quad": flat_quad,
    "quads": lambda: gen.paper_quad_mesh(3),
    "mixed": lambda: gen.paper_mixed_mesh(3),
    "graded": lambda: gen.graded_mesh(3, per_layer=30, per_side=6),
    "distorted": gen.distorted_mesh,
}


def tangled(mesh: Mesh2D, seed: int = 0) -> Mesh2D:
    """The mesh with its free nodes jittered by about one edge length: many inverted and non-convex cells."""
    topo = build_topology(mesh)
    rng = np.random.default_rng(seed)
    p = mesh.points.copy()
    h = np.median(np.linalg.norm(p[topo.edges[:, 0]] - p[topo.edges[:, 1]], axis=1))
    p[topo.free_nodes] += rng.normal(scale=0.8 * h, size=(topo.n_free, 2))
    return Mesh2D.from_arrays(p, triangles=mesh.triangles, quads=mesh.quads)


def run(mesh: Mesh2D, method: str, guard: bool, mode: str, monkeypatch, order: str = "colour", passes: int = 3):
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", mode)
    topo = build_topology(mesh)
    assert _fast.active(topo) == (mode == "numba")
    p = mesh.points
    for _ in range(passes):
        r = SMOOTHERS[method].step(p, topo, guard=guard, order=order)
        p = r.points
    return p, r.rejected


@pytest.mark.parametrize("name", [*MESHES, "tangled"])
@pytest.mark.parametrize("method", sorted(SMOOTHERS))
@pytest.mark.parametrize("guard", [True, False])
def test_every_method_same_result_with_either_kernel(name, method, guard, monkeypatch):
    mesh = tangled(MESHES["mixed"]()) if name == "tangled" else MESHES[name]()
    p_np, rej_np = run(mesh, method, guard, "numpy", monkeypatch)
    p_nb, rej_nb = run(mesh, method, guard, "numba", monkeypatch)
    assert rej_np == rej_nb
    if method == "angle" and mesh.quads.shape[0] and mesh.triangles.shape[0]:
        # the 3:2 split of quad:triangle spokes uses libm's atan2/cos/sin in the compiled kernel
        np.testing.assert_allclose(p_nb, p_np, rtol=0, atol=1e-12 * np.ptp(mesh.points))
    else:
        np.testing.assert_array_equal(p_nb, p_np)


@pytest.mark.parametrize("method", sorted(SMOOTHERS))
def test_input_floors_same_result_with_either_kernel(method, monkeypatch):
    from anglesmooth.driver import smooth
    from anglesmooth.smoothers._floors import input_floors

    mesh = thin_layers()
    assert input_floors(mesh.points, build_topology(mesh)).active
    out = []
    for mode in ("numpy", "numba"):
        monkeypatch.setenv("ANGLESMOOTH_KERNEL", mode)
        out.append(smooth(mesh, method, 5))
    assert out[0].rejected == out[1].rejected
    np.testing.assert_array_equal(out[0].points, out[1].points)


@pytest.mark.parametrize("method", ["angle", "laplacian"])
def test_jacobi_order_same_result_with_either_kernel(method, monkeypatch):
    mesh = MESHES["triangles"]()
    a, _ = run(mesh, method, True, "numpy", monkeypatch, order="jacobi")
    b, _ = run(mesh, method, True, "numba", monkeypatch, order="jacobi")
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name", ["triangles", "mixed"])
def test_numpy_speedups_give_the_same_numbers(name, monkeypatch):
    """The numpy kernels' shortcuts against their plain forms: the area band fused into the score
    against ``area_range`` + ``score``, and a block subset's ragged layout (``_SMALL_SUBSET``) against
    the per-count chunks; tangled candidates, so invalid and inverted cells count too."""
    from anglesmooth.smoothers import _local

    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")
    mesh = tangled(MESHES[name](), seed=3)
    topo = build_topology(mesh)
    rng = np.random.default_rng(4)
    pts = mesh.points
    checked_out = 0
    for blk in topo.blocks():
        if blk.size < 3:
            continue
        cur = pts[topo.free_nodes[blk.nodes]]
        X = cur[None] + rng.normal(scale=0.03 * np.ptp(pts), size=(8, blk.size, 2))
        geom = BlockGeometry(pts, topo, blk)
        lo0, hi0 = geom.area_range(cur)
        lo0, hi0 = 0.8 * lo0, hi0 / 0.8
        lo, hi = geom.area_range(X)
        plain = np.where((lo >= lo0) & (hi <= hi0), geom.score(X), -np.inf)
        np.testing.assert_array_equal(geom.banded_score(X, lo0, hi0), plain)
        checked_out += int(np.isinf(plain).sum())
        sub = np.arange(1, blk.size, 3)
        ragged = geom.restrict(sub).score(X[:, sub])
        from anglesmooth.smoothers import _rows

        monkeypatch.setattr(_local, "_SMALL_SUBSET", 0)  # every subset in per-count chunks
        monkeypatch.setattr(_rows, "_MERGE", 0)  # (no group joins the ragged chunks)
        grouped = geom.restrict(sub)
        monkeypatch.undo()
        monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")
        assert all(isinstance(c[3], int) for c in grouped._t.chunks + grouped._q.chunks)
        np.testing.assert_array_equal(grouped.score(X[:, sub]), ragged)
    assert checked_out > 0  # some candidates left the band


@pytest.mark.parametrize("name", ["graded", "mixed", "quads"])
def test_numpy_subset_shortcuts_give_the_same_numbers(name, monkeypatch):
    """The numpy kernels' subset shortcuts against their plain forms, with input floors: ``restrict``
    (each node's run of rows) against the layout built for the subset, scored plainly and in an area
    band (tested row by row in ``score``), and the ring entries of a subset against the whole block's
    ``laplacian_target`` / ``local_scale``; tangled candidates, so invalid and inverted cells count too."""
    from anglesmooth.smoothers import _local
    from anglesmooth.smoothers._floors import input_floors

    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")
    mesh = MESHES[name]()
    topo = build_topology(mesh)
    floors = input_floors(np.array(mesh.points), topo)
    assert floors.active
    pts = tangled(mesh, seed=5).points
    rng = np.random.default_rng(6)
    invalid = 0
    for blk in topo.blocks():
        if blk.size < 4:
            continue
        cur = pts[topo.free_nodes[blk.nodes]]
        sub = np.sort(rng.choice(blk.size, blk.size // 3, replace=False))
        X = cur[sub][None] + rng.normal(scale=0.03 * np.ptp(pts), size=(8, sub.size, 2))
        geom = BlockGeometry(pts, topo, blk, floors=floors)
        fresh = BlockGeometry(pts, topo, blk, subset=sub, floors=floors)
        lo0, hi0 = fresh.area_range(cur[sub])
        lo0, hi0 = 0.8 * lo0, hi0 / 0.8
        got = geom.restrict(sub)
        for g in (got, got.restrict(np.arange(0, sub.size, 2))):
            k = np.arange(0, sub.size, 2) if g is not got else np.arange(sub.size)
            ref = fresh.score(X)[:, k]
            np.testing.assert_array_equal(g.score(X[:, k]), ref)
            np.testing.assert_array_equal(g.banded_score(X[:, k], lo0[k], hi0[k]), fresh.banded_score(X, lo0, hi0)[:, k])
            invalid += int((ref < -2.5).sum())
        np.testing.assert_array_equal(_local.laplacian_target(pts, topo, blk, subset=sub),
                                      _local.laplacian_target(pts, topo, blk)[sub])
        np.testing.assert_array_equal(_local.local_scale(pts, topo, blk, subset=sub), _local.local_scale(pts, topo, blk)[sub])
    assert invalid > 0


@pytest.mark.parametrize("name", ["triangles", "quads", "mixed"])
def test_kernels_agree_on_random_candidates_valid_invalid_and_degenerate(name, monkeypatch):
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")
    mesh = tangled(MESHES[name](), seed=1)
    topo = build_topology(mesh)
    rng = np.random.default_rng(2)
    pts = mesh.points
    checked_invalid = checked_degenerate = strict_moved = 0
    for blk in topo.blocks():
        cur = pts[topo.free_nodes[blk.nodes]]
        X = cur[None] + rng.normal(scale=0.05 * np.ptp(pts), size=(6, blk.size, 2))
        # a candidate exactly on a neighbour: zero-length edges (NaN cosines) must be invalid in both
        nbr = topo.ring_nbr[blk.ring][np.searchsorted(topo.ring_loc[blk.ring], np.arange(blk.nodes.start, blk.nodes.stop))]
        X = np.concatenate([X, cur[None], pts[nbr][None]])
        ref = BlockGeometry(pts, topo, blk)
        fast = _fastcalls.FastGeometry(pts, topo, blk)
        s_ref, s_fast = ref.score(X), fast.score(X)
        np.testing.assert_array_equal(s_fast, s_ref)
        checked_invalid += int((s_ref < -2.5).sum())
        checked_degenerate += int((s_ref[-1] < -2.5).sum())
        sub = np.arange(0, blk.size, 2)
        np.testing.assert_array_equal(fast.restrict(sub).score(X[:, sub]), ref.restrict(sub).score(X[:, sub]))
        scale = local_scale(pts, topo, blk)
        areas = np.sort(signed_areas(pts, topo.tri, topo.quad))
        binding = (areas[len(areas) // 4], areas[3 * len(areas) // 4])  # area limits that bind for many nodes
        # the compiled compass search against optimize's numpy loop
        strict = rng.random(blk.size) < 0.5  # these nodes score their quad corners with strict_quad
        for band, limits, st in ((None, None, None), (0.8, None, None), (0.5, None, None), (0.8, binding, None),
                                 (None, None, strict), (0.8, binding, strict)):
            kw = dict(area_band=band, area_limits=limits, strict=st)
            for a, b in zip(optimize(fast, cur, scale, 4, **kw), optimize(ref, cur, scale, 4, **kw)):
                np.testing.assert_array_equal(a, b)
        plain, _ = optimize(ref, cur, scale, 4)
        strict_moved += int((optimize(ref, cur, scale, 4, strict=strict)[0] != plain).any(axis=1).sum())
        np.testing.assert_array_equal(_fastcalls.laplacian_target(pts, topo, blk), laplacian_target(pts, topo, blk))
        np.testing.assert_array_equal(_fastcalls.local_scale(pts, topo, blk, sub), local_scale(pts, topo, blk, sub))
        np.testing.assert_allclose(_fastcalls.angle_target(pts, topo, blk), angle_target(pts, topo, blk), rtol=0, atol=1e-12)
    assert checked_invalid > 0 and checked_degenerate > 0  # the invalid branches were exercised
    assert (strict_moved > 0) == (name == "mixed")  # strict_quad changes the search only at nodes of both kinds


def test_auto_uses_compiled_kernels_only_on_large_meshes(monkeypatch):
    monkeypatch.delenv("ANGLESMOOTH_KERNEL", raising=False)
    mesh = MESHES["triangles"]()
    assert not _fast.active(build_topology(mesh))
    monkeypatch.setattr(_fast, "AUTO_MIN_FREE", 10)
    assert _fast.active(build_topology(mesh))
    monkeypatch.setattr(_fast, "_numba_available", lambda: False)
    assert not _fast.active(build_topology(mesh))  # without numba, auto falls back to numpy


def test_cli_suggests_the_fast_extra_only_where_it_would_be_used(monkeypatch, tmp_path):
    src = tmp_path / "in.vtu"
    m = gen.structured_triangles(6, 6)
    meshio.write(src, meshio.Mesh(np.c_[m.points, np.zeros(len(m.points))], [("triangle", m.triangles)]))
    monkeypatch.delenv("ANGLESMOOTH_KERNEL", raising=False)
    monkeypatch.setattr(_fast, "AUTO_MIN_FREE", 10)  # this mesh counts as large

    def stderr(*args):
        r = cli_runner().invoke(cli, [str(a) for a in args])
        assert r.exit_code == 0, r.output
        return r.stderr

    note = "pip install 'anglesmooth[fast]'"
    assert note not in stderr(src, tmp_path / "a.vtu")  # numba is installed (test extra)
    monkeypatch.setattr(_fast, "_numba_available", lambda: False)
    assert note in stderr(src, tmp_path / "b.vtu")
    assert note in stderr("compare", src, "--passes", "1")
    assert note not in stderr(src, tmp_path / "c.vtu", "--quiet")
    assert note not in stderr(src, tmp_path / "d.vtu", "--passes", "0")  # nothing to speed up
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")  # numpy asked for: no advice
    assert note not in stderr(src, tmp_path / "e.vtu")
    monkeypatch.delenv("ANGLESMOOTH_KERNEL")
    monkeypatch.setattr(_fast, "AUTO_MIN_FREE", 10**9)  # a small mesh: numpy is the right kernel anyway
    assert note not in stderr(src, tmp_path / "f.vtu")


def test_bad_kernel_setting_is_a_usage_error(monkeypatch, tmp_path):
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "cuda")
    with pytest.raises(ConfigurationError, match="ANGLESMOOTH_KERNEL"):
        _fast.kernel_mode()
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numba")
    monkeypatch.setattr(_fast, "_numba_available", lambda: False)
    with pytest.raises(ConfigurationError, match="not installed"):
        _fast.kernel_mode()
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "cuda")
    src = tmp_path / "in.vtu"
    m = gen.structured_triangles(4, 4)
    meshio.write(src, meshio.Mesh(np.c_[m.points, np.zeros(len(m.points))], [("triangle", m.triangles)]))
    out = tmp_path / "out.vtu"
    for args in ([str(src), str(out)], ["compare", str(src)]):
        res = cli_runner().invoke(cli, args)
        assert res.exit_code == 2, res.output
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and "ANGLESMOOTH_KERNEL='cuda'" in lines[0], res.stderr
        assert not out.exists()


def test_compiled_kernels_are_safe_from_several_threads(tmp_path):
    """Several caller threads smoothing at once, each kernel call itself cut into chunks on the
    kernels' own threads (``MIN_CHUNK`` lowered so these small meshes use them), give the serial
    results.  (numba's "workqueue" threading layer, used before, aborted the process on concurrent
    parallel launches; the kernels no longer start it.)"""
    script = tmp_path / "threads.py"
    script.write_text(
        "import numpy as np\n"
        "from concurrent.futures import ThreadPoolExecutor\n"
        "from anglesmooth import generate as gen\n"
        "from anglesmooth.smoothers import SMOOTHERS, _fast\n"
        "from anglesmooth.topology import build_topology\n"
        "def smooth(m):\n"
        "    topo, p = build_topology(m), m.points\n"
        "    for _ in range(5):\n"
        "        p = SMOOTHERS['angle'].step(p, topo).points\n"
        "    return p\n"
        "meshes = [gen.paper_triangle_mesh(s, n_interior=200, per_side=10) for s in range(8)]\n"
        "serial = [smooth(m) for m in meshes]\n"
        "_fast.MIN_CHUNK = 16\n"
        "_fast._cores = lambda: 2\n"
        "with ThreadPoolExecutor(4) as pool:\n"
        "    threaded = list(pool.map(smooth, meshes))\n"
        "assert all(np.array_equal(a, b) for a, b in zip(serial, threaded))\n"
        "print(_fast._pool is not None)\n"
    )
    env = dict(os.environ, ANGLESMOOTH_KERNEL="numba", NUMBA_THREADING_LAYER="workqueue",
               PYTHONPATH=os.pathsep.join([str(Path(__file__).resolve().parents[1] / "src"), os.environ.get("PYTHONPATH", "")]))
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["True"]  # the chunked path ran


def test_no_writable_cache_location_compiles_without_caching(tmp_path):
    """A read-only install with a read-only home gives numba no cache location (simulated with a
    locator list that never applies); the kernels must still work (measured: import failed before)."""
    env = dict(os.environ, ANGLESMOOTH_KERNEL="numba", NUMBA_CACHE_LOCATOR_CLASSES="ZipCacheLocator",
               PYTHONPATH=os.pathsep.join([str(Path(__file__).resolve().parents[1] / "src"), os.environ.get("PYTHONPATH", "")]))
    code = (
        "from anglesmooth import generate as gen, smooth\n"
        "r = smooth(gen.paper_quad_mesh(0), 'laplacian', passes=2)\n"
        "print(r.passes)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600, cwd=tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.split() == ["2"]


def _chained(root: BaseException):
    """What numba reports when a signal handler raised inside its helpers during a kernel call."""
    try:
        try:
            raise root
        except BaseException as inner:
            raise SystemError("<function _numba_unpickle> returned a result with an exception set") from inner
    except SystemError as mid:
        raise SystemError("CPUDispatcher(<function angle_choose>) returned a result with an exception set") from mid


def test_an_interrupt_during_a_kernel_is_raised_as_the_interrupt():
    def kernel():
        _chained(KeyboardInterrupt())

    with pytest.raises(KeyboardInterrupt) as info:
        _fast._run(kernel)
    assert type(info.value) is KeyboardInterrupt and info.value.__cause__ is None

    class Terminated(KeyboardInterrupt):  # like the CLI's SIGTERM exception
        pass

    with pytest.raises(Terminated):
        _fast._run(lambda: _chained(Terminated()))
    with pytest.raises(SystemError):  # a real error stays what it is
        _fast._run(lambda: _chained(ValueError("bad")))
    assert _fast._run(lambda a, b: a + b, 2, 3) == 5


def test_row_groups_joined_into_ragged_chunks():
    """``_rows._Rows``: every row in exactly one chunk, each node's rows in their order, the groups of fewer
    than ``_MERGE`` rows last in ragged chunks of sorted nodes; and a block's scores, area ranges and largest
    corners the same numbers with every group regular, some joined and all joined (random triangles with
    input floors, one and several candidates, tangled so that invalid and inverted cells count too)."""
    from anglesmooth.smoothers import _rows
    from anglesmooth.smoothers._floors import input_floors

    rng = np.random.default_rng(7)
    for trial in range(60):
        n = int(rng.integers(1, 3000))
        counts = rng.integers(0, 14, n)
        counts[rng.random(n) < 0.6] = 6
        rel = np.repeat(np.arange(n), counts)
        if trial % 2:
            rel = rng.permutation(rel)
        rows = _rows._Rows(rel, n)
        order = rel[rows.perm]
        seen, r, ragged = np.zeros(n, bool), 0, False
        for r0, r1, nodes, d in rows.chunks:
            assert r0 == r and not seen[nodes].any()
            dd = np.full(nodes.shape[0], d) if isinstance(d, int) else d
            np.testing.assert_array_equal(np.repeat(nodes, dd), order[r0:r1])
            if isinstance(d, int):
                assert not ragged  # the ragged chunks last
            else:
                ragged = True
                assert (np.diff(nodes) > 0).all()
            seen[nodes], r = True, r1
        assert r == rel.shape[0] and (seen == (counts > 0)).all()
        for i in rng.integers(0, n, 5):
            np.testing.assert_array_equal(rows.perm[order == i], np.flatnonzero(rel == i))
    mesh = gen.random_delaunay(20000, seed=3)
    pts = tangled(mesh, seed=8).points
    out = []
    for merge in (0, 600, _rows._MERGE):
        _saved, _rows._MERGE = _rows._MERGE, merge
        try:
            topo = build_topology(mesh)  # (a fresh layout cache)
            floors = input_floors(np.array(mesh.points), topo)
            res, regular = [], 0
            for blk in topo.blocks():
                if not blk.size:
                    continue
                g = BlockGeometry(pts, topo, blk, floors=floors)
                regular += sum(isinstance(c[3], int) for c in g._t.chunks)
                cur = pts[topo.free_nodes[blk.nodes]]
                X = cur[None] + np.random.default_rng(blk.size).normal(scale=0.01 * np.ptp(pts), size=(3, blk.size, 2))
                res += [g.score(cur), g.score(X), *g.area_range(X), g.largest(X[0])]
            out.append((res, regular))
        finally:
            _rows._MERGE = _saved
    assert out[0][1] > out[1][1] > out[2][1]  # fewer regular chunks as more groups join the ragged ones
    for res, _ in out[1:]:
        for a, b in zip(out[0][0], res):
            np.testing.assert_array_equal(a, b)
    assert sum(int((a < -3).sum()) for a in out[0][0][1::5]) > 0  # some invalid candidates
