"""Gate evaluation and gate files (anglesmooth.gates)."""

from __future__ import annotations

import math

import pytest

from anglesmooth.errors import AngleSmoothError
from anglesmooth.gates import GATES, Gate, evaluate, load_gate_file, resolve_thresholds

SUMMARY = {
    "min_angle": 12.34,
    "max_angle": 150.0,
    "inverted": 2,
    "area_ratio": 40.0,
    "tri_aspect_ratio": {"min": 1.0, "mean": 1.5, "max": 3.0},
    "quad_aspect_ratio": {"min": 1.0, "mean": 2.0, "max": 7.5},
}


@pytest.mark.parametrize(
    "name,ok,bad,value",
    [
        ("min_angle", 12.34, 12.35, 12.34),
        ("max_angle", 150.0, 149.9, 150.0),
        ("max_inverted", 2, 1, 2),
        ("max_area_ratio", 40.0, 39.9, 40.0),
        ("max_aspect_ratio", 7.5, 7.4, 7.5),  # the max over triangles and quads
    ],
)
def test_each_gate_boundary(name, ok, bad, value):
    (g,) = evaluate(SUMMARY, {name: ok})
    assert g == Gate(name, ok, value, True)
    (g,) = evaluate(SUMMARY, {name: bad})
    assert not g.passed and g.value == value


def test_order_and_skipped_none():
    gates = evaluate(SUMMARY, {"max_inverted": 5, "min_angle": 1, "max_angle": None})
    assert [g.name for g in gates] == ["min_angle", "max_inverted"]
    assert evaluate(SUMMARY, {}) == []


def test_infinite_area_ratio_fails_and_serializes_as_null():
    (g,) = evaluate({**SUMMARY, "area_ratio": None}, {"max_area_ratio": 1e300})
    assert not g.passed and math.isinf(g.value)
    assert g.to_dict() == {"name": "max_area_ratio", "threshold": 1e300, "value": None, "passed": False,
                           "cell": None}
    assert g.message("m.vtu") == "m.vtu: gate max_area_ratio failed: inf > 1e+300"


def test_undefined_aspect_ratio_passes():
    (g,) = evaluate({**SUMMARY, "tri_aspect_ratio": None, "quad_aspect_ratio": None}, {"max_aspect_ratio": 2})
    assert g.passed and g.value is None


def test_messages():
    gates = evaluate(SUMMARY, {"min_angle": 20, "max_inverted": 0, "max_angle": 120.5})
    assert [g.message("a.msh") for g in gates] == [
        "a.msh: gate min_angle failed: 12.3° < 20°",
        "a.msh: gate max_angle failed: 150.0° > 120.5°",
        "a.msh: gate max_inverted failed: 2 > 0",
    ]


def test_resolve_thresholds(tmp_path):
    f = tmp_path / "g.toml"
    f.write_text("min_angle = 25\nmax_area_ratio = 100\n")
    assert resolve_thresholds({"min_angle": 30, "max_angle": None}, f) == {
        "min_angle": 30, "max_area_ratio": 100, "max_inverted": 0, "max_degenerate": 0}
    assert resolve_thresholds({"max_inverted": 3}) == {"max_inverted": 3, "max_degenerate": 0}
    assert resolve_thresholds({k: None for k in GATES}) == {}


@pytest.mark.parametrize(
    "text,expected",
    [
        ("min_angle = 20\nmax_inverted = 0\n", {"min_angle": 20, "max_inverted": 0}),
        ("[gates]\nmax_aspect_ratio = 4.5\n", {"max_aspect_ratio": 4.5}),
        ("[project]\nname = 'x'\n[tool.anglesmooth.gates]\nmax_angle = 150\n", {"max_angle": 150}),
        ("", {}),
    ],
)
def test_load_gate_file(tmp_path, text, expected):
    f = tmp_path / "g.toml"
    f.write_text(text)
    assert load_gate_file(f) == expected


@pytest.mark.parametrize(
    "text,needle",
    [
        ("min_angel = 20\n", "unknown key 'min_angel'"),
        ("min_angle = true\n", "finite number"),
        ("min_angle = 'x'\n", "finite number"),
        ("min_angle = nan\n", "finite number"),
        ("max_inverted = -1\n", "non-negative integer"),
        ("max_inverted = 1.5\n", "non-negative integer"),
        ("min_angle = \n", "not valid TOML"),
    ],
)
def test_bad_gate_files(tmp_path, text, needle):
    f = tmp_path / "g.toml"
    f.write_text(text)
    with pytest.raises(AngleSmoothError, match=needle.replace("(", r"\(")):
        load_gate_file(f)


def test_missing_gate_file(tmp_path):
    with pytest.raises(AngleSmoothError, match="cannot read gate file"):
        load_gate_file(tmp_path / "nope.toml")


def test_message_of_a_passed_gate_says_so():
    (g,) = evaluate(SUMMARY, {"min_angle": 10})
    assert g.message("a.msh") == "a.msh: gate min_angle passed: 12.3° >= 10°"
