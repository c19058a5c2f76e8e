"""The command line end to end, through click's CliRunner (and a few real subprocesses).

Every test writes into ``tmp_path`` only.  Meshes are small (about 1000 cells),
so the whole module runs in a few seconds.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import meshio
import numpy as np
import pytest
from cli_runner import cli_runner, digest

import anglesmooth
from anglesmooth import SMOOTHERS, build_topology, read, write
from anglesmooth.cli import smooth as cli_module
from anglesmooth.cli import cli
from anglesmooth.cli import outputs as cli_outputs
from anglesmooth.generate import paper_mixed_mesh, paper_triangle_mesh, random_delaunay, structured_triangles
from anglesmooth.report import SCHEMA_VERSION

REQUIRED_SUMMARY = {
    "min_angle", "max_angle", "angles_below_20", "angles_above_130", "angles_above_150", "min_area", "max_area",
    "area_ratio", "inverted", "nonconvex_quads", "nodes", "triangles", "quads", "fixed_nodes",
}
SMOOTH_KEYS = {
    "schema_version", "anglesmooth_version", "input", "output", "method", "guard", "order", "passes",
    "passes_requested", "displacement", "rejected", "before", "after", "elapsed_s", "compile_s", "gates", "passed",
}




def run(*args, input=None):
    return cli_runner().invoke(cli, [str(a) for a in args], input=input)


def one_error_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("anglesmooth: error: ")
    assert "Traceback" not in result.stderr
    return lines[0]


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    d = tmp_path_factory.mktemp("meshes")
    paths = {"msh": d / "tri.msh", "vtu": d / "mixed.vtu", "grouped": d / "grouped.vtu", "tangled": d / "tangled.vtu"}
    write(paper_triangle_mesh(seed=0), paths["msh"])
    write(paper_mixed_mesh(seed=0), paths["vtu"])
    # a jittered triangle grid whose left half is the cell set "patch"
    base = structured_triangles(8, 8)
    pts = base.points.copy()
    interior = ~build_topology(base).boundary
    pts[interior] += np.random.default_rng(1).uniform(-0.2, 0.2, (int(interior.sum()), 2))
    centroid_x = pts[base.triangles].mean(axis=1)[:, 0]
    patch = (centroid_x < 4).astype(np.int32)
    meshio.write(paths["grouped"], meshio.Mesh(pts, [("triangle", base.triangles)], cell_data={"set:patch": [patch]}))
    # one interior node pushed across its ring: several inverted cells
    tangled = structured_triangles(6, 6).points.copy()
    tangled[24] += [1.6, 0.1]
    write(anglesmooth.Mesh2D.from_arrays(tangled, triangles=structured_triangles(6, 6).triangles), paths["tangled"])
    return paths


# ------------------------------------------------------------------ basics


def test_help_lists_commands_and_default_usage():
    result = run("--help")
    assert result.exit_code == 0
    for word in ("check", "compare", "smooth", "INPUT [OUTPUT]", "Exit codes"):
        assert word in result.stdout


@pytest.mark.parametrize("command", ["smooth", "check", "compare", "schema"])
def test_help_of_every_command_is_clean(command):
    """No click artefacts in --help (an unbounded number range was shown as '[x<=None]')."""
    result = run(command, "--help")
    assert result.exit_code == 0 and result.stdout.startswith("Usage: ") and f" {command} " in result.stdout
    assert "None" not in result.stdout


def test_version():
    result = run("--version")
    assert result.exit_code == 0 and anglesmooth.__version__ in result.stdout


def test_method_choices_come_from_registry():
    result = run("smooth", "--help")
    assert all(name in result.stdout for name in SMOOTHERS)


def test_smooth_default_command(meshes, tmp_path):
    out = tmp_path / "out.vtu"
    result = run(meshes["msh"], out)
    assert result.exit_code == 0, result.stderr
    assert out.exists()
    assert result.stdout == ""  # stdout stays clean
    for row in ("min angle", "fixed nodes", "rejected moves", "passes performed", "last displacement", "before"):
        assert row in result.stderr
    assert read(out).n_cells == read(meshes["msh"]).n_cells


def test_smooth_gives_freed_memory_back_before_the_passes_and_before_the_last_summary(meshes, tmp_path, monkeypatch):
    # the build's and the summary's temporaries stay in glibc's heap otherwise (1M triangles: 30 MB of
    # peak), and the passes' ones before the summary of the result
    calls = []
    monkeypatch.setattr(cli_module, "release_free_memory", lambda: calls.append(1) or True)
    monkeypatch.setattr(cli_module, "run_smooth", _after(calls, cli_module.run_smooth))
    result = run(meshes["msh"], tmp_path / "out.vtu", "--quiet")
    assert result.exit_code == 0, result.stderr
    assert calls == [1, "passes", 1]


def _after(calls, fn):
    def wrapped(*args, **kwargs):
        calls.append("passes")
        return fn(*args, **kwargs)

    return wrapped


def test_release_free_memory_is_safe_to_call():
    from anglesmooth import _memory

    assert _memory.release_free_memory() in (True, False)
    if sys.platform.startswith("linux") and os.path.exists("/lib/x86_64-linux-gnu/libc.so.6"):
        assert _memory.release_free_memory() is True  # glibc has malloc_trim


def test_smooth_subcommand_and_quiet(meshes, tmp_path):
    result = run("smooth", meshes["vtu"], tmp_path / "out.msh", "--quiet", "--method", "laplacian")
    assert result.exit_code == 0
    assert result.stdout == "" and result.stderr == ""


def test_json_to_stdout_is_the_only_stdout(meshes, tmp_path):
    result = run(meshes["msh"], tmp_path / "o.vtu", "--json", "-", "--passes", "3", "--order", "jacobi")
    assert result.exit_code == 0
    doc = json.loads(result.stdout)
    assert SMOOTH_KEYS <= set(doc)
    assert REQUIRED_SUMMARY <= set(doc["before"]) and REQUIRED_SUMMARY <= set(doc["after"])
    assert doc["schema_version"] == SCHEMA_VERSION == 1
    assert doc["anglesmooth_version"] == anglesmooth.__version__
    assert (doc["method"], doc["order"], doc["guard"], doc["passes_requested"]) == ("angle", "jacobi", True, 3)
    assert doc["passes"] <= 3 and doc["gates"] == [] and doc["passed"] is True
    assert doc["after"]["min_angle"] > doc["before"]["min_angle"]
    assert "min angle" in result.stderr  # the table still goes to stderr


def test_json_file_and_no_guard(meshes, tmp_path):
    report = tmp_path / "r.json"
    result = run(meshes["vtu"], tmp_path / "o.vtu", "--json", report, "--no-guard", "-m", "laplacian", "-q")
    assert result.exit_code == 0 and result.stdout == ""
    doc = json.loads(report.read_text())
    assert doc["guard"] is False and doc["method"] == "laplacian"


def test_tol_stops_early(meshes, tmp_path):
    result = run(meshes["msh"], tmp_path / "o.vtu", "--tol", "1e9", "--json", "-", "-q")
    doc = json.loads(result.stdout)
    assert doc["passes"] == 1 and doc["passes_requested"] == 10


def test_no_free_node_reports_no_pass(tmp_path):
    src = tmp_path / "square.vtu"
    write(anglesmooth.Mesh2D.from_arrays([[0, 0], [1, 0], [1, 1], [0, 1]], triangles=[[0, 1, 2], [0, 2, 3]]), src)
    result = run(src, tmp_path / "o.vtu", "--json", "-")
    doc = json.loads(result.stdout)
    assert result.exit_code == 0, result.stderr
    assert doc["passes"] == 0 and doc["passes_requested"] == 10 and doc["displacements"] == []
    assert "nothing to smooth" in result.stderr


def test_forced_progress_bar(meshes, tmp_path):
    result = run(meshes["msh"], tmp_path / "o.vtu", "--progress", "--passes", "2")
    assert result.exit_code == 0 and result.stdout == ""


def test_fixed_nodes_bit_identical(meshes, tmp_path):
    out = tmp_path / "o.msh"
    assert run(meshes["vtu"], out, "-q").exit_code == 0
    before, after = read(meshes["vtu"]), read(out)
    fixed = build_topology(before).fixed
    assert fixed.any() and (~fixed).any()
    assert np.array_equal(before.points[fixed], after.points[fixed])
    assert not np.array_equal(before.points[~fixed], after.points[~fixed])


# ------------------------------------------------------------------ fixed groups / nodes


def _fixed_count(*args) -> int:
    result = run(*args, "--json", "-", "-q", "--force")  # --force: the same OUTPUT (of the input's format) each time
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)["before"]["fixed_nodes"]


def test_fix_group_and_fix_nodes_increase_fixed_count(meshes, tmp_path):
    out = tmp_path / "o.vtu"
    plain = _fixed_count(meshes["grouped"], out)
    with_group = _fixed_count(meshes["grouped"], out, "--fix-group", "patch")
    nodes = tmp_path / "nodes.txt"
    free = np.flatnonzero(~build_topology(read(meshes["grouped"])).fixed)[:5]
    nodes.write_text("# extra nodes\n" + " ".join(map(str, free)) + "\n")
    with_nodes = _fixed_count(meshes["grouped"], out, "--fix-nodes", nodes)
    assert with_group > plain and with_nodes == plain + 5
    assert np.array_equal(read(out).points[free], read(meshes["grouped"]).points[free])


def test_unknown_group_lists_available(meshes, tmp_path):
    result = run(meshes["grouped"], tmp_path / "o.vtu", "--fix-group", "nope")
    assert result.exit_code == 2
    assert "patch" in one_error_line(result)
    assert not (tmp_path / "o.vtu").exists()


@pytest.mark.parametrize("content", ["1 2 x", "99999"])
def test_bad_fix_nodes_file(meshes, tmp_path, content):
    nodes = tmp_path / "nodes.txt"
    nodes.write_text(content)
    result = run(meshes["msh"], tmp_path / "o.vtu", "--fix-nodes", nodes)
    assert result.exit_code == 2
    one_error_line(result)
    assert not (tmp_path / "o.vtu").exists()


# ------------------------------------------------------------------ overwrite rules


def test_overwrite_input_needs_force(meshes, tmp_path):
    src = tmp_path / "m.msh"
    shutil.copy(meshes["msh"], src)
    h = digest(src)
    result = run(src, src)
    assert result.exit_code == 2 and "--force" in one_error_line(result)
    assert digest(src) == h
    assert run(src, src, "--force", "-q").exit_code == 0
    assert digest(src) != h


def test_in_place(meshes, tmp_path):
    src = tmp_path / "m.vtu"
    shutil.copy(meshes["vtu"], src)
    h = digest(src)
    assert run(src, "-", "--in-place").exit_code == 2  # no stdout with --in-place (two files: tests/test_batch.py)
    assert digest(src) == h
    result = run(src, "--in-place", "-q")
    assert result.exit_code == 0 and digest(src) != h
    assert sorted(os.listdir(tmp_path)) == ["m.vtu"]  # no temporary files left


def test_in_place_refuses_another_format(meshes, tmp_path):
    """--in-place --output-format vtu on a .msh wrote VTU into the .msh: the input was lost. Another MSH version
    (or the format a configuration file names, when it is the input's) is still the input's format."""
    src = tmp_path / "m.msh"
    shutil.copy(meshes["msh"], src)
    h = digest(src)
    one = run(src, "--in-place", "--output-format", "vtu")  # one file
    shutil.copy(src, tmp_path / "m2.msh")
    many = run(src, tmp_path / "m2.msh", "--in-place", "--output-format", "vtk")  # several files
    (tmp_path / "m2.msh").unlink()
    for result in (one, many):
        assert result.exit_code == 2
        line = [x for x in result.stderr.splitlines() if x.startswith("anglesmooth: error: ")][0]
        assert "--in-place keeps the format of" in line and "would write another format under its name" in line
    assert digest(src) == h and sorted(os.listdir(tmp_path)) == ["m.msh"]
    result = run(src, "--in-place", "--output-format", "gmsh22", "-q")
    assert result.exit_code == 0 and src.read_bytes().startswith(b"$MeshFormat\n2.2")


# ------------------------------------------------------------------ pipelines


@pytest.mark.parametrize("fmt,key,magic", [("gmsh", "msh", b"$MeshFormat"), ("vtu", "vtu", b"<?xml")])
def test_stdin_stdout_round_trip(meshes, tmp_path, fmt, key, magic):
    data = meshes[key].read_bytes()
    result = cli_runner().invoke(cli, ["-", "-", "--input-format", fmt, "--output-format", fmt], input=data)
    assert result.exit_code == 0, result.stderr
    assert result.stdout_bytes.startswith(magic)
    assert "min angle" in result.stderr
    out = tmp_path / f"piped.{key}"
    out.write_bytes(result.stdout_bytes)
    before, after = read(meshes[key]), read(out)
    assert np.array_equal(before.triangles, after.triangles) and np.array_equal(before.quads, after.quads)
    fixed = build_topology(before).fixed
    assert np.array_equal(before.points[fixed], after.points[fixed])
    file_run = tmp_path / f"file.{key}"
    assert run(meshes[key], file_run, "-q").exit_code == 0
    assert np.array_equal(read(file_run).points, after.points)  # same result as through files


def test_check_from_stdin_with_json(meshes):
    result = cli_runner().invoke(cli, ["check", "-", "--input-format", "gmsh", "--json", "-"],
                              input=meshes["msh"].read_bytes())
    assert result.exit_code == 0
    assert json.loads(result.stdout)["files"][0]["input"] == "<stdin>"


@pytest.mark.parametrize(
    "args,needle",
    [
        (["-", "{tmp}/o.vtu"], "--input-format"),
        (["{msh}", "-"], "--output-format"),
        (["{msh}", "-", "--output-format", "vtu", "--json", "-"], "stdout"),
        (["{msh}"], "OUTPUT"),
        (["-", "--in-place", "--input-format", "gmsh"], "--in-place"),
    ],
)
def test_usage_errors_after_parsing(meshes, tmp_path, args, needle):
    args = [a.format(tmp=tmp_path, msh=meshes["msh"]) for a in args]
    result = run(*args)
    assert result.exit_code == 2
    assert needle in one_error_line(result)
    assert result.stdout == ""


@pytest.mark.parametrize("command", ["check", "compare"])
def test_options_before_a_command_name_say_so(meshes, tmp_path, monkeypatch, command):
    """'anglesmooth --quiet check a.msh' implies smooth with INPUT 'check': was exit 3 'cannot read 'check''."""
    monkeypatch.chdir(tmp_path)
    result = run("--quiet", command, meshes["msh"])
    assert result.exit_code == 2
    assert f"to run the {command} command, give the options after its name" in one_error_line(result)
    assert os.listdir(tmp_path) == []
    shutil.copy(meshes["msh"], tmp_path / command)  # a mesh file of that name is still smoothed
    assert run("-q", command, "o.msh").exit_code == 0 and (tmp_path / "o.msh").exists()


@pytest.mark.parametrize("args", [["--method", "nope"], ["--passes", "-1"], ["--order", "random"], ["--bogus"],
                                  ["--tol", "nan"], ["--tol", "-1"]])
def test_click_usage_errors_exit_2(meshes, tmp_path, args):
    result = run(meshes["msh"], tmp_path / "o.vtu", *args)
    assert result.exit_code == 2
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "o.vtu").exists()


# ------------------------------------------------------------------ bad input / output -> 3


def test_missing_input(tmp_path):
    result = run(tmp_path / "missing.msh", tmp_path / "o.vtu")
    assert result.exit_code == 3
    assert "missing.msh" in one_error_line(result)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name,content", [("bad.msh", b"$MeshFormat\n2.2 0 8\ngarbage"), ("bad.vtu", b"\x00\x01 no"),
                                          ("empty.vtk", b"")])
def test_corrupt_input(tmp_path, name, content):
    (tmp_path / name).write_bytes(content)
    result = run(tmp_path / name, tmp_path / "o.vtu")
    assert result.exit_code == 3
    one_error_line(result)
    assert sorted(os.listdir(tmp_path)) == [name]


def test_unwritable_output(meshes, tmp_path):
    result = run(meshes["msh"], tmp_path / "no" / "such" / "dir" / "o.vtu")
    assert result.exit_code == 3
    one_error_line(result)


def test_unknown_output_extension(meshes, tmp_path):
    result = run(meshes["msh"], tmp_path / "o.unknownext")
    assert result.exit_code == 3
    one_error_line(result)
    assert os.listdir(tmp_path) == []


def test_tangled_input_warns_and_never_adds_inversions(meshes, tmp_path):
    result = run(meshes["tangled"], tmp_path / "o.vtu", "--json", "-")
    assert result.exit_code == 0
    assert "inverted" in result.stderr and "warning" in result.stderr
    doc = json.loads(result.stdout)
    assert doc["before"]["inverted"] > 0
    assert doc["after"]["inverted"] <= doc["before"]["inverted"]


# ------------------------------------------------------------------ failures inside: 4, 3, 130


def _boom(exc):
    def f(*a, **k):
        raise exc

    return f


@pytest.mark.parametrize(
    "exc,code,needle",
    [(RuntimeError("kaput"), 4, "internal error"), (MemoryError(), 3, "out of memory"),
     (KeyboardInterrupt(), 130, "interrupted")],
)
def test_unexpected_failures(meshes, tmp_path, monkeypatch, exc, code, needle):
    monkeypatch.setattr(cli_module, "run_smooth", _boom(exc))
    out = tmp_path / "o.vtu"
    result = run(meshes["msh"], out)
    assert result.exit_code == code
    assert needle in one_error_line(result)
    assert not out.exists()


def test_debug_shows_traceback(meshes, tmp_path, monkeypatch):
    monkeypatch.setattr(cli_module, "run_smooth", _boom(RuntimeError("kaput")))
    result = run(meshes["msh"], tmp_path / "o.vtu", "--debug")
    assert result.exit_code == 4 and "Traceback" in result.stderr


# ------------------------------------------------------------------ gates


GATES = [  # (option, passing threshold, failing threshold); the check runs on the unsmoothed input
    ("--min-angle", "0", "89"),
    ("--max-angle", "180", "91"),
    ("--max-area-ratio", "1e12", "1.0001"),
    ("--max-aspect-ratio", "1e12", "1.0"),
]


@pytest.mark.parametrize("option,ok,bad", GATES)
def test_each_gate_on_check(meshes, option, ok, bad):
    assert run("check", meshes["vtu"], option, ok).exit_code == 0
    result = run("check", meshes["vtu"], option, bad)
    assert result.exit_code == 1
    name = option[2:].replace("-", "_")
    failed = [line for line in result.stderr.splitlines() if "failed" in line]
    assert failed == [line for line in failed if line.startswith(f"{meshes['vtu']}: gate {name} failed: ")]
    assert len(failed) == 1


def test_max_inverted_gate(meshes):
    # no gate given: inverted cells still fail check (safe default since issue 15)
    result = run("check", meshes["tangled"])
    assert result.exit_code == 1 and "gate max_inverted failed" in result.stderr
    result = run("check", meshes["tangled"], "--max-angle", "360")  # any gate => max_inverted 0
    assert result.exit_code == 1 and "gate max_inverted failed" in result.stderr
    assert run("check", meshes["tangled"], "--max-inverted", "100").exit_code == 0
    assert run("check", meshes["msh"], "--max-inverted", "0").exit_code == 0


def test_gates_on_smoothing_apply_after_writing(meshes, tmp_path):
    out = tmp_path / "o.vtu"
    result = run(meshes["msh"], out, "--min-angle", "89", "--json", "-")
    assert result.exit_code == 1 and out.exists()
    doc = json.loads(result.stdout)
    assert doc["passed"] is False
    gate = {g["name"]: g for g in doc["gates"]}["min_angle"]
    assert gate == {"name": "min_angle", "threshold": 89.0, "value": doc["after"]["min_angle"], "passed": False,
                    "cell": gate["cell"]}
    assert isinstance(gate["cell"], int) and f"(worst cell {gate['cell']})" in result.stderr
    assert f"{out}: gate min_angle failed" in result.stderr
    result = run(meshes["msh"], out, "--min-angle", "89", "--exit-zero", "-q")
    assert result.exit_code == 0 and "gate min_angle failed" in result.stderr


def test_gate_file(meshes, tmp_path):
    gates = tmp_path / "gates.toml"
    gates.write_text("min_angle = 89\nmax_inverted = 0\n")
    assert run("check", meshes["msh"], "--gate-file", gates).exit_code == 1
    assert run("check", meshes["msh"], "--gate-file", gates, "--min-angle", "0").exit_code == 0  # option wins
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text("[project]\nname = 'x'\n[tool.anglesmooth.gates]\nmax_angle = 91\n")
    assert run("check", meshes["msh"], "--gate-file", pyproject).exit_code == 1


@pytest.mark.parametrize("content,needle", [("min_angel = 20\n", "min_angel"), ("min_angle = [\n", "TOML"),
                                            ("min_angle = 'x'\n", "min_angle")])
def test_bad_gate_file_is_usage_error(meshes, tmp_path, content, needle):
    gates = tmp_path / "gates.toml"
    gates.write_text(content)
    out = tmp_path / "o.vtu"
    for args in (["check", meshes["msh"]], [meshes["msh"], out]):
        result = run(*args, "--gate-file", gates)
        assert result.exit_code == 2
        assert needle in one_error_line(result)
    assert not out.exists()


# ------------------------------------------------------------------ check


def test_check_single_file_table(meshes):
    h = digest(meshes["msh"])
    result = run("check", meshes["msh"])
    assert result.exit_code == 0 and result.stdout == ""
    assert "min angle" in result.stderr and "area ratio" in result.stderr
    assert digest(meshes["msh"]) == h


def test_check_many_files_json_and_unreadable(meshes, tmp_path):
    missing = tmp_path / "missing.vtu"
    result = run("check", meshes["msh"], missing, meshes["vtu"], "--min-angle", "0", "--json", "-")
    assert result.exit_code == 3  # unreadable wins over everything
    doc = json.loads(result.stdout)
    assert doc["schema_version"] == 1 and doc["passed"] is False
    entries = doc["files"]
    assert [e["input"] for e in entries] == [str(meshes["msh"]), str(missing), str(meshes["vtu"])]
    assert set(entries[0]) == {"input", "report", "gates", "passed", "error"}
    assert entries[1]["error"] and entries[1]["report"] is None
    assert entries[0]["passed"] and entries[2]["passed"] and entries[0]["report"]["triangles"] > 0
    assert REQUIRED_SUMMARY <= set(entries[2]["report"])
    errors = [line for line in result.stderr.splitlines() if line.startswith("anglesmooth: error:")]
    assert len(errors) == 1 and "missing.vtu" in errors[0]
    assert "mixed.vtu" in result.stderr and "tri.msh" in result.stderr  # the others are reported
    # a failing gate alongside an unreadable file: still 3
    assert run("check", meshes["msh"], missing, "--min-angle", "89").exit_code == 3


def test_check_many_files_gate_fails(meshes):
    result = run("check", meshes["msh"], meshes["vtu"], "--min-angle", "89")
    assert result.exit_code == 1
    assert sum("gate min_angle failed" in line for line in result.stderr.splitlines()) == 2
    assert run("check", meshes["msh"], meshes["vtu"], "--min-angle", "89", "--exit-zero").exit_code == 0


# ------------------------------------------------------------------ compare and plots


def test_compare_runs_every_method(meshes, tmp_path):
    png = tmp_path / "cmp.png"
    result = run("compare", meshes["vtu"], "--passes", "3", "--json", "-", "--plot", png)
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert [m["method"] for m in doc["methods"]] == list(SMOOTHERS)
    for m in doc["methods"]:
        assert len(m["history"]["min_angle"]) == m["passes"] + 1 == 4
        assert {"rejected", "elapsed_s", "after"} <= set(m)
    for name in SMOOTHERS:
        assert name in result.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_smooth_plot(meshes, tmp_path):
    png = tmp_path / "s.png"
    result = run(meshes["vtu"], tmp_path / "o.vtu", "--plot", png, "-q", "--passes", "2")
    assert result.exit_code == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_plot_without_matplotlib(meshes, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # makes "import matplotlib" fail
    out = tmp_path / "o.vtu"
    result = run(meshes["msh"], out, "--plot", tmp_path / "s.png")
    assert result.exit_code == 3
    assert "pip install 'anglesmooth[plot]'" in one_error_line(result)
    assert not out.exists()


# ------------------------------------------------------------------ real processes


def test_python_dash_m_subprocess(meshes, tmp_path):
    out = tmp_path / "o.vtu"
    proc = subprocess.run([sys.executable, "-m", "anglesmooth", str(meshes["msh"]), str(out), "--json", "-"],
                          capture_output=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["output"] == str(out)
    proc = subprocess.run([sys.executable, "-m", "anglesmooth", str(tmp_path / "missing.msh"), str(out)],
                          capture_output=True, timeout=120)
    assert proc.returncode == 3 and proc.stdout == b""
    assert proc.stderr.decode().count("\n") == 1 and b"Traceback" not in proc.stderr


def test_click_usage_errors_are_one_line(tmp_path):
    """A bad option value, an unknown option or a missing argument: exit 2 and one 'anglesmooth: error:' line
    naming the command's --help (click printed three lines: usage, 'Try ...', 'Error: ...')."""
    cases = [(["in.msh", "o.vtu", "--passes", "-1"], "'--passes' / '-n': -1 is not in the range", "smooth"),
             (["in.msh", "o.vtu", "--frobnicate"], "No such option '--frobnicate'", "smooth"),
             (["check"], "Missing argument 'INPUT...'", "check"),
             (["check", "in.msh", "--max-inverted", "x"], "'--max-inverted': 'x' is not a valid integer", "check"),
             (["schema", "nope"], "'nope' is not one of", "schema")]
    code = ("import sys\nfrom anglesmooth.cli import main\n"
            "try:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n    sys.exit(e.code)\n")
    src = str(Path(__file__).resolve().parents[1] / "src")  # this worktree's code, whatever the cwd
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))
    for argv, words, command in cases:
        proc = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, cwd=tmp_path,
                              env=env, timeout=300)
        assert proc.returncode == 2 and proc.stdout == "", (argv, proc.stderr)
        lines = proc.stderr.splitlines()
        assert len(lines) == 1 and lines[0].startswith("anglesmooth: error: "), (argv, proc.stderr)
        assert words in lines[0] and lines[0].endswith(f"(see 'anglesmooth {command} --help')"), lines[0]
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env,
                          timeout=300)
    assert proc.returncode == 2 and proc.stderr.startswith("Usage: anglesmooth")  # no arguments: the help


