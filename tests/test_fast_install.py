"""The fast install: numba as a dependency (numpy where it is missing), the kernel cache, threads.

The subprocess tests run the package from this checkout (``PYTHONPATH``) with their own cache
directory, so they see a cold cache whatever ran before.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from anglesmooth import generate as gen
from anglesmooth.smoothers import SMOOTHERS, _fast, _jitcache
from anglesmooth.topology import build_topology

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"


def _env(tmp_path: Path, src: Path = SRC, **extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "ANGLESMOOTH_KERNEL")}
    env.update(PYTHONPATH=os.pathsep.join([str(src), os.environ.get("PYTHONPATH", "")]),
               ANGLESMOOTH_CACHE_DIR=str(tmp_path / "cache"), **extra)
    return env


def _py(code: str, env: dict, cwd: Path) -> subprocess.CompletedProcess:
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=cwd, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    return res


def test_numba_is_a_dependency_where_it_has_wheels_and_fast_stays_an_alias():
    tomllib = pytest.importorskip("tomllib", reason="Python < 3.11 has no tomllib; CI runs 3.11+")
    from packaging.requirements import Requirement

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    numba_reqs = [Requirement(r) for r in project["dependencies"] if Requirement(r).name == "numba"]
    assert numba_reqs and all(r.marker is not None for r in numba_reqs)

    def wanted(**env):
        base = {"platform_python_implementation": "CPython", "python_version": "3.12", "sys_platform": "linux",
                "platform_machine": "x86_64"}
        return any(r.marker.evaluate({**base, **env}) for r in numba_reqs)

    assert wanted() and wanted(platform_machine="aarch64") and wanted(sys_platform="win32", platform_machine="AMD64")
    assert wanted(sys_platform="darwin", platform_machine="arm64")
    assert wanted(sys_platform="darwin", platform_machine="x86_64", python_version="3.13")
    assert not wanted(sys_platform="darwin", platform_machine="x86_64", python_version="3.14")  # no wheels
    assert not wanted(platform_python_implementation="PyPy") and not wanted(platform_machine="i686")
    assert not wanted(python_version="3.16") and not wanted(sys_platform="freebsd14")
    assert any(r.marker.evaluate() for r in numba_reqs)  # this machine gets numba from `pip install .`
    assert project["optional-dependencies"]["fast"] == ["numba>=0.59"]


def test_without_numba_the_numpy_kernels_run_with_the_same_numbers(tmp_path):
    """numba's import blocked (as where it cannot be installed): ``auto`` falls back to numpy, the
    CLI works and gives the numpy kernels' exact result; ``ANGLESMOOTH_KERNEL=numba`` is a usage error."""
    mesh_file = tmp_path / "in.vtu"
    code = (
        "import sys\n"
        "sys.modules['numba'] = None  # import numba -> ImportError\n"
        "import numpy as np, meshio\n"
        "from anglesmooth import generate as gen, smooth\n"
        "from anglesmooth.smoothers import _fast\n"
        "from anglesmooth.topology import build_topology\n"
        "m = gen.random_delaunay(3000, 1)\n"
        f"meshio.write({str(mesh_file)!r}, meshio.Mesh(np.c_[m.points, 0 * m.points[:, 0]], [('triangle', m.triangles)]))\n"
        "_fast.AUTO_MIN_FREE = 10\n"
        "topo = build_topology(m)\n"
        "assert not _fast.active(topo) and _fast.would_help(topo)\n"
        "np.save('auto.npy', smooth(m, 'angle', 3).points)\n"
        "from anglesmooth.cli import main\n"
        "sys.argv = ['anglesmooth', 'in.vtu', 'out.vtu', '--passes', '3']\n"
        "try:\n"
        "    main()\n"
        "except SystemExit as e:\n"
        "    assert not e.code, e.code\n"
        "import os\n"
        "from anglesmooth.errors import ConfigurationError\n"
        "os.environ['ANGLESMOOTH_KERNEL'] = 'numba'\n"
        "try:\n"
        "    _fast.kernel_mode()\n"
        "except ConfigurationError as e:\n"
        "    assert 'not installed' in str(e)\n"
        "else:\n"
        "    raise AssertionError('numba asked for without numba')\n"
        "print('numba' in sys.modules and sys.modules['numba'] is not None)\n"
    )
    res = _py(code, _env(tmp_path), tmp_path)
    assert res.stdout.split() == ["False"]
    assert "pip install 'anglesmooth[fast]'" in res.stderr  # the CLI says what it would gain
    import meshio

    from anglesmooth import smooth

    os.environ.pop("ANGLESMOOTH_KERNEL", None)
    m = gen.random_delaunay(3000, 1)
    ref = smooth(m, "angle", 3).points  # this process: numpy (a small mesh under auto)
    np.testing.assert_array_equal(np.load(tmp_path / "auto.npy"), ref)
    np.testing.assert_array_equal(meshio.read(tmp_path / "out.vtu").points[:, :2], ref)


