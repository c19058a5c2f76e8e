"""Tables and JSON documents (anglesmooth.report): formatting only."""

from __future__ import annotations

import json

import pytest
from rich.console import Console

from anglesmooth import build_topology, summarize
from anglesmooth.gates import evaluate
from anglesmooth.generate import paper_mixed_mesh
from anglesmooth.report import (
    ROWS,
    SCHEMA_VERSION,
    change,
    check_json,
    check_table,
    compare_json,
    compare_table,
    files_table,
    fmt,
    smooth_json,
    smooth_table,
    to_json,
)


@pytest.fixture(scope="module")
def summary():
    mesh = paper_mixed_mesh(seed=0)
    return summarize(mesh.points, build_topology(mesh))


def render(renderable) -> str:
    console = Console(record=True, width=200, file=open("/dev/null", "w"))
    console.print(renderable)
    return console.export_text()


def test_rows_name_real_summary_keys(summary):
    for key, sub, *_ in ROWS:
        assert key in summary
        if sub is not None:
            assert sub in summary[key]


def test_fmt_and_change():
    assert fmt(None) == "–" and fmt(float("inf")) == "inf" and fmt(59.999, "angle") == "60.00"
    assert change(10.0, 12.5, +1) == ("+2.50", "green")
    assert change(10.0, 12.5, -1) == ("+2.50", "red")
    assert change(3, 3, -1, "int") == ("=", "dim")
    assert change(None, 3, -1) == ("", "")
    assert change(5, 3, 0, "int") == ("-2", "")


def test_smooth_table(summary):
    after = {**summary, "min_angle": summary["min_angle"] + 10, "inverted": 0}
    text = render(smooth_table(summary, after, {"rejected moves": 7}, title="a -> b"))
    assert "a -> b" in text and "rejected moves" in text and "+10.00" in text
    assert "quad scaled Jacobian, min" in text  # mixed mesh: per-type rows too
    assert "triangle min angle" in text


def test_single_type_table_skips_per_type_rows():
    s = {"triangles": 4, "quads": 0, "min_angle": 30.0, "tri_min_angle": 30.0, "quad_min_angle": None}
    text = render(check_table(s))
    assert "min angle" in text and "triangle min angle" not in text


def test_files_and_compare_tables(summary):
    entries = [
        {"input": "a.msh", "report": summary, "gates": [], "passed": True, "error": None},
        {"input": "b.msh", "report": None, "gates": [], "passed": None, "error": "cannot read"},
    ]
    text = render(files_table(entries, with_gates=True))
    assert "a.msh" in text and "ERROR" in text and "pass" in text
    results = [{"method": "angle", "after": summary, "passes": 3, "rejected": 1, "elapsed_s": 0.25}]
    text = render(compare_table(summary, results))
    assert "input" in text and "angle" in text and "0.250" in text


def test_to_json_is_strict():
    text = to_json({"a": float("nan"), "b": (1, float("-inf"))})
    assert json.loads(text) == {"a": None, "b": [1, None]}
    import numpy as np

    assert json.loads(to_json({"n": np.int64(3), "x": np.arange(2)})) == {"n": 3, "x": [0, 1]}


def test_json_documents(summary):
    gates = evaluate(summary, {"min_angle": 1.0})
    doc = smooth_json(input="a", output="b", method="angle", guard=True, order="colour", passes=2,
                      passes_requested=10, tol=None, displacements=[0.5, 0.1], rejected=3, before=summary,
                      after=summary, elapsed_s=0.1, gates=gates, passed=False)
    assert doc["schema_version"] == SCHEMA_VERSION and doc["displacement"] == 0.1
    assert doc["gates"] == [g.to_dict() for g in gates]
    json.loads(to_json(doc))
    assert check_json([], True)["files"] == []
    cmp = compare_json(input="a", passes_requested=1, guard=True, order="colour", before=summary, results=[])
    assert cmp["methods"] == [] and cmp["schema_version"] == SCHEMA_VERSION
