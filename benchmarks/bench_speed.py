"""Speed benchmark: topology set-up, time per pass, peak memory, end-to-end CLI.

Generates seeded meshes into a temporary directory (never committed), then runs
every case in its own subprocess so that the peak RSS of each case is its own:

* random Delaunay triangle meshes (10k, 100k, 1M triangles) and a jittered
  all-quad mesh (~250k quads);
* for every method of ``anglesmooth.smoothers.SMOOTHERS`` with the guard on,
  plus ``angle`` with the guard off: topology set-up time (``setup s``; the
  guarded passes' input floors, the rest of the driver's set-up, apart in ``floors``), median time per pass
  over ``--repeat`` passes, peak RSS, and the ratio to ``laplacian`` of the
  same mesh and run;
* a single ``np.bincount``-based Laplacian pass (the floor ``laplacian`` is
  compared with);
* with ``--kernels numpy,numba`` every method case runs with each kernel
  (``ANGLESMOOTH_KERNEL``); the default ``auto`` is what users get (numba from
  40k free nodes on, when installed).  ``jit s`` is the time to load (or, on
  the very first run, compile) the compiled kernels, paid once per process;
* the whole CLI (``anglesmooth in.msh out.vtu --passes 10``) beside meshio alone
  reading the same ``.msh`` and writing a zlib-compressed ``.vtu``, for a
  binary and an ASCII ``.msh`` (gmsh writes ASCII unless told otherwise), and
  ``anglesmooth check in.msh``: medians of ``--e2e-repeat`` runs, each in a
  fresh process (start-up included), with the peak RSS of the CLI process;
* where the end-to-end time goes: the CLI's stages (read, topology, quality
  summary, kernel load, passes, summary, write) timed in one process through
  the library, for the binary ``.msh`` (a second table);
* with ``--load N`` (default: one per core) the default ``angle`` pass again
  with each kernel while N busy-loop processes compete for the cores (numba
  with the automatic thread count and with one thread): a busy machine;
* cold and warm first run (``--cold-size``, default 200k triangles): the CLI
  with an empty kernel cache directory, then again with the filled one, and the
  first pass of the library alone in both states, with the compile (or load)
  time reported apart (a third table);
* issue 17's targets (end to end / meshio, set-up, peak RSS, cold - warm,
  compiled / numpy on a busy machine) beside what this run measured, with the
  distance to each (the last table, :mod:`speed_targets`).

Usage::

    PYTHONPATH=src python benchmarks/bench_speed.py                 # everything
    PYTHONPATH=src python benchmarks/bench_speed.py --sizes 100k,1M --repeat 5 --json out.json
    PYTHONPATH=src python benchmarks/bench_speed.py --kernels numpy,numba   # both kernels, every size
    PYTHONPATH=src python benchmarks/bench_speed.py --tiny          # seconds; what the test runs
    PYTHONPATH=src python benchmarks/bench_speed.py --sizes 1M --load 2 --cold-size 200k
    PYTHONPATH=src python benchmarks/bench_speed.py --targets-of out.json   # the targets table of a saved run

No number here is asserted anywhere: the benchmark prints, it does not judge.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from speed_targets import targets_table

SIZES = {"10k": ("tri", 10_000), "100k": ("tri", 100_000), "1M": ("tri", 1_000_000), "quad250k": ("quad", 250_000)}
EXTRA_SIZES = {"quad100k": ("quad", 100_000), "quad1M": ("quad", 1_000_000), "200k": ("tri", 200_000)}  # only when asked for: --sizes quad1M
TINY = {"tiny": ("tri", 2_000), "tinyquad": ("quad", 1_000)}
SRC = Path(__file__).resolve().parents[1] / "src"


# --------------------------------------------------------------------------- meshes



def _entry_points():
    """The module of the compiled kernels' entry points (``warm_up``, ``angle_choose``): ``_fastcalls``, or
    ``_fast`` in an older checkout given with ``--src``."""
    try:
        from anglesmooth.smoothers import _fastcalls
    except ImportError:
        from anglesmooth.smoothers import _fast as _fastcalls
    return _fastcalls

def make_mesh(kind: str, n_cells: int, seed: int = 0):
    """A Mesh2D from anglesmooth.generate, or a scipy-Delaunay fallback when that module is absent."""
    from anglesmooth.mesh import Mesh2D

    try:
        from anglesmooth import generate
    except ImportError:  # pragma: no cover - before generate.py existed
        generate = None
    if kind == "tri":
        if generate is not None and hasattr(generate, "random_delaunay"):
            return generate.random_delaunay(n_cells, seed)
        from scipy.spatial import Delaunay

        rng = np.random.default_rng(seed)
        m = max(1, round((n_cells / 2) ** 0.5))
        s = np.arange(m) / m
        side = np.concatenate([np.c_[s, 0 * s], np.c_[1 + 0 * s, s], np.c_[1 - s, 1 + 0 * s], np.c_[0 * s, 1 - s]])
        pts = np.concatenate([side, rng.uniform(0, 1, size=(max(1, (n_cells - 4 * m + 2) // 2), 2))])
        tri = Delaunay(pts).simplices
        a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
        cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
        tri[cw] = tri[cw][:, ::-1]
        return Mesh2D.from_arrays(pts, triangles=tri)
    if generate is not None and hasattr(generate, "random_quad_mesh"):
        return generate.random_quad_mesh(n_cells, seed)
    n = max(1, round(n_cells**0.5))
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    pts = np.c_[x.ravel(), y.ravel()]
    inner = (pts > 0).all(axis=1) & (pts < 1).all(axis=1)
    pts[inner] += rng.uniform(-0.24, 0.24, size=(int(inner.sum()), 2)) / n
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    v = (j * (n + 1) + i).ravel()
    return Mesh2D.from_arrays(pts, quads=np.c_[v, v + 1, v + n + 2, v + n + 1])


def write_inputs(name: str, kind: str, n_cells: int, tmp: Path) -> dict:
    """The meshes of one size, generated in a subprocess: a child process starts with its parent's
    peak RSS (Linux keeps it across fork and exec), so the driver itself must stay small."""
    info = _run_worker(["inputs", name, kind, str(n_cells), str(tmp)])
    if "error" in info:
        raise RuntimeError(f"generating {name}: {info['error']}")
    return info


def _write_inputs(name: str, kind: str, n_cells: int, tmp: Path) -> dict:
    mesh = make_mesh(kind, n_cells)
    npz = tmp / f"{name}.npz"
    np.savez(npz, points=mesh.points, triangles=mesh.triangles, quads=mesh.quads)
    msh = {"binary": tmp / f"{name}.msh", "ascii": tmp / f"{name}_ascii.msh"}
    try:
        import meshio

        cells = [(k, c) for k, c in (("triangle", mesh.triangles), ("quad", mesh.quads)) if c.shape[0]]
        pts3 = np.c_[mesh.points, np.zeros(mesh.n_points)]
        for enc, path in msh.items():
            meshio.write(path, meshio.Mesh(pts3, cells), file_format="gmsh", binary=enc == "binary")
    except Exception as exc:  # noqa: BLE001 - the CLI columns are optional
        print(f"(no .msh for {name}: {exc})", file=sys.stderr)
        msh = {}
    return {
        "name": name,
        "kind": kind,
        "npz": str(npz),
        "msh": {enc: str(path) for enc, path in msh.items()},
        "n_points": mesh.n_points,
        "n_cells": mesh.n_cells,
    }


# --------------------------------------------------------------------------- workers (one per subprocess)


def _peak_rss_mb() -> float:
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return kb / 1024.0 if sys.platform != "darwin" else kb / 2**20


def _busy_loops(n: int) -> list:
    """``n`` processes spinning on the CPU until killed: the competing load of ``--load``."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def _stop(procs: list) -> None:
    for p in procs:
        p.kill()
        p.wait()


