"""The CLI's kernel load without numba's BLAS probe (:mod:`anglesmooth.smoothers._leanload`): only the CLI's
entry point skips it, the library loads numba as usual, the results are the same, and an unknown numba
release falls back to the usual load.  Each case runs in its own interpreter (the probe runs once a process)."""

from __future__ import annotations

import importlib.util
import inspect
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from anglesmooth.smoothers import _jitcache, _leanload

SRC = Path(__file__).resolve().parents[1] / "src"

#: What each subprocess prints after its run: the flag, numba's probe result, scipy.linalg importable.
_STATE = (
    "import importlib, numba.np.arraymath as am\n"
    "from anglesmooth.smoothers import _leanload\n"
    "had = 'scipy.linalg' in sys.modules\n"
    "importlib.import_module('scipy.linalg')  # imports as usual after the load, whatever the path\n"
    "print(_leanload._lean['on'], am._HAVE_BLAS, had)\n"
)

_MESH = (
    "import sys, numpy as np, meshio\n"
    "from anglesmooth import generate as gen\n"
    "m = gen.random_delaunay(3000, 2)\n"
    "meshio.write('in.vtu', meshio.Mesh(np.c_[m.points, 0 * m.points[:, 0]], [('triangle', m.triangles)]))\n"
)


def _run(code: str, tmp_path: Path) -> list[str]:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(SRC), ANGLESMOOTH_CACHE_DIR=str(tmp_path / "cache"), ANGLESMOOTH_KERNEL="numba")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path,
                         timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    return res.stdout.split()


def _cli(argv_expr: str) -> str:
    return (
        "from anglesmooth.cli import main\n"
        f"sys.argv = ['anglesmooth', 'in.vtu', 'out.vtu', '--passes', '3', '--quiet']\n"
        "try:\n"
        f"    main({argv_expr})\n"
        "except SystemExit as e:\n"
        "    assert not e.code, e.code\n"
    )


def test_the_cli_skips_the_probe_the_library_does_not_and_the_points_are_the_same(tmp_path):
    scipy = importlib.util.find_spec("scipy") is not None
    # the CLI as a process runs it (argv from sys.argv): the probe skipped, scipy.linalg not imported by it
    _run(_MESH, tmp_path)  # scipy.spatial (the mesh generator) imports scipy.linalg: in a process of its own
    lean = _run("import sys\n" + _cli("") + "import os; os.replace('out.vtu', 'lean.vtu')\n" + _STATE, tmp_path)
    assert lean == ["True", "False", "False"]
    # main(argv) called by a program (as the tests do): the usual load
    usual = _run("import sys\n" + _cli("sys.argv[1:]") + _STATE, tmp_path)
    assert usual == ["False", str(scipy), str(scipy)]
    # the library: the usual load, sys.modules as numba leaves it
    lib = _run("import sys, numpy as np, meshio\nfrom anglesmooth import read, smooth\n"
               "m = read('in.vtu')\n"
               "np.save('lib.npy', smooth(m, 'angle', 3).points)\n"
               + _STATE, tmp_path)
    assert lib == ["False", str(scipy), str(scipy)]
    import meshio

    a, b = meshio.read(tmp_path / "lean.vtu"), meshio.read(tmp_path / "out.vtu")
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.points[:, :2], np.load(tmp_path / "lib.npy"))
    np.testing.assert_array_equal(a.cells_dict["triangle"], b.cells_dict["triangle"])


def test_an_unknown_numba_release_or_an_arraymath_already_loaded_keeps_the_usual_load(tmp_path):
    code = (
        "import sys\n"
        "from anglesmooth.smoothers import _fast, _leanload\n"
        "_leanload.LEAN_NUMBA = ((9, 0), (9, 9))\n"
        "_leanload.lean_load()\n"
        "print(_leanload._lean_numba_ok())\n"
        "_fast._k()\n"
        "print(_leanload._skip_blas_probe())  # arraymath is loaded now: nothing to skip\n"
        + _STATE
    )
    scipy = str(importlib.util.find_spec("scipy") is not None)
    assert _run(code, tmp_path) == ["False", "False", "True", scipy, scipy]


def test_the_installed_numba_is_a_checked_release_and_reads_the_probe_only_where_no_kernel_goes():
    """What the skip assumes, against the numba installed here: its release is in LEAN_NUMBA, the probe's
    answer ``_HAVE_BLAS`` is read at one place (the inner product of np.correlate / np.convolve), and no
    compiled module of anglesmooth calls those (nor np.cov / np.corrcoef, built on them)."""
    import numba
    import numba.np.arraymath as am

    assert _leanload._lean_numba_ok(), numba.__version__
    source = inspect.getsource(am)
    assert re.findall(r"^_HAVE_BLAS = _check_blas\(\)$", source, re.M)
    reads = [m.start() for m in re.finditer(r"\b_HAVE_BLAS\b", source)]
    assert len(reads) == 2  # its definition and one read
    inner = source.index("def _get_inner_prod(")
    assert inner < reads[1] < source.index("\ndef ", inner + 1)
    callers = {m.group(1) for m in re.finditer(r"^def (\w+)\(.*?(?=^def |\Z)", source, re.M | re.S)
               if "_get_inner_prod(" in m.group(0) and m.group(1) != "_get_inner_prod"}
    assert callers == {"_np_correlate_core_impl"}
    files = _jitcache._kernel_files()
    assert len(files) >= 3
    for path in files:
        text = Path(path).read_text(encoding="utf-8")
        for name in _leanload.BLAS_PROBE_USERS:
            assert name + "(" not in text, (path, name)
