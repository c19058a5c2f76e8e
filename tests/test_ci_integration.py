"""CI integration (issue 15): the pre-commit hook, ``--format github``, ``--junit-xml``, safe default gates,
readable gate messages, progress lines in CI logs."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml
from cli_runner import cli_runner
from reference import cells_of, corner_angle

import anglesmooth
from anglesmooth import build_topology, write
from anglesmooth.cli import cli
from anglesmooth.cli import formats
from anglesmooth.cli import outputs as cli_outputs
from anglesmooth.gates import Gate, evaluate, worst_cell
from anglesmooth.generate import paper_mixed_mesh, paper_triangle_mesh, structured_triangles
from anglesmooth.quality import summarize

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"


def run(*args, input=None):
    return cli_runner().invoke(cli, [str(a) for a in args], input=input)


def tangled_mesh() -> anglesmooth.Mesh2D:
    """One interior node pushed across its ring: inverted cells."""
    pts = structured_triangles(6, 6).points.copy()
    pts[24] += [1.6, 0.1]
    return anglesmooth.Mesh2D.from_arrays(pts, triangles=structured_triangles(6, 6).triangles)


def sliver_mesh() -> anglesmooth.Mesh2D:
    """A unit square of two triangles and a third, valid (positive area) but degenerate, sliver triangle."""
    pts = [[0, 0], [1, 0], [1, 1], [0, 1], [2, 0.5], [2, 0.5 + 1e-14]]
    return anglesmooth.Mesh2D.from_arrays(pts, triangles=[[0, 1, 2], [0, 2, 3], [1, 4, 5]])


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    d = tmp_path_factory.mktemp("ci")
    paths = {"good": d / "good.msh", "mixed": d / "mixed.vtu", "tangled": d / "tangled.vtu", "sliver": d / "sliver.vtu"}
    write(paper_triangle_mesh(seed=0), paths["good"])
    write(paper_mixed_mesh(seed=2, n_interior=80, per_side=8), paths["mixed"])
    write(tangled_mesh(), paths["tangled"])
    write(sliver_mesh(), paths["sliver"])
    return paths


# ------------------------------------------------------------------ item 5: safe defaults


def test_check_fails_on_inverted_cells_without_any_threshold(meshes):
    result = run("check", meshes["tangled"])
    assert result.exit_code == 1
    (line,) = [x for x in result.stderr.splitlines() if "gate" in x and "failed" in x]
    inverted = summarize(tangled_mesh().points, build_topology(tangled_mesh()))["inverted"]
    assert re.fullmatch(rf"{re.escape(str(meshes['tangled']))}: gate max_inverted failed: {inverted} > 0 "
                        r"\(first cell \d+\)", line)
    assert run("check", meshes["tangled"], "--max-inverted", str(inverted)).exit_code == 0
    assert run("check", meshes["tangled"], "--max-inverted", str(inverted - 1)).exit_code == 1
    assert run("check", meshes["tangled"], "--exit-zero").exit_code == 0


def test_check_fails_on_degenerate_cells_without_any_threshold(meshes):
    summary = summarize(sliver_mesh().points, build_topology(sliver_mesh()))
    assert summary["inverted"] == 0 and summary["degenerate"] == 1  # valid orientation, zero area in practice
    result = run("check", meshes["sliver"])
    assert result.exit_code == 1
    assert f"{meshes['sliver']}: gate max_degenerate failed: 1 > 0 (first cell 2)" in result.stderr.splitlines()
    assert run("check", meshes["sliver"], "--max-degenerate", "1").exit_code == 0


def test_check_of_a_good_mesh_passes_the_default_gates(meshes):
    result = run("check", meshes["good"], "--json", "-")
    assert result.exit_code == 0
    doc = json.loads(result.stdout)
    assert [(g["name"], g["threshold"], g["passed"]) for g in doc["files"][0]["gates"]] == [
        ("max_inverted", 0, True), ("max_degenerate", 0, True)]
    assert f"{meshes['good']}: all 2 gates passed" in result.stderr


# ------------------------------------------------------------------ item 6: gate messages


@pytest.mark.parametrize(
    "name,value,threshold,expected",
    [
        ("min_angle", 41.36314, 41.3632, "41.3631° < 41.3632°"),  # not 41.4 < 41.4
        ("min_angle", 19.99999, 20, "19.99999° < 20°"),  # not 20.0 < 20
        ("min_angle", 12.34, 20, "12.3° < 20°"),
        ("max_angle", 150.04, 150, "150.04° > 150°"),
        ("max_angle", 150.000001, 150.0, "150.000001° > 150°"),
        ("max_area_ratio", 1234.5678, 1234.567, "1234.568 > 1234.567"),
        ("max_aspect_ratio", 1e30, 1e6, "1e+30 > 1000000"),
        ("max_inverted", 3.0, 0, "3 > 0"),
    ],
)
def test_gate_values_print_with_enough_digits_to_differ(name, value, threshold, expected):
    key = {"max_inverted": "inverted", "max_area_ratio": "area_ratio"}.get(name, name)
    summary = {key: value}
    if name == "max_aspect_ratio":
        summary = {"tri_aspect_ratio": {"min": 1.0, "mean": 2.0, "max": value}, "quad_aspect_ratio": None}
    (gate,) = evaluate(summary, {name: threshold})
    assert not gate.passed and gate.comparison() == expected


def test_worst_cell_is_the_cell_with_the_smallest_angle():
    """Against a per-cell loop with acos (tests/reference/) on a valid mesh."""
    mesh = paper_mixed_mesh(seed=3, n_interior=60, per_side=6)
    topo = build_topology(mesh)
    p = mesh.points.tolist()
    per_cell = [min(corner_angle(p, c[k], c[k - 1], c[(k + 1) % len(c)]) for k in range(len(c)))
                for c in cells_of(topo)]
    expected = min(range(len(per_cell)), key=per_cell.__getitem__)
    summary = summarize(mesh.points, topo)
    assert math.degrees(per_cell[expected]) == pytest.approx(summary["min_angle"], abs=1e-9)
    (gate,) = evaluate(summary, {"min_angle": 89.0}, mesh.points, topo)
    assert gate.cell == expected and gate.message("m.vtu").endswith(f"(worst cell {expected})")
    (passed,) = evaluate(summary, {"min_angle": 0.0}, mesh.points, topo)
    assert passed.cell is None  # computed for failures only
    areas = [abs(sum(p[c[k]][0] * p[c[(k + 1) % len(c)]][1] - p[c[(k + 1) % len(c)]][0] * p[c[k]][1]
                     for k in range(len(c)))) / 2 for c in cells_of(topo)]
    assert worst_cell(mesh.points, topo, "max_area_ratio") == min(range(len(areas)), key=areas.__getitem__)


def test_worst_cell_on_the_command_line_matches_the_json(meshes):
    result = run("check", meshes["mixed"], "--min-angle", "60", "--json", "-")
    assert result.exit_code == 1
    gate = next(g for g in json.loads(result.stdout)["files"][0]["gates"] if g["name"] == "min_angle")
    assert f"gate min_angle failed: {Gate(**gate).comparison()} (worst cell {gate['cell']})" in result.stderr


# ------------------------------------------------------------------ item 2: --format github


def test_escaping_follows_the_actions_toolkit():
    assert formats.escape_data("100% done\r\nnext: a,b") == "100%25 done%0D%0Anext: a,b"
    assert formats.escape_property("dir:a,b%\n.vtu") == "dir%3Aa%2Cb%25%0A.vtu"


ERROR_LINE = re.compile(r"::error file=(?P<file>[^,:]+),title=anglesmooth (?P<gate>\w+)::value (?P<value>[\d.]+)"
                        r"(?P<unit>°?) (?P<op>[<>]) (?P<threshold>[\d.]+)(?P=unit) \((?:worst|first) cell (?P<cell>\d+)\)")


def test_github_format_line_by_line(meshes, tmp_path):
    js = tmp_path / "r.json"
    result = run("check", meshes["good"], meshes["tangled"], "--min-angle", "25", "--format", "github", "--json", js)
    assert result.exit_code == 1
    doc = json.loads(js.read_text())
    failed = [(e["input"], g) for e in doc["files"] for g in e["gates"] if not g["passed"]]
    lines = result.stdout.splitlines()
    assert len(lines) == len(failed) + 1 and len(failed) >= 3  # min_angle on both files, max_inverted on one
    for line, (file, gate) in zip(lines, failed):
        m = ERROR_LINE.fullmatch(line)
        assert m, line
        assert m["file"] == file and m["gate"] == gate["name"] and int(m["cell"]) == gate["cell"]
        assert float(m["threshold"]) == gate["threshold"]
        assert float(m["value"]) == pytest.approx(gate["value"], abs=0.051)
        assert (m["op"] == "<") == (gate["name"] == "min_angle") and (m["unit"] == "°") == (gate["name"] == "min_angle")
    assert lines[-1] == f"::notice title=anglesmooth::2 files: 0 passed, 2 failed ({len(failed)} gates)"
    assert "gate min_angle failed" not in result.stderr  # the annotations replace the plain lines


def test_github_format_escapes_file_names_and_reports_unreadable_files(meshes, tmp_path):
    odd = tmp_path / "a,b:c%.vtu"
    odd.write_bytes(meshes["tangled"].read_bytes())
    result = run("check", odd, tmp_path / "missing.vtu", "--format", "github")
    assert result.exit_code == 3
    lines = result.stdout.splitlines()
    escaped = str(odd).replace("%", "%25").replace(":", "%3A").replace(",", "%2C")
    assert lines[0].startswith(f"::error file={escaped},title=anglesmooth max_inverted::value ")
    assert lines[1] == (f"::error file={tmp_path / 'missing.vtu'},title=anglesmooth::"
                        f"cannot read '{tmp_path / 'missing.vtu'}': no such file")
    assert lines[2] == "::notice title=anglesmooth::2 files: 0 passed, 1 failed (1 gate), 1 unreadable"


def test_github_format_stays_within_the_annotation_limit(meshes, tmp_path):
    copies = []
    for i in range(5):
        path = tmp_path / f"t{i}.vtu"
        path.write_bytes(meshes["tangled"].read_bytes())
        copies.append(path)
    # 3 failed gates per file (min_angle, max_angle, max_inverted): 15 failures
    result = run("check", *copies, "--min-angle", "30", "--max-angle", "100", "--format", "github")
    assert result.exit_code == 1
    lines = result.stdout.splitlines()
    errors = [x for x in lines if x.startswith("::error ")]
    plain = [x for x in lines if not x.startswith("::")]
    assert len(errors) == formats.GITHUB_MAX_ERRORS == 10
    assert len(plain) == 5 and all(re.fullmatch(r".+: gate \w+ failed: .+", x) for x in plain)
    assert lines[-1] == ("::notice title=anglesmooth::5 files: 0 passed, 5 failed (15 gates); 5 more failure(s) "
                         "in the log only (GitHub shows 10 error annotations per step)")
    assert sum(x.startswith("::notice") for x in lines) == 1


def test_github_format_goes_to_stderr_when_stdout_carries_the_report(meshes):
    result = run("check", meshes["tangled"], "--format", "github", "--json", "-")
    assert result.exit_code == 1
    json.loads(result.stdout)  # only the JSON document on stdout
    assert any(x.startswith("::error file=") for x in result.stderr.splitlines())


@pytest.mark.parametrize("report", [["--json", "/dev/stdout"], ["--junit-xml", "/dev/fd/1"]])
def test_github_format_goes_to_stderr_when_a_report_names_stdout_by_path(meshes, report):
    """--json /dev/stdout is stdout as much as --json -: the workflow commands must not land inside the JSON."""
    proc = subprocess.run([sys.executable, "-m", "anglesmooth", "check", str(meshes["tangled"]), "--format", "github",
                           "-q", *report], capture_output=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(SRC)})
    assert proc.returncode == 1, proc.stderr
    out = proc.stdout.decode()
    assert "::" not in out
    if report[0] == "--json":
        json.loads(out)
    else:
        ET.fromstring(out)
    assert any(x.startswith("::error file=") for x in proc.stderr.decode().splitlines())


def test_github_format_on_smoothing_with_gates(meshes, tmp_path):
    out = tmp_path / "o.vtu"
    result = run(meshes["mixed"], out, "-n", "2", "--min-angle", "89", "--format", "github", "-q")
    assert result.exit_code == 1 and out.exists()
    lines = result.stdout.splitlines()
    assert ERROR_LINE.fullmatch(lines[0])["file"] == str(out)
    assert lines[-1] == "::notice title=anglesmooth::1 file: 0 passed, 1 failed (1 gate)"
    # no gates: no annotations at all
    result = run(meshes["mixed"], out, "-n", "1", "--format", "github", "-q")  # OUTPUT exists: replaced
    assert result.exit_code == 0 and result.stdout == ""


# ------------------------------------------------------------------ item 2: --junit-xml


def test_junit_xml_for_check(meshes, tmp_path):
    junit = tmp_path / "junit.xml"
    files = [meshes["good"], meshes["tangled"], tmp_path / "missing.vtu"]
    result = run("check", *files, "--min-angle", "25", "--junit-xml", junit)
    assert result.exit_code == 3
    root = ET.parse(junit).getroot()
    assert root.tag == "testsuites"
    (suite,) = root.findall("testsuite")
    cases = suite.findall("testcase")
    # every readable file x (min_angle, max_inverted, max_degenerate), one error case for the unreadable one
    assert [(c.get("classname"), c.get("name")) for c in cases] == [
        *[(str(f), g) for f in files[:2] for g in ("min_angle", "max_inverted", "max_degenerate")],
        (str(files[2]), "read")]
    failures = {(c.get("classname"), c.get("name")): c.find("failure") for c in cases if c.find("failure") is not None}
    assert set(failures) == {(str(files[0]), "min_angle"), (str(files[1]), "min_angle"), (str(files[1]), "max_inverted")}
    message = failures[(str(files[0]), "min_angle")].get("message")
    assert re.fullmatch(r"min_angle: [\d.]+° < 25° \(worst cell \d+\)", message)
    assert "threshold: 25" in failures[(str(files[0]), "min_angle")].text
    assert cases[-1].find("error").get("message") == f"cannot read '{files[2]}': no such file"
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("7", "3", "1")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["junit.xml"]  # staged and renamed, nothing else


def test_junit_xml_for_smoothing_and_bad_paths(meshes, tmp_path):
    junit, out = tmp_path / "s.xml", tmp_path / "o.vtu"
    result = run(meshes["mixed"], out, "-n", "1", "--min-angle", "1", "--junit-xml", junit, "-q")
    assert result.exit_code == 0
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite.get("name") == "anglesmooth smooth" and suite.get("failures") == "0"
    assert [c.get("name") for c in suite.findall("testcase")] == ["min_angle", "max_inverted", "max_degenerate"]
    assert all(c.get("classname") == str(out) for c in suite.findall("testcase"))
    # an unwritable JUnit path: exit 3 before any work, nothing written
    result = run("check", meshes["good"], "--junit-xml", tmp_path / "nodir" / "j.xml")
    assert result.exit_code == 3 and "cannot write JUnit XML" in result.stderr
    result = run("check", meshes["good"], "--junit-xml", "-")
    assert result.exit_code == 2 and "--junit-xml needs a file path" in result.stderr


def test_format_choices_come_from_the_registry():
    for command in ("check", "smooth"):
        text = run(command, "--help").stdout
        assert all(name in text for name in formats.FORMATS) and "--junit-xml" in text


# ------------------------------------------------------------------ item 8: progress in CI logs


def test_progress_lines_when_stderr_is_not_a_terminal(meshes, tmp_path, monkeypatch):
    out = tmp_path / "o.vtu"
    monkeypatch.setattr(cli_outputs, "PROGRESS_EVERY_S", 0.0)
    result = run(meshes["mixed"], out, "-n", "3", "--progress")  # OUTPUT exists after the 1st: replaced
    lines = [x for x in result.stderr.splitlines() if x.startswith("smoothing:")]
    assert lines[0].startswith("smoothing: up to 3 passes over ")
    assert [re.match(r"smoothing: pass (\d)/3, displacement \S+, [\d.]+ s$", x)[1] for x in lines[1:]] == ["1", "2", "3"]
    monkeypatch.setattr(cli_outputs, "PROGRESS_EVERY_S", 3600.0)
    result = run(meshes["mixed"], out, "-n", "3", "--progress")  # OUTPUT exists after the 1st: replaced
    lines = [x for x in result.stderr.splitlines() if x.startswith("smoothing:")]
    assert len(lines) == 2 and lines[1].startswith("smoothing: pass 3/3")  # the start and the last pass only
    for args in ([], ["--no-progress"], ["--progress", "-q"]):
        result = run(meshes["mixed"], out, "-n", "3", *args)
        assert "smoothing:" not in result.stderr


# ------------------------------------------------------------------ item 1: pre-commit


def _hook() -> dict:
    (hook,) = yaml.safe_load((ROOT / ".pre-commit-hooks.yaml").read_text())
    return hook


def test_hook_definition():
    hook = _hook()
    assert hook["id"] == "anglesmooth-check" and hook["entry"] == "anglesmooth check"
    assert hook["pass_filenames"] is True
    pattern = re.compile(hook["files"])
    for name in ("a.msh", "dir/b.vtu", "c.vtk", "d.xdmf", "e.inp", "f.med", "g.su2", "h.mesh"):
        assert pattern.search(name), name
    for name in ("README.md", "notes.txt", "data.xml", "model.stl", "mesh.vtu.bak"):
        assert not pattern.search(name), name
    # every suffix of the pattern is one meshio reads
    import meshio._helpers

    suffixes = re.fullmatch(r"\\\.\((.*)\)\$", hook["files"])[1].split("|")
    assert {f".{s}" for s in suffixes} <= set(meshio._helpers.extension_to_filetypes)


def test_pre_commit_runs_the_hook_on_mesh_files(meshes, tmp_path):
    """A git repository with a ``repo: local`` hook made from .pre-commit-hooks.yaml, run by pre-commit itself.

    ``language: system`` runs ``entry`` from PATH: a shim named ``anglesmooth`` put first on PATH runs this
    checkout's code (and logs its arguments); nothing is installed and nothing needs the network.
    """
    repo, home, bin_dir = tmp_path / "repo", tmp_path / "home", tmp_path / "bin"
    for d in (repo, home, bin_dir):
        d.mkdir()
    log = tmp_path / "argv.log"
    shim = bin_dir / "anglesmooth"
    shim.write_text(f"#!{sys.executable}\nimport os, sys\n"
                    f"open({str(log)!r}, 'a').write(' '.join(sys.argv[1:]) + '\\n')\n"
                    f"os.execv(sys.executable, [sys.executable, '-m', 'anglesmooth', *sys.argv[1:]])\n")
    shim.chmod(0o755)
    hook = {**_hook(), "language": "system"}
    (repo / ".pre-commit-config.yaml").write_text(yaml.safe_dump({"repos": [{"repo": "local", "hooks": [hook]}]}))
    (repo / "meshes").mkdir()
    (repo / "meshes" / "good.msh").write_bytes(meshes["good"].read_bytes())
    (repo / "README.md").write_text("not a mesh\n")
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}", "PYTHONPATH": str(SRC),
           "HOME": str(home), "PRE_COMMIT_HOME": str(home / "pre-commit"), "GIT_CONFIG_NOSYSTEM": "1",
           "PIP_NO_INDEX": "1", "NO_COLOR": "1"}

    def git(*args):
        subprocess.run(["git", *args], cwd=repo, env=env, check=True, capture_output=True)

    def pre_commit():
        return subprocess.run([sys.executable, "-m", "pre_commit", "run", "--all-files", "--color", "never"],
                              cwd=repo, env=env, capture_output=True, text=True, timeout=120)

    git("init", "-q")
    git("add", ".")
    proc = pre_commit()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert re.search(r"anglesmooth check\.+Passed", proc.stdout)
    assert log.read_text().splitlines() == ["check meshes/good.msh"]  # README.md not passed

    (repo / "meshes" / "tangled.vtu").write_bytes(meshes["tangled"].read_bytes())
    git("add", ".")
    log.unlink()
    proc = pre_commit()
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert re.search(r"anglesmooth check\.+Failed", proc.stdout)
    assert "meshes/tangled.vtu: gate max_inverted failed: " in proc.stdout
    assert sorted(log.read_text().split()) == ["check", "meshes/good.msh", "meshes/tangled.vtu"]

    # gates from the repository's pyproject.toml apply (config discovery from the working directory)
    (repo / "meshes" / "tangled.vtu").unlink()
    (repo / "pyproject.toml").write_text("[tool.anglesmooth.gates]\nmin_angle = 89\n")
    git("add", "-A")
    proc = pre_commit()
    assert proc.returncode == 1 and "meshes/good.msh: gate min_angle failed: " in proc.stdout
    assert np.isfinite(float(re.search(r"failed: ([\d.]+)° < 89°", proc.stdout)[1]))