def worker_method(npz: str, method: str, guard: bool, repeat: int, threads: int = 0, load: int = 0) -> dict:
    from anglesmooth.mesh import Mesh2D
    from anglesmooth.smoothers import SMOOTHERS, _fast
    from anglesmooth.smoothers._floors import input_floors
    from anglesmooth.topology import build_topology

    if threads:
        _fast.set_threads(threads)

    d = np.load(npz)
    mesh = Mesh2D.from_arrays(d["points"], triangles=d["triangles"], quads=d["quads"])
    t0 = time.perf_counter()
    topo = build_topology(mesh)
    topo.blocks()  # the per-colour slices, built once and cached
    setup = time.perf_counter() - t0
    kernel, jit = "numpy", None
    if _fast.active(topo):
        t0 = time.perf_counter()
        _entry_points().warm_up()  # load (or compile) the kernels: paid once per process, not per pass
        kernel, jit = "numba", time.perf_counter() - t0
    step = SMOOTHERS[method].step
    pts = np.array(mesh.points)
    # a guarded pass gets the input floors, as the driver (and so the CLI) gives them, computed once per run
    t0 = time.perf_counter()
    opts = {"floors": input_floors(pts, topo)} if guard else {}
    floors = time.perf_counter() - t0 if guard else None  # the rest of the driver's set-up
    times = []
    loaders = _busy_loops(load)
    try:
        time.sleep(0.3 if load else 0.0)  # let the load start
        cpu = []
        for _ in range(repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            pts = step(pts, topo, guard=guard, **opts).points
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
    finally:
        _stop(loaders)
    out = {"setup_s": setup, "floors_s": floors, "pass_s": statistics.median(times), "passes_s": times, "peak_rss_mb": _peak_rss_mb(),
           "pass_cpu_s": statistics.median(cpu),
           "kernel": kernel, "jit_s": jit, "load": load,
           "threads": (_fast.threads(max(b.nodes.stop - b.nodes.start for b in topo.blocks())) if kernel == "numba"
                       else 1)}
    if method == "laplacian" and guard is False:
        out["bincount_pass_s"] = _bincount_pass(mesh.points, topo, repeat)
    return out


#: the stages of a default ``angle`` pass that :func:`worker_breakdown` times (``choose (fused)``: the
#: compiled kernel that does stages 1-3 at once, so its parts cannot be told apart from outside)
BREAKDOWN = ("angle target", "geometry", "scoring", "stage 2", "stuck", "choose (fused)", "optimization",
             "block loop")


class _Timeline:
    """Time between labelled events: every :meth:`switch` charges the time since the last one to the
    label that was current, so the stages of a pass add up to the whole pass."""

    def __init__(self):
        self.acc = dict.fromkeys(BREAKDOWN, 0.0)
        self.label = "block loop"
        self.t = time.perf_counter()

    def switch(self, label: str) -> str:
        now = time.perf_counter()
        self.acc[self.label] += now - self.t
        self.t, old, self.label = now, self.label, label
        return old

    def wrap(self, fn, label: str, after: str | None = None):
        """``fn`` with its calls charged to ``label`` (then to ``after``, default: the label before)."""

        def timed(*args, **kwargs):
            old = self.switch(label)
            try:
                return fn(*args, **kwargs)
            finally:
                self.switch(after or old)

        return timed


def worker_breakdown(npz: str, repeat: int) -> dict:
    """Literal and default ``angle`` passes, and where the default pass's time goes, in one process.

    The functions ``angle.step`` calls are wrapped (in the namespaces of its modules) so that each stage's
    time is charged to it: ``angle target`` (the angle positions), ``geometry`` (gathering the fixed
    vertices of every incident cell of the block), ``scoring`` (the local score of the angle
    positions and the stage-1 acceptance), ``stage 2`` (the Laplacian position and the best of five
    for the nodes that were not accepted), ``stuck`` (stage 3), ``optimization`` (choosing the worst
    nodes and their compass search), ``choose (fused)`` (the compiled kernel doing stages 1-3 in one
    loop) and ``block loop`` (copying the points, gathering each block's current positions and
    scattering the new ones).  The wrappers cost a few microseconds per block.
    """
    from anglesmooth.mesh import Mesh2D
    from anglesmooth.smoothers import _fast
    from anglesmooth.smoothers import _choose, _worst
    from anglesmooth.smoothers import angle as angle_mod
    from anglesmooth.smoothers._floors import input_floors
    from anglesmooth.topology import build_topology

    d = np.load(npz)
    mesh = Mesh2D.from_arrays(d["points"], triangles=d["triangles"], quads=d["quads"])
    topo = build_topology(mesh)
    topo.blocks()
    kernel = "numba" if _fast.active(topo) else "numpy"
    if kernel == "numba":
        _entry_points().warm_up()
    pts0 = np.array(mesh.points)
    floors = input_floors(pts0, topo)

    def passes(**kw):
        pts, times = pts0.copy(), []
        step(pts, topo, **kw)  # first pass: per-block layouts cached, not timed
        for _ in range(repeat):
            t0 = time.perf_counter()
            pts = step(pts, topo, **kw).points
            times.append(time.perf_counter() - t0)
        return times

    step = angle_mod.step
    literal = passes(guard=False)
    default = passes(floors=floors)
    # the same default passes again, with every stage timed
    tl = _Timeline()
    # the modules of the pass (angle.step, stages 1-3 in _choose, stage 4 in _worst) that call each function
    homes = {"angle_target": (angle_mod, _choose), "geometry": (angle_mod,), "laplacian_target": (_choose,),
             "first_valid": (angle_mod, _choose), "local_scale": (_worst,), "optimize": (_worst,),
             "_per_node": (_choose, _worst), "run_blocks": (angle_mod,), "np": (angle_mod, _choose, _worst)}
    saved = {k: getattr(mods[0], k) for k, mods in homes.items()}
    calls_mod = _entry_points()
    saved_choose = calls_mod.angle_choose
    calls = {"per_node": 0}

    def per_node(*args):
        calls["per_node"] += 1  # first call: stage 1's acceptance threshold; second: the optimization's
        tl.switch("scoring" if calls["per_node"] % 2 else "optimization")
        return saved["_per_node"](*args)

    class _NumpyProxy:  # the modules' np with argpartition (the choice of the worst nodes) charged to optimization
        def __getattr__(self, name):
            return getattr(np, name)

        @staticmethod
        def argpartition(*args, **kwargs):
            tl.switch("optimization")
            return np.argpartition(*args, **kwargs)

    def run_blocks(points, topo_, order, update, **kw):  # (kw: run_blocks' options, e.g. current)
        def timed_update(*args):
            calls["per_node"] = 0
            tl.switch("scoring")
            try:
                return update(*args)
            finally:
                tl.switch("block loop")

        return saved["run_blocks"](points, topo_, order, timed_update, **kw)

    patched = {
        "angle_target": tl.wrap(saved["angle_target"], "angle target"),
        "geometry": tl.wrap(saved["geometry"], "geometry"),
        "laplacian_target": tl.wrap(saved["laplacian_target"], "stage 2", "stage 2"),
        "first_valid": tl.wrap(saved["first_valid"], "stuck", "stuck"),
        "local_scale": tl.wrap(saved["local_scale"], "optimization"),
        "optimize": tl.wrap(saved["optimize"], "optimization"),
        "_per_node": per_node,
        "run_blocks": run_blocks,
        "np": _NumpyProxy(),
    }
    try:
        for k, v in patched.items():
            for m in homes[k]:
                setattr(m, k, v)
        calls_mod.angle_choose = tl.wrap(saved_choose, "choose (fused)")
        staged = []
        pts = pts0.copy()
        step(pts, topo, floors=floors)
        per_pass = []
        for _ in range(repeat):
            tl.switch("block loop")
            before = dict(tl.acc)
            t0 = time.perf_counter()
            pts = step(pts, topo, floors=floors).points
            tl.switch("block loop")
            staged.append(time.perf_counter() - t0)
            per_pass.append({k: tl.acc[k] - before[k] for k in BREAKDOWN})
    finally:
        for k, v in saved.items():
            for m in homes[k]:
                setattr(m, k, v)
        calls_mod.angle_choose = saved_choose
    stages = {k: statistics.median(p[k] for p in per_pass) for k in BREAKDOWN}
    lit, dflt = statistics.median(literal), statistics.median(default)
    return {"kernel": kernel, "literal_s": lit, "default_s": dflt, "ratio": dflt / lit, "staged_s":
            statistics.median(staged), "stages_s": stages, "floors_active": bool(floors.active),
            "peak_rss_mb": _peak_rss_mb()}


def _bincount_pass(points: np.ndarray, topo, repeat: int) -> float:
    """One Jacobi Laplacian pass over all nodes with two np.bincount calls (the floor)."""
    src = np.repeat(np.arange(topo.n_points), np.diff(topo.ring_offsets))
    nbr = topo.ring_indices
    deg = np.maximum(np.diff(topo.ring_offsets), 1)
    times = []
    for _ in range(max(repeat, 3)):
        t0 = time.perf_counter()
        nb = np.take(points, nbr, axis=0)
        new = np.empty_like(points)
        new[:, 0] = np.bincount(src, weights=nb[:, 0], minlength=topo.n_points) / deg
        new[:, 1] = np.bincount(src, weights=nb[:, 1], minlength=topo.n_points) / deg
        new[topo.fixed] = points[topo.fixed]
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def worker_meshio(msh: str, out: str) -> dict:
    import meshio

    t0 = time.perf_counter()
    m = meshio.read(msh)
    t1 = time.perf_counter()
    meshio.write(out, m, file_format="vtu", compression="zlib")
    t2 = time.perf_counter()
    return {"read_s": t1 - t0, "write_s": t2 - t1, "total_s": t2 - t0, "peak_rss_mb": _peak_rss_mb()}


def worker_first(npz: str) -> dict:
    """The first default ``angle`` pass of a process (the kernels compile or load in it), the second,
    and the compile / load time counted by ``_fast.jit_stats`` (the cache directory is the caller's)."""
    from anglesmooth.mesh import Mesh2D
    from anglesmooth.smoothers import SMOOTHERS, _fast
    from anglesmooth.topology import build_topology

    d = np.load(npz)
    mesh = Mesh2D.from_arrays(d["points"], triangles=d["triangles"], quads=d["quads"])
    topo = build_topology(mesh)
    cold = _fast.cold_kernels(_fast.METHOD_KERNELS["angle"]) if _fast.active(topo) else []
    pts, times = np.array(mesh.points), []
    for _ in range(2):
        t0 = time.perf_counter()
        pts = SMOOTHERS["angle"].step(pts, topo).points
        times.append(time.perf_counter() - t0)
    st = _fast.jit_stats()
    return {"pass1_s": times[0], "pass2_s": times[1], "compile_s": st["compile_s"], "load_s": st["load_s"],
            "cold_kernels": cold, "kernel": "numba" if _fast.active(topo) else "numpy", "peak_rss_mb": _peak_rss_mb()}


STAGES = ("import", "read", "topology", "summary", "passes", "summary2", "write")


def worker_stages(msh: str, out: str, passes: int = 10) -> dict:
    """The CLI's smoothing path through the library, each stage timed (one process, defaults: ``angle``).

    As in the CLI, the first pass also loads the compiled kernels (numba) when they run; its time is
    reported apart (``pass1_s``) beside the median of the other passes (``pass_s``).
    """
    t = [time.perf_counter()]
    from anglesmooth import io as mesh_io
    from anglesmooth.driver import smooth
    from anglesmooth.quality import summarize
    from anglesmooth.smoothers import _fast
    from anglesmooth.topology import build_topology

    t.append(time.perf_counter())
    mesh = mesh_io.read(msh)
    t.append(time.perf_counter())
    topo = build_topology(mesh)
    t.append(time.perf_counter())
    summarize(mesh.points, topo)
    t.append(time.perf_counter())
    ends = [t[-1]]
    result = smooth(mesh, "angle", passes, topology=topo, callback=lambda k, p, d: ends.append(time.perf_counter()))
    t.append(time.perf_counter())
    summarize(result.points, topo)
    t.append(time.perf_counter())
    mesh_io.write(mesh, out, points=result.points)
    t.append(time.perf_counter())
    per_pass = [b - a for a, b in zip(ends, ends[1:])]
    out_d = {f"{k}_s": b - a for k, a, b in zip(STAGES, t, t[1:])}
    out_d.update(total_s=t[-1] - t[0], pass1_s=per_pass[0] if per_pass else None,
                 pass_s=statistics.median(per_pass[1:]) if len(per_pass) > 1 else None,
                 kernel="numba" if _fast.active(topo) else "numpy", peak_rss_mb=_peak_rss_mb())
    return out_d


def _run_worker(args: list[str], kernel: str | None = None, cache: str | None = None) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    if kernel is not None:
        env["ANGLESMOOTH_KERNEL"] = kernel
    if cache is not None:
        env.pop("NUMBA_CACHE_DIR", None)
        env["ANGLESMOOTH_CACHE_DIR"] = cache
    res = subprocess.run([sys.executable, __file__, "--worker", *args], capture_output=True, text=True, env=env)
    if res.returncode != 0:
        return {"error": (res.stderr.strip().splitlines() or ["failed"])[-1]}
    return json.loads(res.stdout.strip().splitlines()[-1])


def _cli_available() -> bool:
    try:
        import anglesmooth.cli  # noqa: F401
    except Exception:  # noqa: BLE001
        return False
    return True


def _run_timed(cmd: list[str], env: dict) -> tuple[float, int, float]:
    """Wall time, exit code and peak RSS (MB) of one child process (``wait4``: that child's own rusage)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    return wall, proc.returncode, usage.ru_maxrss / 1024.0


def run_cli(args: list[str], repeat: int = 1, cache: str | None = None) -> dict:
    """``python -m anglesmooth ARGS`` ``repeat`` times in fresh processes: median wall time, largest peak RSS."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), env.get("PYTHONPATH", "")])
    if cache is not None:
        env.pop("NUMBA_CACHE_DIR", None)
        env["ANGLESMOOTH_CACHE_DIR"] = cache
    runs = [_run_timed([sys.executable, "-m", "anglesmooth", *args], env) for _ in range(max(1, repeat))]
    codes = {rc for _, rc, _ in runs}
    return {"total_s": statistics.median(w for w, _, _ in runs), "runs_s": [w for w, _, _ in runs],
            "returncode": max(codes, key=abs), "peak_rss_mb": max(r for _, _, r in runs)}


# --------------------------------------------------------------------------- driver


def cases(methods: tuple[str, ...] | None = None) -> list[tuple[str, bool]]:
    from anglesmooth.smoothers import SMOOTHERS

    out = [(m, True) for m in SMOOTHERS] + [("angle", False), ("laplacian", False)]
    return [c for c in out if methods is None or c[0] in methods]


def run_cold(name: str, kind: str, n_cells: int, tmp: Path, cli: bool) -> list[dict]:
    """Cold (empty kernel cache directory) and warm (the same directory, filled) first runs."""
    import shutil

    info = write_inputs(name, kind, n_cells, tmp)
    cache = str(tmp / "kernel-cache")
    rows = []
    common = {"mesh": name, "cells": info["n_cells"], "nodes": info["n_points"]}
    for state in ("cold", "warm"):
        if state == "cold":
            shutil.rmtree(cache, ignore_errors=True)
        r = _run_worker(["first", info["npz"]], cache=cache)
        rows.append({**common, "method": f"first pass ({state})", "guard": True, "state": state, **r})
    if cli and info["msh"]:
        for state in ("cold", "warm"):
            if state == "cold":
                shutil.rmtree(cache, ignore_errors=True)
            report = tmp / f"{name}_{state}.json"
            c = run_cli([info["msh"]["binary"], str(tmp / f"{name}_cold.vtu"), "--passes", "10", "--json",
                         str(report)], cache=cache)
            doc = json.loads(report.read_text()) if report.exists() else {}
            rows.append({**common, "method": f"CLI ({state} cache)", "guard": True, "state": state,
                         "e2e_s": c["total_s"], "returncode": c["returncode"], "peak_rss_mb": c["peak_rss_mb"],
                         "compile_s": doc.get("compile_s"), "elapsed_s": doc.get("elapsed_s")})
    shutil.rmtree(cache, ignore_errors=True)
    for p in tmp.glob(f"{name}*"):
        p.unlink()
    return rows


def run(sizes: dict, repeat: int, cli: bool, tmp: Path, slow_repeat: int | None = None,
        kernels: tuple[str, ...] = ("auto",), e2e_repeat: int = 3, load: int = 0,
        methods: tuple[str, ...] | None = None, breakdown: bool = True) -> list[dict]:
    rows = []
    for name, (kind, n_cells) in sizes.items():
        info = write_inputs(name, kind, n_cells, tmp)
        print(f"# {name}: {info['n_cells']} cells, {info['n_points']} nodes", file=sys.stderr, flush=True)
        for kernel in kernels:
            results = {}
            for method, guard in cases(methods):
                rep = repeat
                if method == "optimization" and slow_repeat is not None:
                    rep = slow_repeat
                r = _run_worker(["method", info["npz"], method, str(int(guard)), str(rep)], kernel)
                results[(method, guard)] = r
                print(f"#   {kernel:5s} {method:16s} guard={guard!s:5s} {r.get('pass_s', float('nan')):8.3f} s/pass",
                      file=sys.stderr, flush=True)
            if load and kernel in ("auto", "numba"):  # the same default pass on a busy machine
                for threads in (0, 1):
                    r = _run_worker(["method", info["npz"], "angle", "1", str(repeat), str(threads), str(load)],
                                    kernel)
                    results[("angle", True, "load", threads)] = r
                    print(f"#   {kernel:5s} angle load={load} threads={r.get('threads')} "
                          f"{r.get('pass_s', float('nan')):8.3f} s/pass", file=sys.stderr, flush=True)
            if load and kernel in ("auto", "numpy"):
                r = _run_worker(["method", info["npz"], "angle", "1", str(repeat), "0", str(load)], "numpy")
                results[("angle", True, "load", "numpy")] = r
            lap = results.get(("laplacian", True), {}).get("pass_s")
            floor = results.get(("laplacian", False), {}).get("bincount_pass_s")
            literal = results.get(("angle", False), {}).get("pass_s")
            for (method, guard, *loaded), r in results.items():
                row = {"mesh": name, "cells": info["n_cells"], "nodes": info["n_points"],
                       "method": f"{method} (loaded)" if loaded else method, "guard": guard}
                if loaded:
                    row["threads_asked"] = loaded[1] if loaded[1] != "numpy" else 0
                row.update({k: v for k, v in r.items() if k != "passes_s"})
                if lap and "pass_s" in r:
                    row["ratio_to_laplacian"] = r["pass_s"] / lap
                if floor and "pass_s" in r:
                    row["ratio_to_bincount"] = r["pass_s"] / floor
                if literal and "pass_s" in r:
                    row["ratio_to_literal"] = r["pass_s"] / literal
                rows.append(row)
            if breakdown:
                r = _run_worker(["breakdown", info["npz"], str(repeat)], kernel)
                rows.append({"mesh": name, "cells": info["n_cells"], "nodes": info["n_points"], "kind": kind,
                             "method": "breakdown", "guard": True, **r})
                print(f"#   {kernel:5s} breakdown: default/literal {r.get('ratio', float('nan')):.2f}",
                      file=sys.stderr, flush=True)
        for enc, msh in info["msh"].items() if cli else ():
            common = {"mesh": name, "cells": info["n_cells"], "nodes": info["n_points"], "msh": enc}
            meshio_runs = [_run_worker(["meshio", msh, str(tmp / f"{name}_meshio.vtu")]) for _ in range(e2e_repeat)]
            ok = [r for r in meshio_runs if "error" not in r]
            m = {k: statistics.median(r[k] for r in ok) for k in ("total_s", "read_s", "write_s")} if ok else {}
            c = run_cli([msh, str(tmp / f"{name}_cli.vtu"), "--passes", "10"], e2e_repeat)
            chk = run_cli(["check", msh], e2e_repeat)
            rows.append({**common, "method": f"meshio ({enc} msh)", "guard": None, "e2e_s": m.get("total_s"),
                         "read_s": m.get("read_s"), "write_s": m.get("write_s"),
                         "peak_rss_mb": max((r["peak_rss_mb"] for r in ok), default=None)})
            ratio = c["total_s"] / m["total_s"] if m.get("total_s") else None
            rows.append({**common, "method": f"CLI ({enc} msh)", "guard": True, "e2e_s": c["total_s"],
                         "runs_s": c["runs_s"], "ratio_to_meshio": ratio, "returncode": c["returncode"],
                         "peak_rss_mb": c["peak_rss_mb"]})
            rows.append({**common, "method": f"CLI check ({enc} msh)", "guard": None, "e2e_s": chk["total_s"],
                         "runs_s": chk["runs_s"], "returncode": chk["returncode"], "peak_rss_mb": chk["peak_rss_mb"]})
            if enc == "binary":
                st = _run_worker(["stages", msh, str(tmp / f"{name}_stages.vtu")])
                rows.append({**common, "method": "stages", "guard": True, **st})
        for p in tmp.glob(f"{name}*"):
            p.unlink()
    return rows


def _fmt(v, spec):
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return format(v, spec)
    return "-".rjust(int(spec.split(".")[0].rstrip("dfs")))


def table(rows: list[dict]) -> str:
    head = (f"{'mesh':>9} {'cells':>9} {'method':<22} {'guard':<5} {'kernel':<6} {'thr':>3} {'load':>4} "
            f"{'setup s':>8} {'floors':>6} {'jit s':>6} "
            f"{'s/pass':>8} {'cpu s':>6} {'x lap':>6} {'x lit':>6} {'x bincnt':>8} {'e2e s':>7} {'x meshio':>8} "
            f"{'RSS MB':>7}")
    lines = [head, "-" * len(head)]
    for r in rows:
        guard = "" if r.get("guard") is None else ("on" if r["guard"] else "off")
        kernel = r.get("kernel", "")
        if "error" in r:
            lines.append(f"{r['mesh']:>9} {r['cells']:>9} {r['method']:<22} {guard:<5} {kernel:<6} error: {r['error']}")
            continue
        lines.append(
            f"{r['mesh']:>9} {r['cells']:>9} {r['method']:<22} {guard:<5} {kernel:<6} {_fmt(r.get('threads'), '3d')} "
            f"{_fmt(r.get('load'), '4d')} {_fmt(r.get('setup_s'), '8.2f')} "
            f"{_fmt(r.get('floors_s'), '6.2f')} {_fmt(r.get('jit_s'), '6.2f')} {_fmt(r.get('pass_s'), '8.3f')} {_fmt(r.get('pass_cpu_s'), '6.3f')} "
            f"{_fmt(r.get('ratio_to_laplacian'), '6.2f')} {_fmt(r.get('ratio_to_literal'), '6.2f')} "
            f"{_fmt(r.get('ratio_to_bincount'), '8.1f')} {_fmt(r.get('e2e_s'), '7.2f')} "
            f"{_fmt(r.get('ratio_to_meshio'), '8.2f')} {_fmt(r.get('peak_rss_mb'), '7.0f')}"
        )
    return "\n".join(lines)


def stage_table(rows: list[dict]) -> str:
    """Where the end-to-end time goes: one line per mesh, the CLI's stages in seconds."""
    cols = ("import", "read", "topology", "summary", "passes", "pass1", "pass", "summary2", "write", "total")
    head = f"{'mesh':>9} {'kernel':<6} " + " ".join(f"{c:>8}" for c in cols) + f" {'meshio':>8} {'RSS MB':>7}"
    lines = ["stages of 'anglesmooth in.msh out.vtu' (binary .msh, 10 default passes) in one process, seconds;",
             "pass1 = first pass (loads the compiled kernels), pass = median of the others, meshio = its read+write",
             head, "-" * len(head)]
    meshio = {r["mesh"]: r.get("e2e_s") for r in rows if r["method"] == "meshio (binary msh)"}
    for r in rows:
        if r["method"] != "stages":
            continue
        if "error" in r:
            lines.append(f"{r['mesh']:>9} error: {r['error']}")
            continue
        vals = " ".join(_fmt(r.get(f"{c}_s"), "8.3f") for c in cols)
        lines.append(f"{r['mesh']:>9} {r.get('kernel', ''):<6} {vals} {_fmt(meshio.get(r['mesh']), '8.3f')} "
                     f"{_fmt(r.get('peak_rss_mb'), '7.0f')}")
    return "\n".join(lines)


def breakdown_table(rows: list[dict]) -> str:
    """Default ``angle`` pass / literal pass (``guard=False``) per mesh and kernel, and where the default's time goes."""
    short = {"angle target": "target", "geometry": "geom", "scoring": "score", "stage 2": "stage2", "stuck": "stuck",
             "choose (fused)": "fused", "optimization": "optim", "block loop": "loop"}
    head = (f"{'mesh':>9} {'cells':>9} {'kernel':<6} {'literal s':>9} {'default s':>9} {'x lit':>6} | "
            + " ".join(f"{short[k]:>7}" for k in BREAKDOWN) + " (ms; % of the staged pass)")
    lines = ["default angle pass (input floors as the driver gives them) / literal pass (guard=False), medians of one",
             "run; then where a default pass goes: target = angle positions, geom = gathering the blocks' cells,",
             "score = score of the angle positions + stage-1 acceptance, stage2 = Laplacian + best of five, stuck =",
             "stage 3, fused = the compiled stages 1-3 (angle_choose), optim = worst-node choice + compass search,",
             "loop = block loop (copy, gather, scatter)", head, "-" * len(head)]
    for r in rows:
        if r["method"] != "breakdown":
            continue
        if "error" in r:
            lines.append(f"{r['mesh']:>9} {r['cells']:>9} error: {r['error']}")
            continue
        st = r["stages_s"]
        tot = sum(st.values()) or 1.0
        parts = " ".join(f"{1e3 * st[k]:7.1f}" if st[k] else f"{'-':>7}" for k in BREAKDOWN)
        pct = " ".join(f"{100 * st[k] / tot:6.0f}%" if st[k] else f"{'':>7}" for k in BREAKDOWN)
        lines.append(f"{r['mesh']:>9} {r['cells']:>9} {r.get('kernel', ''):<6} {_fmt(r.get('literal_s'), '9.3f')} "
                     f"{_fmt(r.get('default_s'), '9.3f')} {_fmt(r.get('ratio'), '6.2f')} | {parts}")
        lines.append(f"{'':>9} {'':>9} {'':<6} {'':>9} {'':>9} {'':>6} | {pct}")
    return "\n".join(lines)


def cold_table(rows: list[dict]) -> str:
    """Cold (empty kernel cache) and warm first runs: the library's first and second pass, the CLI."""
    head = (f"{'mesh':>9} {'case':<20} {'kernel':<6} {'pass1 s':>8} {'pass2 s':>8} {'compile s':>9} {'load s':>7} "
            f"{'e2e s':>7} {'CLI compile_s':>13} {'RSS MB':>7}")
    lines = ["cold = empty kernel cache directory, warm = the same directory filled by the cold run",
             head, "-" * len(head)]
    for r in rows:
        if "state" not in r:
            continue
        if "error" in r:
            lines.append(f"{r['mesh']:>9} {r['method']:<20} error: {r['error']}")
            continue
        lines.append(f"{r['mesh']:>9} {r['method']:<20} {r.get('kernel', ''):<6} {_fmt(r.get('pass1_s'), '8.3f')} "
                     f"{_fmt(r.get('pass2_s'), '8.3f')} {_fmt(r.get('compile_s') if 'pass1_s' in r else None, '9.2f')} "
                     f"{_fmt(r.get('load_s'), '7.2f')} {_fmt(r.get('e2e_s'), '7.2f')} "
                     f"{_fmt(r.get('compile_s') if 'e2e_s' in r else None, '13.2f')} {_fmt(r.get('peak_rss_mb'), '7.0f')}")
    return "\n".join(lines)


def _numba_version() -> str | None:
    try:
        import numba
    except ImportError:
        return None
    return numba.__version__


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--worker"]:
        kind, *rest = argv[1:]
        if kind == "method":
            npz, method, guard, rep, *more = rest
            out = worker_method(npz, method, bool(int(guard)), int(rep), *map(int, more))
        elif kind == "first":
            out = worker_first(*rest)
        elif kind == "inputs":
            name, mesh_kind, n_cells, tmp = rest
            out = _write_inputs(name, mesh_kind, int(n_cells), Path(tmp))
        elif kind == "stages":
            out = worker_stages(*rest)
        elif kind == "breakdown":
            out = worker_breakdown(rest[0], int(rest[1]))
        else:
            out = worker_meshio(*rest)
        print(json.dumps(out))
        return 0
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=",".join(SIZES),
                    help=f"comma-separated subset of {','.join(SIZES)} (default: all), or {','.join(EXTRA_SIZES)}")
    ap.add_argument("--repeat", type=int, default=5, help="passes timed per case (median reported)")
    ap.add_argument("--slow-repeat", type=int, default=None, help="passes for 'optimization' (default: --repeat)")
    ap.add_argument("--no-cli", action="store_true", help="skip the end-to-end CLI and meshio columns")
    ap.add_argument("--e2e-repeat", type=int, default=3,
                    help="fresh-process runs of each end-to-end command (median reported)")
    ap.add_argument("--tiny", action="store_true", help="tiny meshes, 2 passes (for the test suite)")
    ap.add_argument("--kernels", default="auto",
                    help="comma-separated ANGLESMOOTH_KERNEL values to run every method with (auto, numpy, numba)")
    ap.add_argument("--load", type=int, default=None, metavar="N",
                    help="busy-loop processes competing with the loaded cases (default: one per core; 0: none)")
    ap.add_argument("--cold-size", default="200k", metavar="SIZE",
                    help="mesh of the cold / warm first-run cases (a size name, or 'none')")
    ap.add_argument("--methods", default=None, metavar="M,...",
                    help="only these methods (e.g. 'angle': its default and literal pass); default: all")
    ap.add_argument("--no-breakdown", action="store_true",
                    help="skip the default/literal ratio and per-stage breakdown of the default angle pass")
    ap.add_argument("--src", metavar="DIR", default=None,
                    help="run the workers with the package in DIR (e.g. another checkout's src/: a before/after "
                         "comparison with the same harness); default: this checkout's src/")
    ap.add_argument("--json", metavar="PATH", help="also write the rows as JSON")
    ap.add_argument("--targets-of", metavar="PATH", help="only print the targets table of a run saved with --json")
    args = ap.parse_args(argv)
    if args.targets_of:
        print(targets_table(json.loads(Path(args.targets_of).read_text())["rows"]))
        return 0
    global SRC
    if args.src:
        SRC = Path(args.src).resolve()
    load = (os.cpu_count() or 1) if args.load is None else args.load
    cold = None if args.cold_size == "none" else args.cold_size
    if args.tiny:
        sizes, repeat, args.e2e_repeat, load = TINY, 2, 1, min(load, 1)
        cold = "tiny" if cold else None
    else:
        known = {**SIZES, **EXTRA_SIZES}
        unknown = [s for s in args.sizes.split(",") if s not in known]
        if unknown:
            ap.error(f"unknown size(s) {unknown}; choose from {','.join(known)}")
        sizes, repeat = {s: known[s] for s in args.sizes.split(",")}, args.repeat
    cli = not args.no_cli and _cli_available()
    t0 = time.perf_counter()
    la0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="anglesmooth-bench-") as tmp:
        methods = tuple(args.methods.split(",")) if args.methods else None
        rows = run(sizes, repeat, cli, Path(tmp), args.slow_repeat, tuple(args.kernels.split(",")),
                   args.e2e_repeat, load, methods, not args.no_breakdown)
        if cold:
            kind, n_cells = {**SIZES, **EXTRA_SIZES, **TINY}[cold]
            print(f"# cold / warm first run: {cold}", file=sys.stderr, flush=True)
            rows += run_cold(cold, kind, n_cells, Path(tmp), cli)
    print(table([r for r in rows if r["method"] not in ("stages", "breakdown") and "state" not in r]))
    if any(r["method"] == "breakdown" for r in rows):
        print()
        print(breakdown_table(rows))
    if any(r["method"] == "stages" for r in rows):
        print()
        print(stage_table(rows))
    if any("state" in r for r in rows):
        print()
        print(cold_table(rows))
    print()
    print(targets_table(rows))
    meta = {
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "numba": _numba_version(),
        "cpus": os.cpu_count(),
        "load": load,
        "repeat": repeat,
        "e2e_repeat": args.e2e_repeat,
        "wall_s": time.perf_counter() - t0,
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "src": str(SRC),
        "loadavg_start": la0,
        "loadavg_end": os.getloadavg(),
    }
    print(f"\nmachine: {os.cpu_count()} cpus, load average (1, 5, 15 min) at start "
          f"{', '.join(f'{v:.2f}' for v in la0)}, at end {', '.join(f'{v:.2f}' for v in meta['loadavg_end'])}; "
          f"package from {SRC}")
    if args.json:
        Path(args.json).write_text(json.dumps({"meta": meta, "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(SRC))
    sys.exit(main())
