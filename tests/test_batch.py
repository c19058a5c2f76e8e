"""Many files in one run (issue 16, issue 15 item 7): ``smooth A B C --output-dir``, ``--in-place``, directories,
``--jobs``, a Dask ``LocalCluster``, failure isolation, interruption, ``check DIR --exclude``, ``check --jobs``.

Meshes are small (300-1100 cells) so that the whole module is quick; the process
pool and the cluster are the real ones (spawned processes), started once where
they can be.  "Bit-identical" compares the written files byte for byte and the
results with their timings removed.
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_runner import cli_runner, digest

from anglesmooth import FileResult, Mesh2D, check_files, read, smooth_files
from anglesmooth.batch import BatchError, find_mesh_files, output_name
from anglesmooth.cli import cli
from anglesmooth.generate import paper_mixed_mesh, paper_triangle_mesh, random_delaunay, structured_quads
from anglesmooth.io import write

SRC = str(Path(__file__).resolve().parents[1] / "src")
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")]))


def run(*args):
    return cli_runner().invoke(cli, [str(a) for a in args])


def tree(d: Path) -> dict[str, str]:
    """Every file under ``d`` (hidden ones included) -> sha256."""
    return {str(p.relative_to(d)): digest(p) for p in sorted(d.rglob("*")) if p.is_file()}


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("anglesmooth: error: ")]


def timeless(results: list[FileResult]) -> list[dict]:
    """The results without their wall times (everything else must be equal across back ends)."""
    out = []
    for r in results:
        report = None if r.report is None else {k: v for k, v in r.report.items() if k != "elapsed_s"}
        out.append({"input": r.input, "output": r.output, "report": report, "gates": r.gates, "passed": r.passed,
                    "error": r.error, "exit_code": r.exit_code, "messages": r.messages})
    return out


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    """in/: three good meshes in two formats, one corrupt file, a sub-directory, and files that are no meshes."""
    d = tmp_path_factory.mktemp("batch") / "in"
    (d / "sub").mkdir(parents=True)
    write(paper_triangle_mesh(seed=0), d / "a.msh")
    write(paper_mixed_mesh(seed=0), d / "b.vtu")
    write(random_delaunay(300, seed=1), d / "sub" / "c.vtu")
    (d / "bad.vtu").write_text("not a mesh")
    (d / "notes.txt").write_text("not a mesh file suffix")
    (d / ".hidden.vtu").write_text("hidden files are skipped")
    return d


@pytest.fixture
def work(inputs, tmp_path) -> Path:
    shutil.copytree(inputs, tmp_path / "in")
    return tmp_path


GOOD = ["in/a.msh", "in/b.vtu", "in/sub/c.vtu"]


@pytest.fixture(scope="module")
def single(inputs, tmp_path_factory) -> dict[str, str]:
    """sha256 of what the single-file command writes for each good input (the reference)."""
    d = tmp_path_factory.mktemp("single")
    out = {}
    for rel in GOOD:
        target = d / Path(rel).name
        assert run(inputs.parent / rel, target, "-q").exit_code == 0
        out[rel] = digest(target)
    return out


# ------------------------------------------------------------------------------ several inputs, naming


def test_several_inputs_with_output_dir_match_the_single_file_command(work, single, monkeypatch):
    monkeypatch.chdir(work)
    before = tree(work / "in")
    result = run(*GOOD, "--output-dir", "out")
    assert result.exit_code == 0, result.stderr
    assert tree(work / "out") == {Path(rel).name: h for rel, h in single.items()}
    assert tree(work / "in") == before  # inputs untouched
    lines = result.stderr.splitlines()
    progress = [line for line in lines if line.startswith("[")]
    assert [p.split(":")[0] for p in progress] == [f"[{i}/3] {rel} -> out/{Path(rel).name}"
                                                   for i, rel in enumerate(GOOD, 1)]
    assert "summary" in result.stderr and "smoothed" in result.stderr


def test_suffix_and_output_format_name_the_outputs(work, monkeypatch):
    monkeypatch.chdir(work)
    result = run("in/a.msh", "in/b.vtu", "--output-dir", "out", "--suffix", "_s", "--output-format", "vtu", "-q")
    assert result.exit_code == 0, result.stderr
    assert sorted(os.listdir(work / "out")) == ["a_s.vtu", "b_s.vtu"]
    assert read(work / "out" / "a_s.vtu").n_cells == read(work / "in" / "a.msh").n_cells
    # --suffix alone writes beside each input
    assert run("in/a.msh", "in/b.vtu", "--suffix", ".smooth", "-q").exit_code == 0
    assert {"a.smooth.msh", "b.smooth.vtu"} <= set(os.listdir(work / "in"))


def test_a_directory_with_an_output_points_to_output_dir(work, monkeypatch):
    """'anglesmooth in/ out/' said "cannot write 'out/': it is a directory" (out/ did not exist)."""
    monkeypatch.chdir(work)
    before = tree(work)
    result = run("in/", "out/")
    assert result.exit_code == 3
    assert error_lines(result.stderr) == ["anglesmooth: error: cannot read 'in/': is a directory (to smooth every "
                                          "mesh file in it, give --output-dir DIR: anglesmooth smooth 'in/' "
                                          "--output-dir DIR)"]
    assert tree(work) == before and not (work / "out").exists()


@pytest.mark.parametrize("suffix", ["/x", "/../../x", "_s/"])
def test_a_suffix_with_a_slash_is_a_usage_error(work, monkeypatch, suffix):
    """--suffix /x was an internal error (exit 4, ValueError from the path library)."""
    monkeypatch.chdir(work)
    before = tree(work)
    result = run("in/a.msh", "in/b.vtu", "--suffix", suffix)
    assert result.exit_code == 2
    assert error_lines(result.stderr) == [f"anglesmooth: error: the suffix {suffix!r} (--suffix) is added to each "
                                          "file name and must not contain '/' (put the outputs in another "
                                          "directory with --output-dir)"]
    assert tree(work) == before


def test_directory_input_is_walked_and_mirrored(work, single, monkeypatch):
    monkeypatch.chdir(work)
    result = run("in", "--output-dir", "out", "-q")
    assert result.exit_code == 3  # in/bad.vtu
    assert error_lines(result.stderr) == [
        "anglesmooth: error: cannot read 'in/bad.vtu': not a valid vtu file (truncated or corrupt)"]
    assert tree(work / "out") == {"a.msh": single["in/a.msh"], "b.vtu": single["in/b.vtu"],
                                  "sub/c.vtu": single["in/sub/c.vtu"]}
    # a quoted glob is expanded like the shell does
    assert run("in/*.msh", "--output-dir", "globbed", "-q").exit_code == 0
    assert os.listdir(work / "globbed") == ["a.msh"]


def test_in_place_rewrites_each_input(work, single, monkeypatch):
    monkeypatch.chdir(work)
    result = run(*GOOD, "--in-place", "-q")
    assert result.exit_code == 0, result.stderr
    assert {rel: digest(work / rel) for rel in GOOD} == single
    assert sorted(os.listdir(work / "in" / "sub")) == ["c.vtu"]  # no temporary files


def test_two_files_alone_still_mean_input_output(work, monkeypatch):
    monkeypatch.chdir(work)
    assert run("in/a.msh", "x.vtu", "-q").exit_code == 0
    assert read("x.vtu").n_cells == read("in/a.msh").n_cells
    assert not (work / "out").exists()


@pytest.mark.parametrize("args, needle", [
    (["in/a.msh", "in/b.vtu", "in/sub/c.vtu"], "--output-dir"),  # three files and nowhere to write
    (["in/a.msh", "in", "--output-dir", "o", "--in-place"], "--in-place"),
    (["in/b.vtu", "in/sub/c.vtu", "--output-dir", "o", "--json", "o/b.vtu"], "--json"),
    (["in/b.vtu", "in/sub/c.vtu", "--output-dir", "in"], "overwrite the input"),
    (["in/a.msh", "in/b.vtu", "--output-dir", "o", "--plot", "p.png"], "--plot"),
    (["in/a.msh", "-", "--output-dir", "o"], "'-'"),
    (["in/a.msh", "in/b.vtu", "--output-dir", "o", "--jobs", "x"], "number of processes"),
    (["empty", "--output-dir", "o"], "no mesh files"),
    (["in/a.msh", "in/b.vtu", "--output-dir", "o", "--threads", "1"], "--threads works with one INPUT only"),
])
def test_usage_errors_write_nothing(work, monkeypatch, args, needle):
    monkeypatch.chdir(work)
    (work / "empty").mkdir()
    before = tree(work)
    result = run(*args)
    assert result.exit_code == 2, result.stderr
    assert needle in result.stderr and "Traceback" not in result.stderr
    assert tree(work) == before


def test_two_inputs_with_one_output_are_refused(work, monkeypatch):
    monkeypatch.chdir(work)
    shutil.copy(work / "in" / "b.vtu", work / "in" / "sub" / "b.vtu")
    result = run("in/b.vtu", "in/sub/b.vtu", "--output-dir", "o")
    assert result.exit_code == 2 and "would both be written to 'o/b.vtu'" in result.stderr
    assert not (work / "o").exists()
    with pytest.raises(BatchError, match="both"):
        smooth_files(["in/b.vtu", "in/sub/b.vtu"], output_dir="o")


# ------------------------------------------------------------------------------ failure isolation, JSON


def test_a_bad_file_among_good_ones(work, single, monkeypatch):
    monkeypatch.chdir(work)
    result = run("in/a.msh", "in/bad.vtu", "in/missing.vtu", "in/b.vtu", "--output-dir", "out", "--json", "r.json")
    assert result.exit_code == 3
    assert error_lines(result.stderr) == [
        "anglesmooth: error: cannot read 'in/bad.vtu': not a valid vtu file (truncated or corrupt)",
        "anglesmooth: error: cannot read 'in/missing.vtu': no such file"]
    assert tree(work / "out") == {"a.msh": single["in/a.msh"], "b.vtu": single["in/b.vtu"]}
    doc = json.loads((work / "r.json").read_text())
    assert [f["input"] for f in doc["files"]] == ["in/a.msh", "in/bad.vtu", "in/missing.vtu", "in/b.vtu"]
    assert [f["error"] is None for f in doc["files"]] == [True, False, False, True]
    assert doc["files"][0]["output"] == "out/a.msh" and doc["files"][0]["after"]["min_angle"] > 20
    assert doc["summary"] == {**doc["summary"], "files": 4, "smoothed": 2, "failed": 2, "gates_passed": 2}
    assert doc["passed"] is False
    import jsonschema

    from anglesmooth.cli.schema import load_schema

    jsonschema.Draft202012Validator(load_schema("smooth-files")).validate(doc)
    for broken in ({**doc, "files": [{"input": "x"}]}, {k: v for k, v in doc.items() if k != "summary"}):
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.Draft202012Validator(load_schema("smooth-files")).validate(broken)


def test_exit_code_is_the_worst(work, monkeypatch):
    monkeypatch.chdir(work)
    gate = ["--min-angle", "89"]  # fails everywhere
    result = run("in/a.msh", "in/b.vtu", "--output-dir", "o1", *gate)
    assert result.exit_code == 1
    assert [line.split(":")[0] for line in result.stderr.splitlines() if "gate min_angle failed" in line] == [
        "o1/a.msh", "o1/b.vtu"]
    assert run("in/a.msh", "in/bad.vtu", "--output-dir", "o2", *gate, "-q").exit_code == 3  # 3 over 1
    assert run("in/a.msh", "in/b.vtu", "--output-dir", "o3", *gate, "--exit-zero", "-q").exit_code == 0
    assert run("in/a.msh", "in/b.vtu", "--output-dir", "o4", "--min-angle", "1", "-q").exit_code == 0


def test_ci_formats_report_every_file(work, monkeypatch):
    import xml.etree.ElementTree as ET

    monkeypatch.chdir(work)
    result = run("in/a.msh", "in/bad.vtu", "in/b.vtu", "--output-dir", "o", "--min-angle", "89", "--format", "github",
                 "--junit-xml", "j.xml", "--jobs", "2")
    assert result.exit_code == 3
    lines = result.stdout.splitlines()
    assert [line.split("::")[1] for line in lines] == [
        "error file=o/a.msh,title=anglesmooth min_angle", "error file=in/bad.vtu,title=anglesmooth",
        "error file=o/b.vtu,title=anglesmooth min_angle", "notice title=anglesmooth"]
    assert "gate min_angle failed" not in result.stderr  # the github format replaces the plain lines
    suite = ET.parse(work / "j.xml").getroot().find("testsuite")
    assert suite.get("failures") == "2" and suite.get("errors") == "1"
    assert {c.get("classname") for c in suite.iter("testcase")} == {"o/a.msh", "in/bad.vtu", "o/b.vtu"}


def test_library_results(work, monkeypatch):
    monkeypatch.chdir(work)
    results = smooth_files(["in/a.msh", "in/bad.vtu"], output_dir="lib", passes=3, thresholds={"min_angle": 89})
    assert [r.exit_code for r in results] == [1, 3]
    assert results[0].output == "lib/a.msh" and results[0].report["passes"] == 3 and not results[0].passed
    assert results[1].report is None and "in/bad.vtu" in results[1].error
    assert pickle.loads(pickle.dumps(results)) == results
    assert output_name("in/sub/c.vtu", output_dir="o", relative="sub/c.vtu", suffix="_x") == "o/sub/c_x.vtu"
    assert find_mesh_files(["in"], exclude=["sub/*"]) == ["in/a.msh", "in/b.vtu", "in/bad.vtu"]


# ------------------------------------------------------------------------------ processes


def test_jobs_2_is_bit_identical_to_serial(work, monkeypatch):
    monkeypatch.chdir(work)
    files = find_mesh_files(["in"])
    serial = smooth_files(files, output_dir="serial", jobs=1)
    seen = []
    pooled = smooth_files(files, output_dir="pool", jobs=2, on_result=lambda i, r: seen.append(i))
    assert seen == list(range(len(files)))  # in input order
    assert tree(work / "serial") == tree(work / "pool") and len(tree(work / "pool")) == 3
    assert [t["output"] for t in timeless(serial)] == [t["output"].replace("pool", "serial", 1)
                                                       for t in timeless(pooled)]
    strip = [{**t, "output": None, "report": t["report"] and {**t["report"], "output": None}} for t in timeless(serial)]
    assert strip == [{**t, "output": None, "report": t["report"] and {**t["report"], "output": None}}
                     for t in timeless(pooled)]
    # the command line: the same lines, times aside
    one = run("in", "--output-dir", "c1")
    two = run("in", "--output-dir", "c2", "--jobs", "2")
    assert one.exit_code == two.exit_code == 3

    def shape(text, d):
        return [line.split(", 10 passes")[0].replace(d, "D") for line in text.splitlines() if "summary" not in line
                and not line.startswith(("┏", "┃", "┡", "│", "└"))]

    assert shape(one.stderr, "c1") == shape(two.stderr, "c2")
    assert tree(work / "c1") == tree(work / "c2")


def test_worker_initializer_limits_numba_threads_and_ignores_ctrl_c():
    code = ("import os, signal; os.environ.pop('NUMBA_NUM_THREADS', None)\n"
            "from anglesmooth.batch._executors import _init_worker\n"
            "_init_worker(1)\n"
            "import numba\n"
            "print(os.environ['NUMBA_NUM_THREADS'], numba.config.NUMBA_NUM_THREADS, numba.get_num_threads(),\n"
            "      signal.getsignal(signal.SIGINT) is signal.SIG_IGN)\n")
    out = subprocess.run([sys.executable, "-c", code], env=ENV, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1", "1", "1", "True"]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=lambda s: s.name)
def test_interrupting_a_pool_run_leaves_no_partial_output(tmp_path, sig):
    """The first file (one triangle) finishes at once; the signal arrives while the workers smooth the big ones."""
    src = tmp_path / "in"
    src.mkdir()
    write(Mesh2D.from_arrays([[0, 0], [1, 0], [0, 1]], triangles=[[0, 1, 2]]), src / "a.vtu")
    for i in range(1, 4):
        write(random_delaunay(20_000, seed=i), src / f"m{i}.vtu")
    before = tree(src)
    proc = subprocess.Popen([sys.executable, "-m", "anglesmooth", "in", "--output-dir", "out", "--jobs", "2",
                             "--passes", "20000"], cwd=tmp_path, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if line.startswith("[1/4]"):
            break
    else:
        proc.kill()
        raise AssertionError("".join(lines))
    proc.send_signal(sig)
    stdout, rest = proc.communicate(timeout=600)
    stderr = "".join(lines) + rest
    assert proc.returncode == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], stderr
    assert error_lines(stderr) == [f"anglesmooth: error: {'interrupted' if sig == signal.SIGINT else 'terminated'}"]
    assert "Traceback" not in stderr and stdout == ""
    assert sorted(os.listdir(tmp_path / "out")) == ["a.vtu"]  # the finished file, complete; nothing else
    assert read(tmp_path / "out" / "a.vtu").n_cells == 1
    assert tree(src) == before


# ------------------------------------------------------------------------------ Dask


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed", reason="Dask is an optional extra (anglesmooth[dask])")
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = ENV["PYTHONPATH"]  # the worker processes import this worktree's src
    try:
        with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0",
                                      silence_logs=40) as lc, distributed.Client(lc) as client:
            yield client
    finally:
        if old is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old


def test_local_cluster_is_bit_identical_to_serial(work, cluster, monkeypatch):
    monkeypatch.chdir(work)
    files = find_mesh_files(["in"])
    serial = smooth_files(files, output_dir="serial")
    dask = smooth_files(files, output_dir="dask", client=cluster)
    assert tree(work / "serial") == tree(work / "dask") and len(tree(work / "dask")) == 3

    def same(results, d):
        return [{**t, "output": t["output"].replace(d, "D", 1),
                 "report": t["report"] and {**t["report"], "output": t["report"]["output"].replace(d, "D", 1)}}
                for t in timeless(results)]

    assert same(serial, "serial") == same(dask, "dask")
    assert dask[files.index("in/bad.vtu")].error == "cannot read 'in/bad.vtu': not a valid vtu file (truncated or corrupt)"
    # the command line through --scheduler, and check
    address = cluster.scheduler.address
    result = run("in", "--output-dir", "cli", "--scheduler", address, "-q")
    mirrored = tree(work / "serial")
    mirrored["sub/c.vtu"] = mirrored.pop("c.vtu")  # the command line keeps a directory's sub-directories
    assert result.exit_code == 3 and tree(work / "cli") == mirrored
    local = run("check", "in", "--min-angle", "5", "--json", "-")
    remote = run("check", "in", "--min-angle", "5", "--json", "-", "--scheduler", address)
    assert (local.exit_code, local.stdout, local.stderr) == (remote.exit_code, remote.stdout, remote.stderr)


def test_a_dask_worker_terminated_mid_write_leaves_no_temporary_file(tmp_path):
    """SIGTERM to a Dask worker process while its thread writes the output: the signal goes to the worker's
    main thread (its event loop) and ended the process there, leaving the staged file beside the output
    (``.out.vtu.anglesmooth-XXXXXXXX.vtu``).  Now the temporaries are removed first; the output is not written."""
    import threading

    distributed = pytest.importorskip("distributed", reason="Dask is an optional extra (anglesmooth[dask])")
    import dask

    write(random_delaunay(2_000, seed=5), tmp_path / "a.vtu")
    flag = tmp_path / "writing"

    def slow_writes():  # in the worker: the write stops halfway, with its temporary file there
        import time

        import anglesmooth.io as aio

        real = aio._write_meshio

        def half(tmp, *args, **kwargs):
            if ".anglesmooth-" not in str(tmp):  # the output check's sample
                return real(tmp, *args, **kwargs)
            with open(tmp, "wb") as fh:
                fh.write(b"<VTKFile half written")
            flag.write_text(str(os.getpid()))
            time.sleep(120)

        aio._write_meshio = half

    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = ENV["PYTHONPATH"]
    try:
        with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
                distributed.LocalCluster(n_workers=1, processes=True, threads_per_worker=1, dashboard_address=":0",
                                         silence_logs=50) as lc, distributed.Client(lc) as client:
            client.run(slow_writes)
            results = []
            t = threading.Thread(target=lambda: results.extend(
                smooth_files([str(tmp_path / "a.vtu")], output_dir=str(tmp_path / "out"), client=client, passes=1)))
            t.start()
            for _ in range(1200):
                if flag.exists():
                    break
                t.join(0.1)
            assert flag.exists(), results
            assert [f for f in os.listdir(tmp_path / "out") if ".anglesmooth-" in f]  # mid-write: the temporary
            os.kill(int(flag.read_text()), signal.SIGTERM)
            t.join(120)
            assert not t.is_alive()
    finally:
        if old is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old
    assert len(results) == 1 and results[0].exit_code != 0
    assert os.listdir(tmp_path / "out") == []


def test_scheduler_without_dask_is_a_usage_error(work):
    code = ("import sys; sys.modules['distributed'] = None; sys.modules['dask'] = None\n"
            "from anglesmooth.cli import main; main(sys.argv[1:])\n")
    out = subprocess.run([sys.executable, "-c", code, "in/a.msh", "in/b.vtu", "--output-dir", "o",
                          "--scheduler", "tcp://127.0.0.1:1"], cwd=work, env=ENV, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 2, out.stderr
    assert out.stderr.strip() == "anglesmooth: error: --scheduler needs Dask: pip install 'anglesmooth[dask]'"
    assert not (work / "o").exists()


def test_unreachable_scheduler(work, monkeypatch):
    monkeypatch.chdir(work)
    pytest.importorskip("distributed", reason="Dask is an optional extra (anglesmooth[dask])")
    result = run("check", "in/a.msh", "--scheduler", "tcp://127.0.0.1:9")
    assert result.exit_code == 3 and "cannot connect to the Dask scheduler" in result.stderr


# ------------------------------------------------------------------------------ check over the same machinery


def test_check_directory_with_exclude(work, monkeypatch):
    monkeypatch.chdir(work)
    result = run("check", "in", "--json", "-")
    assert result.exit_code == 3
    assert [f["input"] for f in json.loads(result.stdout)["files"]] == ["in/a.msh", "in/b.vtu", "in/bad.vtu",
                                                                        "in/sub/c.vtu"]
    result = run("check", "in", "--exclude", "bad.vtu", "--exclude", "sub/*", "--json", "-")
    assert result.exit_code == 0, result.stderr
    assert [f["input"] for f in json.loads(result.stdout)["files"]] == ["in/a.msh", "in/b.vtu"]
    result = run("check", "in", "--exclude", "*.vtu", "--exclude", "*.msh")
    assert result.exit_code == 0 and "every file matches --exclude" in result.stderr
    result = run("check", "in/notes-*.vtu")  # a pattern that finds nothing is a file that does not exist
    assert result.exit_code == 3 and "no such file" in result.stderr
    (work / "empty").mkdir()
    result = run("check", "empty")  # a directory without mesh files: a usage error (README)
    assert result.exit_code == 2 and error_lines(result.stderr)[0].startswith(
        "anglesmooth: error: no mesh files found in 'empty' (suffixes searched: .msh .vtu")


def test_check_jobs_2_output_is_identical(work, monkeypatch):
    monkeypatch.chdir(work)
    args = ["check", "in", "in/missing.msh", "--min-angle", "15", "--json", "-"]
    one, two = run(*args), run(*args, "--jobs", "2")
    assert one.exit_code == two.exit_code == 3
    assert one.stdout == two.stdout and one.stderr == two.stderr
    assert len(error_lines(one.stderr)) == 2
    results = check_files(find_mesh_files(["in"]), thresholds={"min_angle": 15}, jobs=2)
    assert timeless(results) == timeless(check_files(find_mesh_files(["in"]), thresholds={"min_angle": 15}))


# ------------------------------------------------------------------------------ the benchmark


BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_batch.py"


@pytest.mark.skipif(not BENCH.exists(), reason="benchmarks/ not shipped")
def test_bench_batch_tiny(tmp_path):
    out = tmp_path / "bench.json"
    res = subprocess.run([sys.executable, str(BENCH), "--tiny", "--json", str(out)], capture_output=True, text=True,
                         env=ENV, cwd=tmp_path, timeout=600)
    assert res.returncode == 0, res.stderr
    rows = json.loads(out.read_text())["rows"]
    ways = [r["way"] for r in rows]
    assert len(rows) == 8 and {w[:3] for w in ways} == {"(a)", "(b)", "(c)", "(d)"}
    assert all(r["identical"] and r["files_per_s"] > 0 for r in rows)  # every way wrote the same files
    assert "| meshes | way | wall (s) | files/s |" in res.stdout
    assert sorted(os.listdir(tmp_path)) == ["bench.json"]  # meshes went to a temporary directory


def test_the_h5_of_an_xdmf_output_is_an_output(tmp_path, monkeypatch):
    """An XDMF output writes NAME.h5 beside itself: two outputs sharing one, or --json naming one, are refused
    before any work (the second file's data replaced the first's; the JSON replaced the mesh data)."""
    from anglesmooth.filesets import hdf5_sibling, plan_outputs

    assert hdf5_sibling("d/a.xdmf") == os.path.join("d", "a.h5") and hdf5_sibling("d/a.XMF") is not None
    assert hdf5_sibling("d/a.vtu") is None
    with pytest.raises(BatchError, match=r"HDF5 data of 'out/a.xmf' .* over the output of 'in/a.xdmf'"):
        plan_outputs(["in/a.xdmf", "in/a.xmf"], ["out/a.xdmf", "out/a.xmf"], False)
    with pytest.raises(BatchError, match=r"over the input 'in/b.h5'"):
        plan_outputs(["in/b.h5", "in/c.vtu"], ["in/b_s.h5", "in/b.xdmf"], False)
    plan_outputs(["in/a.xdmf", "in/b.xdmf"], ["in/a.xdmf", "in/b.xdmf"], True)  # in place: their own data
    monkeypatch.chdir(tmp_path)
    (tmp_path / "in").mkdir()
    for name in ("a", "b"):
        write(paper_triangle_mesh(seed=1), tmp_path / "in" / f"{name}.vtu")
    before = sorted(os.listdir(tmp_path))
    r = run("in/a.vtu", "in/b.vtu", "--output-dir", "out", "--output-format", "xdmf", "--json", "out/a.h5")
    assert r.exit_code == 2 and "is one of the mesh files" in r.stderr
    assert sorted(os.listdir(tmp_path)) == before  # no out/ either


def test_an_output_format_that_cannot_hold_the_mesh_fails_before_smoothing(tmp_path, monkeypatch):
    """As for one file: STL holds no quads, so a quad mesh fails with the reason in words before it is
    smoothed (the error came from meshio's writer after the smoothing, in other words)."""
    from anglesmooth import driver

    write(structured_quads(6, 6), tmp_path / "a.vtu")
    calls = []
    monkeypatch.setattr(driver, "smooth", lambda *a, **k: calls.append(1))
    (r,) = smooth_files([str(tmp_path / "a.vtu")], output_dir=str(tmp_path / "out"), extension=".stl")
    assert r.exit_code == 3 and "the stl format cannot hold this mesh: its quad cells would be lost" in r.error, r.error
    assert calls == [] and os.listdir(tmp_path / "out") == []


def test_obj_output_leaves_out_line_cells(tmp_path):
    """OBJ (meshio's writer) holds faces only: a mesh with boundary lines (every gmsh mesh) was refused ("the obj
    format cannot hold this mesh"); its line cells are left out, as STL, OFF and WKT do, the faces kept."""
    import meshio

    m = paper_triangle_mesh(seed=1)
    edges = np.array([[0, 1], [1, 2]])
    meshio.write(tmp_path / "a.vtu", meshio.Mesh(m.points, [("line", edges), ("triangle", m.triangles)],
                                                 cell_data={"gmsh:physical": [np.array([5, 5]),
                                                                              np.ones(len(m.triangles), int)]}))
    (r,) = smooth_files([str(tmp_path / "a.vtu")], output_dir=str(tmp_path / "out"), extension=".obj", passes=2)
    assert r.exit_code == 0, r.error
    back = meshio.read(tmp_path / "out" / "a.obj")
    assert [(c.type, len(c.data)) for c in back.cells] == [("triangle", len(m.triangles))]
    np.testing.assert_array_equal(back.cells[0].data, m.triangles)


def test_json_report_inside_the_output_dir_it_creates(tmp_path, monkeypatch):
    """--json out/r.json with --output-dir out (not there yet) was refused: "directory 'out' does not exist"."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "in").mkdir()
    for name in ("a", "b"):
        write(paper_triangle_mesh(seed=1), tmp_path / "in" / f"{name}.vtu")
    r = run("in", "--output-dir", "out", "--json", "elsewhere/r.json")
    assert r.exit_code == 3 and "directory 'elsewhere' does not exist" in r.stderr  # only the dirs it makes
    assert not (tmp_path / "out").exists()
    r = run("in", "--output-dir", "out/x", "--json", "out/r.json", "--junit-xml", "out/x/j.xml")
    assert r.exit_code == 0, r.stderr
    assert sorted(os.listdir(tmp_path / "out")) == ["r.json", "x"]
    assert sorted(os.listdir(tmp_path / "out" / "x")) == ["a.vtu", "b.vtu", "j.xml"]
    assert len(json.loads((tmp_path / "out" / "r.json").read_text())["files"]) == 2
