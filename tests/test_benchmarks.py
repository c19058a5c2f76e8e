"""The speed benchmark runs on a tiny size and prints its table and JSON (no timing is asserted)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_speed.py"


@pytest.mark.skipif(not SCRIPT.exists(), reason="benchmarks/ not shipped")
def test_bench_speed_tiny(tmp_path):
    out = tmp_path / "bench.json"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    res = subprocess.run(
        [sys.executable, str(SCRIPT), "--tiny", "--kernels", "numpy,numba", "--json", str(out)],
        capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600,
    )
    assert res.returncode == 0, res.stderr
    header = res.stdout.splitlines()[0].split()
    for col in ("mesh", "method", "s/pass", "RSS"):
        assert col in header
    from anglesmooth.smoothers import SMOOTHERS

    data = json.loads(out.read_text())
    rows = data["rows"]
    methods = {(r["mesh"], r["method"], r["guard"], r.get("kernel")) for r in rows}
    for name in SMOOTHERS:
        for kernel in ("numpy", "numba"):  # every method ran with both kernels
            assert ("tiny", name, True, kernel) in methods and ("tinyquad", name, True, kernel) in methods
    assert ("tiny", "angle", False, "numba") in methods
    assert ("tiny", "angle (loaded)", True, "numba") in methods and ("tiny", "angle (loaded)", True, "numpy") in methods
    loaded = [r for r in rows if r["method"] == "angle (loaded)"]
    assert {r["load"] for r in loaded} == {1} and {r["threads"] for r in loaded if r["kernel"] == "numba"} == {1}
    # cold / warm first runs (an empty, then the filled kernel cache directory): the library and the CLI
    states = {(r["method"], r["state"]): r for r in rows if "state" in r}
    assert set(states) == {("first pass (cold)", "cold"), ("first pass (warm)", "warm"), ("CLI (cold cache)", "cold"),
                           ("CLI (warm cache)", "warm")}
    for r in states.values():
        assert "error" not in r and r.get("returncode", 0) == 0, r
        assert r["compile_s"] >= 0 and r["peak_rss_mb"] > 0
    assert "cold = empty kernel cache directory" in res.stdout
    rows = [r for r in rows if "state" not in r]
    timed = [r for r in rows if "kernel" in r and r["method"] != "stages"]
    for r in timed:
        assert "error" not in r, r
        assert r["pass_s"] >= 0 and r["setup_s"] >= 0 and r["peak_rss_mb"] > 0
        assert (r["jit_s"] is None) == (r["kernel"] == "numpy")
    assert any("ratio_to_laplacian" in r for r in rows)
    # the end-to-end rows: the CLI beside meshio alone, for a binary and an ASCII .msh
    e2e = {(r["mesh"], r["method"]): r for r in rows if r not in timed}
    for mesh in ("tiny", "tinyquad"):
        for enc in ("binary", "ascii"):
            assert e2e[(mesh, f"CLI ({enc} msh)")]["returncode"] == 0
            assert e2e[(mesh, f"CLI ({enc} msh)")]["ratio_to_meshio"] > 0
            assert e2e[(mesh, f"meshio ({enc} msh)")]["e2e_s"] > 0
            assert e2e[(mesh, f"CLI check ({enc} msh)")]["returncode"] == 0
            assert e2e[(mesh, f"CLI ({enc} msh)")]["peak_rss_mb"] > 0
        # where the end-to-end time goes: every stage of the CLI's path timed, adding up to the total
        st = e2e[(mesh, "stages")]
        stages = [st[f"{k}_s"] for k in ("import", "read", "topology", "summary", "passes", "summary2", "write")]
        assert all(v >= 0 for v in stages) and abs(sum(stages) - st["total_s"]) < 1e-6
        assert 0 < st["pass1_s"] <= st["passes_s"]
    assert "stages of 'anglesmooth in.msh out.vtu'" in res.stdout
    assert list(tmp_path.iterdir()) == [out]  # meshes went to a temporary directory