@pytest.mark.skipif(shutil.which("anglesmooth") is None, reason="console script not installed")
def test_console_script(meshes, tmp_path):
    proc = subprocess.run(["anglesmooth", "check", str(meshes["vtu"]), "--min-angle", "89"], capture_output=True,
                          timeout=120)
    assert proc.returncode == 1 and proc.stdout == b""
    assert b"gate min_angle failed" in proc.stderr


def _wait_for_sigterm_handler(pid: int, timeout: float = 60.0) -> None:
    """Wait until the CLI has installed its SIGTERM handler (Linux: SigCgt in /proc), else a few seconds."""
    status = f"/proc/{pid}/status"
    deadline = time.monotonic() + timeout
    while os.path.exists(status) and time.monotonic() < deadline:
        with open(status) as fh:
            caught = next((line.split()[1] for line in fh if line.startswith("SigCgt:")), "0")
        if int(caught, 16) & (1 << (signal.SIGTERM - 1)):
            time.sleep(0.5)
            return
        time.sleep(0.05)
    time.sleep(3.0)


@pytest.mark.parametrize("sig,code,message", [(signal.SIGTERM, 143, "terminated"), (signal.SIGINT, 130, "interrupted")])
def test_signal_leaves_no_output(tmp_path, sig, code, message):
    src, out = tmp_path / "big.vtu", tmp_path / "o.vtu"
    write(random_delaunay(20_000, seed=3), src)
    proc = subprocess.Popen([sys.executable, "-m", "anglesmooth", str(src), str(out), "--passes", "1000000"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _wait_for_sigterm_handler(proc.pid)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == code, stderr
    assert stderr.decode().strip() == f"anglesmooth: error: {message}" and stdout == b""
    assert sorted(os.listdir(tmp_path)) == ["big.vtu"]


# ------------------------------------------------------------------ nothing left behind


def test_unwritable_json_path_fails_before_work_and_leaves_no_mesh(meshes, tmp_path, monkeypatch):
    out = tmp_path / "out.vtu"
    calls = []
    monkeypatch.setattr(cli_module, "run_smooth", lambda *a, **k: calls.append(1))
    result = run(meshes["msh"], out, "--json", tmp_path / "missing" / "r.json")
    assert result.exit_code == 3
    assert "cannot write JSON report" in one_error_line(result)
    assert not out.exists() and calls == []  # refused before reading or smoothing


def test_failed_mesh_write_leaves_no_json(meshes, tmp_path, monkeypatch):
    out, rep = tmp_path / "out.vtu", tmp_path / "r.json"

    def boom(*a, **k):
        raise anglesmooth.MeshWriteError("cannot write 'out.vtu': disk full")

    import anglesmooth.io

    monkeypatch.setattr(anglesmooth.io, "write", boom)
    result = run(meshes["msh"], out, "--json", rep)
    assert result.exit_code == 3
    assert "disk full" in one_error_line(result)
    assert not out.exists() and not rep.exists()
    assert sorted(os.listdir(tmp_path)) == []  # no staged temporary file either


def test_output_under_a_regular_file_is_not_a_directory(meshes, tmp_path):
    afile = tmp_path / "afile.txt"
    afile.write_text("x")
    result = run(meshes["msh"], afile / "out.vtu")
    assert result.exit_code == 3
    assert "is not a directory" in one_error_line(result)


def test_file_names_with_brackets_are_printed_as_they_are(meshes, tmp_path):
    """rich markup must not eat parts of file names such as "[bold]" (tables, gate lines, warnings)."""
    d = tmp_path / "run[fast]"
    d.mkdir()
    src = d / "mesh[bold].vtu"
    shutil.copy(meshes["tangled"], src)
    out = d / "out[1].vtu"
    r = run(src, out, "--passes", "1", "--min-angle", "0", "--max-inverted", "1000", "--no-progress")
    assert r.exit_code == 0, r.stderr
    assert f"{src}->{out}" in "".join(r.stderr.split())  # the table title (wrapped on narrow terminals)
    assert f"warning: {src}: the input has" in r.stderr  # the tangled-input warning
    assert f"{out}: all 3 gates passed" in r.stderr  # min_angle, max_inverted, max_degenerate
    r = run("check", src, out, "--min-angle", "0", "--max-inverted", "1000")
    assert r.exit_code == 0, r.stderr
    assert "mesh[bold].vtu" in r.stderr and "out[1].vtu" in r.stderr  # the one-row-per-file table


@pytest.mark.parametrize("compiled", [False, True])
def test_progress_bar_says_when_the_first_pass_loads_compiled_kernels(compiled):
    import io as _io

    from rich.console import Console

    buf = _io.StringIO()
    console = Console(file=buf, force_terminal=True, width=120)
    with cli_outputs.progress_bar(console, 3, 10, True, compiled=compiled) as callback:
        callback(1, None, 0.5)
    text = buf.getvalue()
    assert ("compiled kernels" in text) == compiled
    assert "displacement 5.00e-01" in text
