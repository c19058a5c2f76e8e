"""The published JSON Schemas: ``anglesmooth schema X`` prints them, real reports validate against them."""

from __future__ import annotations

import copy
import json
from importlib import resources

import jsonschema
import pytest
from cli_runner import cli_runner

import anglesmooth
from anglesmooth import write
from anglesmooth.cli import cli
from anglesmooth.cli.schema import SCHEMAS, load_schema
from anglesmooth.gates import GATES
from anglesmooth.generate import paper_mixed_mesh, structured_triangles
from anglesmooth.quality import METRICS
from anglesmooth.report import SCHEMA_VERSION


def run(*args):
    return cli_runner().invoke(cli, [str(a) for a in args])


def validator(name: str) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(load_schema(name), format_checker=jsonschema.FormatChecker())


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("schema")
    mixed, tangled = d / "mixed.vtu", d / "tangled.vtu"
    write(paper_mixed_mesh(seed=1, n_interior=60, per_side=6), mixed)
    pts = structured_triangles(6, 6).points.copy()
    pts[24] += [1.6, 0.1]  # pushed across its ring: inverted cells
    write(anglesmooth.Mesh2D.from_arrays(pts, triangles=structured_triangles(6, 6).triangles), tangled)
    return {"mixed": mixed, "tangled": tangled, "dir": d}


@pytest.mark.parametrize("name", list(SCHEMAS))
def test_schema_command_prints_the_shipped_draft_2020_12_schema(name):
    result = run("schema", name)
    assert result.exit_code == 0, result.stderr
    printed = json.loads(result.stdout)
    shipped = json.loads(resources.files("anglesmooth").joinpath("schemas", f"{name}.schema.json").read_text())
    assert printed == shipped
    assert printed["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(printed)
    assert printed["properties"]["schema_version"]["const"] == SCHEMA_VERSION  # the contract


def test_unknown_schema_is_a_usage_error():
    assert run("schema", "plot").exit_code == 2


def test_summary_schema_describes_every_metric_and_gate():
    for name in SCHEMAS:
        summary = load_schema(name)["$defs"]["summary"]
        assert set(summary["properties"]) == set(METRICS), name
        assert set(summary["required"]) == set(METRICS)
    for name in ("smooth", "check"):
        assert load_schema(name)["$defs"]["gate"]["properties"]["name"]["enum"] == list(GATES)


def test_smooth_reports_validate(files, tmp_path):
    v = validator("smooth")
    for args in ([], ["--min-angle", "89", "--max-aspect-ratio", "1.5"], ["--tol", "0.5", "--method", "laplacian"]):
        out, js = tmp_path / "o.vtu", tmp_path / "o.json"
        result = run(files["mixed"], out, "-n", "2", "--json", js, "-q", *args)  # the same OUTPUT: replaced
        assert result.exit_code in (0, 1), result.stderr
        doc = json.loads(js.read_text())
        v.validate(doc)
    assert doc["method"] == "laplacian"
    # a tangled input: inverted cells listed in "before"
    result = run(files["tangled"], tmp_path / "t.vtu", "-n", "1", "--json", "-", "-q", "--min-angle", "1")
    doc = json.loads(result.stdout)
    assert doc["before"]["inverted"] > 0 and doc["before"]["inverted_cells"]
    v.validate(doc)


def test_check_reports_validate(files):
    result = run("check", files["mixed"], files["tangled"], files["dir"] / "missing.vtu", "--json", "-", "-q",
                 "--min-angle", "30")
    assert result.exit_code == 3
    doc = json.loads(result.stdout)
    validator("check").validate(doc)
    assert [e["error"] is None for e in doc["files"]] == [True, True, False]
    assert any(g["cell"] is not None for g in doc["files"][1]["gates"])


def test_compare_report_validates(files):
    result = run("compare", files["mixed"], "-n", "1", "--json", "-", "-q")
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    validator("compare").validate(doc)
    assert {m["method"] for m in doc["methods"]} == set(anglesmooth.SMOOTHERS)


def test_schemas_reject_broken_documents(files):
    """The schemas constrain something: a wrong version, a missing key, a bad type or gate name fail."""
    result = run("check", files["mixed"], "--json", "-", "-q")
    doc = json.loads(result.stdout)
    v = validator("check")
    v.validate(doc)
    broken = []
    for mutate in (
        lambda d: d.update(schema_version=SCHEMA_VERSION + 1),
        lambda d: d.pop("passed"),
        lambda d: d["files"][0]["report"].pop("min_angle"),
        lambda d: d["files"][0]["report"].update(inverted=-1),
        lambda d: d["files"][0]["report"].update(tri_aspect_ratio={"min": 1.0}),
        lambda d: d["files"][0]["gates"][0].update(name="min_angel"),
        lambda d: d["files"][0].update(passed="yes"),
    ):
        bad = copy.deepcopy(doc)
        mutate(bad)
        broken.append(v.is_valid(bad))
    assert broken == [False] * 7
