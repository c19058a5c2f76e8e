"""Configuration discovery (anglesmooth.config) and how the command line merges it under its options."""

from __future__ import annotations

import json

import pytest
from cli_runner import cli_runner

from anglesmooth import write
from anglesmooth.cli import cli
from anglesmooth.cli.main import CONFIGURABLE
from anglesmooth.config import KEYS, ConfigFileError, discover, find_config, load_config
from anglesmooth.generate import paper_mixed_mesh


def run(*args):
    return cli_runner().invoke(cli, [str(a) for a in args])


def one_error_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("anglesmooth: error: "), result.stderr
    return lines[0]


@pytest.fixture(scope="module")
def mesh(tmp_path_factory):
    path = tmp_path_factory.mktemp("cfgmesh") / "m.vtu"
    write(paper_mixed_mesh(seed=4, n_interior=60, per_side=6), path)
    return path


@pytest.fixture
def project(tmp_path, monkeypatch):
    """A project directory with a pyproject.toml, the working directory two levels below it."""
    root = tmp_path / "proj"
    work = root / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    return root


PYPROJECT = """\
[project]
name = "x"

[tool.anglesmooth]
method = "laplacian"
passes = 1
order = "jacobi"

[tool.anglesmooth.gates]
min_angle = 1
max_aspect_ratio = 1000
"""


def smooth_json(mesh, tmp_path, *args):
    result = run(mesh, tmp_path / "o.vtu", "--json", "-", "-q", *args)  # the same OUTPUT each call: replaced
    assert result.exit_code in (0, 1), result.stderr
    return json.loads(result.stdout)


# ------------------------------------------------------------------ discovery


def test_find_config_walks_up_like_ruff(tmp_path):
    root = tmp_path / "r"
    deep = root / "x" / "y"
    deep.mkdir(parents=True)
    assert find_config(deep) is None or not str(find_config(deep)).startswith(str(tmp_path))
    (root / "pyproject.toml").write_text(PYPROJECT)
    assert find_config(deep) == root / "pyproject.toml"
    # a pyproject.toml without [tool.anglesmooth] is passed over
    (root / "x" / "pyproject.toml").write_text("[project]\nname = 'inner'\n")
    assert find_config(deep) == root / "pyproject.toml"
    # the nearest wins; anglesmooth.toml wins over pyproject.toml in one directory
    (root / "x" / "anglesmooth.toml").write_text("passes = 3\n")
    assert find_config(deep) == root / "x" / "anglesmooth.toml"
    (deep / "pyproject.toml").write_text("[tool.anglesmooth]\npasses = 4\n")
    assert discover(deep).settings == {"passes": 4}
    (deep / "anglesmooth.toml").write_text("passes = 5\n")
    assert discover(deep).settings == {"passes": 5}


def test_load_config_values_and_paths(tmp_path):
    (tmp_path / "nodes.txt").write_text("1 2\n")
    f = tmp_path / "anglesmooth.toml"
    f.write_text('fix-group = "wall"\nfix_nodes = "nodes.txt"\ntol = 1e-3\nno-guard = true\n'
                 "[gates]\nmin-angle = 20\nmax_inverted = 2\n")
    cfg = load_config(f)
    assert cfg.path == f
    assert cfg.settings == {"fix-group": ["wall"], "fix-nodes": str(tmp_path / "nodes.txt"), "tol": 1e-3,
                            "no-guard": True}
    assert cfg.gates == {"min_angle": 20, "max_inverted": 2}


@pytest.mark.parametrize(
    "text,needle",
    [
        ("pases = 3\n", "unknown key 'pases'"),
        ("min-angle = 20\n", "gate thresholds go in the gates table"),
        ("passes = 'ten'\n", "passes must be a non-negative integer, got 'ten'"),
        ("passes = -1\n", "passes must be a non-negative integer"),
        ("no-guard = 1\n", "no-guard must be true or false"),
        ("fix-group = [1]\n", "fix-group must be a string or a list of strings"),
        ("tol = nan\n", "tol must be a non-negative number"),
        ("[gates]\nmin_angel = 2\n", "unknown key 'min_angel'"),
        ("gates = 3\n", "gates must be a table"),
        ("passes = \n", "not valid TOML"),
    ],
)
def test_bad_configuration_names_the_key_and_the_file(tmp_path, text, needle):
    f = tmp_path / "anglesmooth.toml"
    f.write_text(text)
    with pytest.raises(ConfigFileError, match=needle.replace("(", r"\(").replace("[", r"\[")) as info:
        load_config(f)
    assert str(f) in str(info.value) and info.value.exit_code == 2


def test_every_key_is_an_option_of_some_command():
    options = {opt[2:] for cmd in CONFIGURABLE.values() for p in cmd.params for opt in p.opts}
    assert set(KEYS) <= options


# ------------------------------------------------------------------ the command line