def test_kernels_cache_in_the_user_cache_dir_not_in_a_read_only_package(tmp_path):
    """The package copied to a read-only directory (as site-packages in a container): the first run
    compiles into the cache directory and says so on stderr (not a terminal here), the second loads
    from it and says nothing; the package directory gets no cache file; JSON has compile_s apart."""
    pkg_root = tmp_path / "site"
    shutil.copytree(SRC / "anglesmooth", pkg_root / "anglesmooth", ignore=shutil.ignore_patterns("__pycache__"))
    for p in sorted(pkg_root.rglob("*"), reverse=True):
        p.chmod(p.stat().st_mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    mesh_file = tmp_path / "in.vtu"
    m = gen.random_delaunay(2000, 2)
    import meshio

    meshio.write(mesh_file, meshio.Mesh(np.c_[m.points, 0 * m.points[:, 0]], [("triangle", m.triangles)]))
    env = _env(tmp_path, src=pkg_root, ANGLESMOOTH_KERNEL="numba")
    try:
        runs = []
        for k in range(2):
            res = subprocess.run([sys.executable, "-m", "anglesmooth", "in.vtu", f"out{k}.vtu", "-m", "laplacian",
                                  "--passes", "2", "--json", f"r{k}.json"], capture_output=True, text=True, env=env,
                                 cwd=tmp_path, timeout=600)
            assert res.returncode == 0, res.stderr[-3000:]
            runs.append((res.stderr, json.loads((tmp_path / f"r{k}.json").read_text())))
        cached = sorted(p.name for p in (tmp_path / "cache").rglob("*.nbi"))
        in_package = [p for p in pkg_root.rglob("*") if p.suffix in (".nbi", ".nbc")]
    finally:
        for p in pkg_root.rglob("*"):
            p.chmod(p.stat().st_mode | stat.S_IWUSR)
    assert cached, "nothing cached"
    assert in_package == []
    (err0, doc0), (err1, doc1) = runs
    assert "compiling kernels once, about" in err0 and "compiling kernels once" not in err1
    assert doc0["compile_s"] > 0 and doc1["compile_s"] >= 0
    assert doc0["compile_s"] > doc1["compile_s"]  # compiling vs loading: not a timing assertion on speed, on kind
    assert doc0["elapsed_s"] >= 0 and doc0["passes"] == 2


def test_jit_stats_tell_compiled_from_loaded(tmp_path):
    code = (
        "import json\n"
        "from anglesmooth import generate as gen, smooth\n"
        "from anglesmooth.smoothers import _fast\n"
        "cold = _fast.cold_kernels()\n"
        "r = smooth(gen.paper_quad_mesh(0), 'laplacian', passes=1)\n"
        "s = _fast.jit_stats()\n"
        "print(json.dumps([cold, s['compiled'], s['loaded'], abs(r.compile_s - s['compile_s'] - s['load_s']) < 1e-9,"
        " _fast.cold_kernels(s['compiled'] + s['loaded'])]))\n"
    )
    env = _env(tmp_path, ANGLESMOOTH_KERNEL="numba")
    cold, compiled, loaded, same, after = json.loads(_py(code, env, tmp_path).stdout)
    assert compiled and loaded == [] and set(compiled) <= set(cold) and same and after == []
    cold2, compiled2, loaded2, same2, _ = json.loads(_py(code, env, tmp_path).stdout)
    assert compiled2 == [] and sorted(loaded2) == sorted(compiled) and same2  # the second process loads them
    assert not set(compiled) & set(cold2)
    assert set(compiled) < set(_fast.COMPILE_S)  # only what laplacian calls, not every kernel


def test_stage_5_screen_compile_is_timed_apart(tmp_path):
    # the default angle's stage-5 screen kernel (_patchkernels._screen_below) compiles through _fast, so its
    # compile is in compile_s (and the report's compile time), not in the smoothing time
    code = (
        "import json\n"
        "from anglesmooth import generate as gen, smooth\n"
        "from anglesmooth.smoothers import _fast\n"
        "r = smooth(gen.paper_mixed_mesh(0), 'angle', passes=1)\n"
        "print(json.dumps(_fast.jit_stats()['compiled']))\n"
    )
    compiled = json.loads(_py(code, _env(tmp_path, ANGLESMOOTH_KERNEL="numba"), tmp_path).stdout)
    assert "_screen_below" in compiled and "angle_choose" in compiled


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.delenv("ANGLESMOOTH_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    if sys.platform.startswith("linux"):
        assert _jitcache.cache_dir() == tmp_path / "xdg" / "anglesmooth" / "numba"
    monkeypatch.setenv("ANGLESMOOTH_CACHE_DIR", str(tmp_path / "own"))
    assert _jitcache.cache_dir() == tmp_path / "own"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    assert _jitcache.cache_dir() == tmp_path / "numba"


def test_threads_follow_the_cores_the_settings_and_the_work(monkeypatch):
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    monkeypatch.setattr(_fast, "_cores", lambda: 8)
    assert _fast.threads() == 8
    assert _fast.threads(10) == 1  # a small block: one thread
    assert _fast.threads(3 * _fast.MIN_CHUNK) == 3
    monkeypatch.setenv("NUMBA_NUM_THREADS", "2")
    assert _fast.threads(10**7) == 2
    monkeypatch.delenv("NUMBA_NUM_THREADS")
    _fast.set_threads(1)
    try:
        assert _fast.threads(10**7) == 1
    finally:
        _fast.set_threads(None)
    with pytest.raises(ValueError):
        _fast.set_threads(0)
    if hasattr(os, "sched_getaffinity"):
        monkeypatch.undo()
        assert _fast._cores() == len(os.sched_getaffinity(0))


def test_every_kernel_parameter_is_classified_for_the_threaded_split():
    """A kernel parameter that is not known as per-node, shared or scalar makes its calls run whole,
    on one thread: a new kernel must name its parameters in ``_fast.PER_NODE``/``SHARED``/``SCALARS``."""
    import inspect

    k = _fast._k()
    kernels = [getattr(k, n) for n in dir(k) if _fast._is_dispatcher(getattr(k, n)) and not n.startswith("_")]
    assert {fn.__name__ for fn in kernels} >= {n for n in _fast.COMPILE_S if not n.startswith("_")}
    assert all(_fast._is_dispatcher(getattr(k, n)) for n in _fast.COMPILE_S)  # the private ones: not split
    for fn in kernels:
        params = set(inspect.signature(fn.py_func).parameters)
        known = set(_fast.PER_NODE) | _fast.SHARED | _fast.SCALARS
        assert params <= known, (fn.__name__, params - known)
        assert _fast._split_spec(fn) is not None


@pytest.mark.parametrize("method", sorted(SMOOTHERS))
def test_threaded_kernels_give_the_one_thread_numbers(method, monkeypatch):
    """The same passes with every block cut into chunks on three threads: bit-identical points."""
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numba")
    mesh = gen.paper_mixed_mesh(3) if method != "optimization" else gen.paper_quad_mesh(2)
    topo = build_topology(mesh)

    def passes():
        p = mesh.points
        for _ in range(3):
            p = SMOOTHERS[method].step(p, topo).points
        return p

    _fast.set_threads(1)
    try:
        one = passes()
        monkeypatch.setattr(_fast, "MIN_CHUNK", 7)
        monkeypatch.setattr(_fast, "_cores", lambda: 3)
        _fast.set_threads(None)
        assert _fast.threads(topo.n_free) == 3
        three = passes()
    finally:
        _fast.set_threads(None)
    np.testing.assert_array_equal(one, three)


def test_a_scalar_parameter_given_one_value_per_node_is_split_with_the_nodes():
    k = _fast._k()
    nodes = np.arange(10, dtype=np.int64)
    names = _fast._params(k.angle_choose)
    args = [0.0 if p in _fast.SCALARS else np.zeros(3) for p in names]
    args[names.index("nodes")] = nodes
    args[names.index("good")] = 0.5
    per_node, _, _ = _fast._split_spec(k.angle_choose, args)
    assert (names.index("good"), 0) not in per_node
    args[names.index("good")] = np.full(10, 0.5)
    per_node, _, _ = _fast._split_spec(k.angle_choose, args)
    assert (names.index("good"), 0) in per_node
    args[names.index("good")] = np.zeros(0)  # empty ("none"): whole, like a scalar
    per_node, _, _ = _fast._split_spec(k.angle_choose, args)
    assert (names.index("good"), 0) not in per_node
    args[names.index("good")] = np.full(7, 0.5)  # neither one value nor one per node: not split
    assert _fast._split_spec(k.angle_choose, args) is None


def test_cli_threads_option_caps_the_kernel_threads(monkeypatch, tmp_path):
    import meshio
    from cli_runner import cli_runner

    from anglesmooth.cli import cli

    src = tmp_path / "in.vtu"
    m = gen.structured_triangles(6, 6)
    meshio.write(src, meshio.Mesh(np.c_[m.points, np.zeros(len(m.points))], [("triangle", m.triangles)]))
    seen = []
    real = _fast.threads
    monkeypatch.setattr(_fast, "threads", lambda n=None: seen.append(real(n)) or seen[-1])
    monkeypatch.setattr(_fast, "_cores", lambda: 4)
    monkeypatch.setattr(_fast, "MIN_CHUNK", 1)
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numba")
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    try:
        r = cli_runner().invoke(cli, [str(src), str(tmp_path / "a.vtu"), "--threads", "2", "-m", "laplacian"])
        assert r.exit_code == 0, r.output
        assert seen and max(seen) == 2
        seen.clear()
        r = cli_runner().invoke(cli, [str(src), str(tmp_path / "b.vtu"), "-m", "laplacian"])
        assert r.exit_code == 0, r.output
        assert max(seen) == 4  # no option: no cap left over from the run before
        r = cli_runner().invoke(cli, [str(src), str(tmp_path / "c.vtu"), "--threads", "0"])
        assert r.exit_code == 2 and not (tmp_path / "c.vtu").exists()
    finally:
        _fast.set_threads(None)


def test_warm_up_compiles_what_a_smoothing_run_calls(tmp_path):
    """warm_up's tiny mesh gives the kernels the signature of a real run (writeable points: the
    read-only mesh points compiled a second variant before), so the run compiles nothing more."""
    code = (
        "import json\n"
        "from anglesmooth import generate as gen, smooth\n"
        "from anglesmooth.smoothers import _fast, _fastcalls\n"
        "_fastcalls.warm_up(['ring_mean', 'score'])\n"
        "before = list(_fast.jit_stats()['compiled'])\n"
        "smooth(gen.random_delaunay(3000, 3), 'laplacian', passes=2)\n"
        "print(json.dumps([before, _fast.jit_stats()['compiled']]))\n"
    )
    before, after = json.loads(_py(code, _env(tmp_path, ANGLESMOOTH_KERNEL="numba"), tmp_path).stdout)
    assert sorted(before) == ["ring_mean", "score"] and after == before


def test_a_default_run_compiles_one_signature_per_kernel_the_one_warm_up_compiles(tmp_path):
    """Every argument the dispatch passes has one type whatever the caller gave (a scalar or per-node
    acceptance threshold, read-only or not: a read-only ``good`` compiled ``angle_choose`` twice),
    so warm_up's tiny mesh leaves a default ``angle`` run nothing to compile."""
    code = (
        "import json\n"
        "from anglesmooth import generate as gen, smooth\n"
        "from anglesmooth.smoothers import _fast, _fastcalls\n"
        "names = list(_fast.METHOD_KERNELS['angle'])\n"
        "_fastcalls.warm_up(names)\n"
        "before = sorted(_fast.jit_stats()['compiled'])\n"
        "smooth(gen.random_delaunay(3000, 3), 'angle', passes=2)\n"
        "k = _fast._k()\n"
        "print(json.dumps([names, before, sorted(_fast.jit_stats()['compiled']),"
        " [len(getattr(k, n).overloads) for n in names]]))\n"
    )
    names, before, after, n_sigs = json.loads(_py(code, _env(tmp_path, ANGLESMOOTH_KERNEL="numba"), tmp_path).stdout)
    assert before == sorted(names) and after == before and n_sigs == [1] * len(names)


def test_background_warm_up_starts_only_for_compiled_runs(monkeypatch):
    from anglesmooth.smoothers import _jitcache_warm

    monkeypatch.setattr(_jitcache_warm, "_thread", None)
    started = []
    monkeypatch.setattr(_jitcache_warm.threading, "Thread",
                        lambda **kw: type("T", (), {"start": lambda self: started.append(kw["args"])})())
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numpy")
    assert not _jitcache_warm.start("angle", 10**6)
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "auto")
    assert not _jitcache_warm.start("angle", _fast.AUTO_MIN_FREE - 1)  # auto keeps it on numpy
    assert not _jitcache_warm.start("no-such-method", 10**6)
    assert started == []
    assert _jitcache_warm.start("angle", _fast.AUTO_MIN_FREE) == (_fast._numba_available())
    assert started == ([(_fast.METHOD_KERNELS["angle"],)] if _fast._numba_available() else [])
    assert not _jitcache_warm.start("laplacian", 10**6)  # once per process


def test_background_warm_up_compiles_each_kernel_once_and_changes_no_result(tmp_path):
    """The CLI's warm-up thread (started after reading) and the run's own calls share the compile lock:
    each kernel compiles once, in either thread; the points are those of a run without the thread
    (which loads the kernels the first one cached); the run's compile_s is what it waited."""
    code = (
        "import json, sys, hashlib\n"
        "from anglesmooth import generate as gen, smooth\n"
        "from anglesmooth.smoothers import _fast, _jitcache_warm\n"
        "m = gen.random_delaunay(3000, 3)\n"
        "started = _jitcache_warm.start('angle', m.n_points) if sys.argv[1] == 'warm' else False\n"
        "r = smooth(m, 'angle', passes=2)\n"
        "s = _fast.jit_stats()\n"
        "k = _fast._k()\n"
        "print(json.dumps([started, sorted(s['compiled']), sorted(s['loaded']), r.compile_s, s['wait_s'],"
        " [len(getattr(k, n).overloads) for n in _fast.METHOD_KERNELS['angle']],"
        " hashlib.sha256(r.points.tobytes()).hexdigest()]))\n"
    )
    env = _env(tmp_path, ANGLESMOOTH_KERNEL="numba")
    runs = []
    for mode in ("warm", "plain"):
        res = subprocess.run([sys.executable, "-c", code, mode], capture_output=True, text=True, env=env,
                             cwd=tmp_path, timeout=600)
        assert res.returncode == 0, res.stderr[-3000:]
        runs.append(json.loads(res.stdout))
    (started, compiled, loaded, compile_s, wait_s, n_sigs, digest), plain = runs
    names = sorted(_fast.METHOD_KERNELS["angle"])
    assert started and compiled == names and loaded == [] and n_sigs == [1] * len(names)
    assert 0 <= compile_s == wait_s
    assert plain[0] is False and plain[1] == [] and plain[2] == names and plain[5] == n_sigs
    assert plain[6] == digest


def test_numba_is_imported_without_error_highlighting_and_the_environment_is_restored():
    """numba's first import (through _fast) sets NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING only meanwhile:
    the compile then skips colorama's per-error stream wrapping; a user's own setting is left alone."""
    import subprocess
    import sys

    code = ("import os, sys; from anglesmooth.smoothers import _fast; _fast._k(); "
            "import numba.core.errors as e; print(type(e.termcolor()).__name__, "
            "os.environ.get('NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING'))")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"}
    env["PYTHONPATH"] = os.pathsep.join([str(Path(__file__).resolve().parents[1] / "src"), env.get("PYTHONPATH", "")])
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split() == ["NOPColorScheme", "None"]
    env["NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"] = "1"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split() == ["NOPColorScheme", "1"]


def test_the_kernel_cache_is_stamped_with_every_compiled_module():
    """A cached kernel holds the compiled helpers it calls from other modules (``_nodescore``): its stamp
    must cover every module of the package that compiles code, or editing a helper would leave stale
    kernels in the cache."""
    from anglesmooth.smoothers import _jitcache

    pkg = Path(_jitcache.__file__).resolve().parent
    compiling = sorted(str(p) for p in pkg.glob("*.py") if "njit" in p.read_text(encoding="utf-8")
                       and p.name not in ("_fast.py", "_jitcache.py", "_jitcache_warm.py"))
    assert compiling == [str(Path(f).resolve()) for f in _jitcache._kernel_files()]
