"""The paper reproduction (benchmarks/paper/reproduce.py): smoke run into tmp_path, and the committed docs/paper."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("matplotlib")
pytest.importorskip("scipy")

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "paper" / "reproduce.py"
FIGURES = [
    "fig08_distorted.png",
    "fig09_triangle.png",
    "fig10_mixed.png",
    "fig11_graded.png",
    "fig12_convergence.png",
    "fig13_passes.png",
    "fig15_quad.png",
]
SECTIONS = [
    "## Table 1",
    "## Table 2",
    "## Table 3",
    "## Table 4 and Figure 13",
    "## Figure 12",
    "## Section 5.1.1 / Figure 8",
    "## Section 5.1.3 / Figure 11",
    "## Table 5",
    "## Section 5.2",
    "## Figures 9, 10, 11, 15",
]
METHODS = ["original", "laplacian", "smart-laplacian", "angle-literal", "angle-default", "optimization"]


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--smoke", "--out", str(out)], capture_output=True, text=True, cwd=out
    )
    assert proc.returncode == 0, proc.stderr
    return out


def _check_outputs(out: Path):
    readme = (out / "README.md").read_text()
    for head in SECTIONS:
        assert head in readme, head
    for fig in FIGURES:
        p = out / fig
        assert p.exists() and p.stat().st_size > 1000, fig
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert p.stat().st_size < 400_000, fig
        assert f"({fig})" in readme, fig
    res = json.loads((out / "results.json").read_text())
    assert set(res) >= {"meta", "quality", "five_element", "distorted", "surface", "cost", "figures", "paper"}
    for kind in ("triangle", "mixed", "graded", "quad"):
        agg = res["quality"][kind]["aggregate"]
        assert set(agg) >= set(METHODS)
        for key in METHODS:
            for m in ("min_angle", "max_angle", "angles_below_20", "angles_above_150", "area_ratio", "inverted"):
                assert m in agg[key]
        per_pass = res["quality"][kind]["per_pass"]["laplacian"]["min_angle"]
        assert len(per_pass) == res["meta"]["passes"] + 1
    return readme, res


def test_smoke_outputs(smoke):
    readme, res = _check_outputs(smoke)
    assert res["meta"]["smoke"] and res["meta"]["passes"] == 2
    assert "Smoke run" in readme
    tri = res["quality"]["triangle"]["aggregate"]
    mean = lambda key, m: tri[key][m]["mean"]  # noqa: E731
    # every smoother improves the random Delaunay mesh a lot
    for key in METHODS[1:]:
        assert mean(key, "min_angle") > mean("original", "min_angle") + 5
        assert 0 < mean(key, "max_angle") < 180
        assert mean(key, "inverted") == 0
    # the robust default beats Laplacian already after 2 passes; optimization and default are the best
    assert mean("angle-default", "min_angle") > mean("laplacian", "min_angle")
    assert mean("angle-default", "angles_below_20") < mean("laplacian", "angles_below_20")
    # Figure 8: unguarded Laplacian inverts, the angle rule does not and improves the minimum angle
    d = res["distorted"]
    assert d["laplacian-1pass"]["inverted"] > 0
    assert d["angle-literal"]["inverted"] == 0
    assert d["angle-literal"]["min_angle"] > d["original"]["min_angle"]
    assert d["smart-laplacian"]["min_angle"] == pytest.approx(d["original"]["min_angle"])
    # Figure 12: three starts converge towards one point
    fe = res["five_element"]
    assert len(fe["paths"]) == 3 and all(len(p) == 3 for p in fe["paths"])
    assert all(r < 100 for r in fe["last_over_first_pct"])
    # Table 5: finite positive errors, l and the quadrature stated
    s = res["surface"]
    assert s["domain"]["size_l"] == pytest.approx(100.0) and s["gauss"] == 5
    for f in ("f1", "f2", "f3"):
        for key in ("original", "laplacian", "angle-literal", "angle-default"):
            assert s[f][key]["mean"] > 0
    # cost: every method timed, Laplacian is the unit
    c = res["cost"]["large"]["methods"]
    assert c["laplacian"]["relative"] == pytest.approx(1.0)
    assert all(v["median_s"] > 0 for v in c.values())


def _committed():
    out = ROOT / "docs" / "paper"
    if not (out / "results.json").exists():
        pytest.skip("docs/paper not generated")
    return out


def test_committed_docs_match_the_paper_claims():
    """The committed full run (10 seeds, 10 passes): the paper's headline claims on the triangle mesh."""
    readme, res = _check_outputs(_committed())
    assert not res["meta"]["smoke"] and len(res["meta"]["seeds"]) >= 5 and res["meta"]["passes"] == 10
    tri = res["quality"]["triangle"]["aggregate"]
    mean = lambda key, m: tri[key][m]["mean"]  # noqa: E731
    assert mean("angle-literal", "min_angle") > mean("laplacian", "min_angle")
    assert mean("angle-literal", "angles_below_20") < mean("laplacian", "angles_below_20")
    assert mean("angle-literal", "area_ratio") < mean("laplacian", "area_ratio")
    assert mean("angle-default", "min_angle") > mean("angle-literal", "min_angle")
    g = res["quality"]["graded"]["aggregate"]
    assert g["angle-default"]["min_angle"]["mean"] >= g["laplacian"]["min_angle"]["mean"]
    assert g["angle-default"]["inverted"]["max"] == 0
    total = sum(p.stat().st_size for p in _committed().iterdir())
    assert total < 3_000_000