def test_pyproject_settings_apply_from_a_subdirectory(project, mesh, tmp_path):
    (project / "pyproject.toml").write_text(PYPROJECT)
    doc = smooth_json(mesh, tmp_path)
    assert (doc["method"], doc["passes_requested"], doc["order"]) == ("laplacian", 1, "jacobi")
    assert [g["name"] for g in doc["gates"]] == ["min_angle", "max_inverted", "max_degenerate", "max_aspect_ratio"]
    # the command line overrides the file
    doc = smooth_json(mesh, tmp_path, "--passes", "2", "--method", "angle", "--min-angle", "2")
    assert (doc["method"], doc["passes_requested"], doc["order"]) == ("angle", 2, "jacobi")
    assert {g["name"]: g["threshold"] for g in doc["gates"]}["min_angle"] == 2
    # --no-config ignores it
    doc = smooth_json(mesh, tmp_path, "--no-config")
    assert (doc["method"], doc["passes_requested"], doc["order"], doc["gates"]) == ("angle", 10, "colour", [])


def test_config_gates_on_check_and_compare(project, mesh):
    (project / "anglesmooth.toml").write_text("passes = 1\n[gates]\nmin_angle = 60\n")
    result = run("check", mesh)
    assert result.exit_code == 1 and "gate min_angle failed" in result.stderr
    assert run("check", mesh, "--min-angle", "0").exit_code == 0
    assert run("check", mesh, "--no-config").exit_code == 0
    result = run("compare", mesh, "--json", "-", "-q")
    assert result.exit_code == 0 and json.loads(result.stdout)["passes_requested"] == 1


def test_gate_file_beats_the_config_and_options_beat_both(project, mesh, tmp_path):
    (project / "pyproject.toml").write_text("[tool.anglesmooth.gates]\nmin_angle = 60\nmax_angle = 179\n")
    gates = tmp_path / "gates.toml"
    gates.write_text("min_angle = 0.5\n")

    def thresholds(*args):
        result = run("check", mesh, "--json", "-", "-q", *args)
        return {g["name"]: g["threshold"] for g in json.loads(result.stdout)["files"][0]["gates"]}

    assert thresholds()["min_angle"] == 60
    assert thresholds("--gate-file", gates) == {"min_angle": 0.5, "max_angle": 179, "max_inverted": 0,
                                                "max_degenerate": 0}
    assert thresholds("--gate-file", gates, "--min-angle", "7")["min_angle"] == 7


def test_explicit_config_file(project, mesh, tmp_path):
    (project / "pyproject.toml").write_text(PYPROJECT)
    other = tmp_path / "ci.toml"
    other.write_text('method = "smart-laplacian"\npasses = 2\n')
    doc = smooth_json(mesh, tmp_path, "--config", other)
    assert (doc["method"], doc["passes_requested"], doc["gates"]) == ("smart-laplacian", 2, [])
    doc = smooth_json(mesh, tmp_path, f"--config={other}", "-n", "3")
    assert doc["passes_requested"] == 3
    # a pyproject-style file under another name
    other.write_text('[project]\nname = "y"\n[tool.anglesmooth]\npasses = 4\n')
    assert smooth_json(mesh, tmp_path, "--config", other)["passes_requested"] == 4
    result = run("check", mesh, "--config", tmp_path / "missing.toml")
    assert result.exit_code == 2 and "cannot read configuration" in one_error_line(result)


def test_config_format_github(project, mesh):
    (project / "anglesmooth.toml").write_text('format = "github"\n[gates]\nmin_angle = 60\n')
    result = run("check", mesh)
    assert result.exit_code == 1 and result.stdout.splitlines()[0].startswith("::error file=")
    assert run("check", mesh, "--format", "table").stdout == ""


@pytest.mark.parametrize(
    "text,needle",
    [
        ("pases = 3\n", "unknown key 'pases'"),
        ('method = "bogus"\n', "method: 'bogus' is not one of"),
        ('order = "random"\n', "order: 'random' is not one of"),
        ('fix-nodes = "missing.txt"\n', "fix-nodes:"),
        ("[gates]\nmax_inverted = 0.5\n", "max_inverted must be a non-negative integer"),
    ],
)
def test_bad_config_is_a_usage_error_on_every_command(project, mesh, tmp_path, text, needle):
    (project / "anglesmooth.toml").write_text(text)
    for args in ([mesh, tmp_path / "o.vtu"], ["check", mesh], ["compare", mesh]):
        result = run(*args)
        assert result.exit_code == 2, (args, result.stderr)
        line = one_error_line(result)
        assert needle in line and str(project / "anglesmooth.toml") in line
    assert not (tmp_path / "o.vtu").exists()
    assert run("check", mesh, "--no-config").exit_code == 0  # the way out
    assert run("check", "--help").exit_code == 0  # help still works


def test_no_configuration_in_a_removed_working_directory(tmp_path, monkeypatch, mesh):
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    assert find_config() is None
    assert run("check", mesh).exit_code == 0
