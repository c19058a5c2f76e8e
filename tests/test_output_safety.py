"""The output contract (issue 13): nothing that is not a named output is ever modified.

* every output (OUTPUT, --json, --plot) differs from every input (INPUT, --fix-nodes,
  --gate-file) and from the other outputs, compared by resolved path and inode;
* special files (character devices, FIFOs, sockets, /dev/stdout) are written into, never
  replaced; regular files atomically, symlinks followed, mode / owner kept;
* stdout writes are complete (non-blocking pipes, short writes) or fail with the documented
  code (141 broken pipe, 3 full device);
* every output path is checked before any work; all outputs are committed together at the
  end, so an error or a signal before that leaves none;
* ordinary mistakes never exit 4.

Devices are made with ``mknod`` in the test's own directory, which needs root; CI runs as root.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import socket
import stat
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import meshio
import numpy as np
import pytest
from cli_runner import PREFIX, cli_runner, digest, error_line, snapshot

from anglesmooth import _paths, read, smooth, write
from anglesmooth.cli import cli
from anglesmooth.generate import random_delaunay

SRC = str(Path(__file__).resolve().parents[1] / "src")
ROOT = os.geteuid() == 0
needs_root = pytest.mark.skipif(not ROOT, reason="mknod and chown need root (CI runs as root)")
def env(**extra) -> dict:
    e = dict(os.environ, PYTHONPATH=SRC + os.pathsep + os.environ.get("PYTHONPATH", ""))
    e.update(extra)
    return e


def invoke(*args, **kwargs):
    return cli_runner().invoke(cli, [str(a) for a in args], **kwargs)


def run_cli(*args, cwd=None, timeout=120, **kwargs) -> subprocess.CompletedProcess:
    kwargs.setdefault("env", env())
    return subprocess.run([sys.executable, "-m", "anglesmooth", *map(str, args)], cwd=cwd, capture_output=True,
                          timeout=timeout, **kwargs)


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("small") / "in.vtu"
    write(random_delaunay(400, seed=3), path)
    return path


@pytest.fixture(scope="module")
def large(tmp_path_factory) -> Path:
    """About 600 KB of VTU: far more than a pipe holds."""
    path = tmp_path_factory.mktemp("large") / "in.vtu"
    write(random_delaunay(30_000, seed=4), path)
    return path


@pytest.fixture()
def work(tmp_path, small) -> Path:
    (tmp_path / "in.vtu").write_bytes(small.read_bytes())
    (tmp_path / "fix.txt").write_text("1 2\n")
    (tmp_path / "gates.toml").write_text("min_angle = 1\n")
    os.link(tmp_path / "in.vtu", tmp_path / "hard.vtu")
    os.symlink("in.vtu", tmp_path / "sym.vtu")
    return tmp_path


# --------------------------------------------------------------------------- 1. outputs vs inputs

COLLISIONS = [
    ("check-json-input", ["check", "in.vtu", "--json", "in.vtu"], "--json 'in.vtu' is the same file as INPUT"),
    ("check-json-second-input", ["check", "in.vtu", "fix.txt", "--json", "fix.txt"], "same file as INPUT 'fix.txt'"),
    ("check-json-hardlink", ["check", "in.vtu", "--json", "hard.vtu"], "--json 'hard.vtu' is the same file as INPUT"),
    ("check-json-symlink", ["check", "in.vtu", "--json", "sym.vtu"], "--json 'sym.vtu' is the same file as INPUT"),
    ("check-json-gate-file", ["check", "in.vtu", "--gate-file", "gates.toml", "--json", "gates.toml"],
     "same file as --gate-file"),
    ("smooth-plot-input", ["in.vtu", "out.vtu", "--plot", "in.vtu"], "--plot 'in.vtu' is the same file as INPUT"),
    ("smooth-json-output", ["in.vtu", "out.vtu", "--json", "out.vtu"], "OUTPUT 'out.vtu' and --json 'out.vtu'"),
    ("smooth-plot-json", ["in.vtu", "out.vtu", "--json", "r.x", "--plot", "r.x"], "--json 'r.x' and --plot 'r.x'"),
    ("smooth-json-fix-nodes", ["in.vtu", "out.vtu", "--fix-nodes", "fix.txt", "--json", "fix.txt"],
     "same file as --fix-nodes"),
    ("smooth-json-gate-file", ["in.vtu", "out.vtu", "--gate-file", "gates.toml", "--json", "gates.toml"],
     "same file as --gate-file"),
    ("smooth-output-hardlink", ["in.vtu", "hard.vtu"], "pass --force or --in-place"),
    ("smooth-output-symlink", ["in.vtu", "sym.vtu"], "pass --force or --in-place"),
    ("smooth-in-place-json-input", ["in.vtu", "--in-place", "--json", "hard.vtu"], "same file as INPUT"),
    ("compare-json-input", ["compare", "in.vtu", "--json", "sym.vtu"], "--json 'sym.vtu' is the same file as INPUT"),
    ("compare-plot-input", ["compare", "in.vtu", "--plot", "hard.vtu"], "--plot 'hard.vtu' is the same file as INPUT"),
    ("compare-json-plot", ["compare", "in.vtu", "--json", "a.png", "--plot", "a.png"], "are the same file"),
    ("check-junit-input", ["check", "in.vtu", "--junit-xml", "hard.vtu"], "--junit-xml 'hard.vtu' is the same file"),
    ("smooth-junit-json", ["in.vtu", "out.vtu", "--json", "r.x", "--junit-xml", "r.x"], "are the same file"),
]


@pytest.mark.parametrize("argv, needle", [c[1:] for c in COLLISIONS], ids=[c[0] for c in COLLISIONS])
def test_an_output_never_names_an_input_or_another_output(work, argv, needle, monkeypatch):
    monkeypatch.chdir(work)
    before = snapshot(work)
    r = invoke(*argv)
    assert r.exit_code == 2, r.stderr
    assert needle in error_line(r.stderr)
    assert snapshot(work) == before  # nothing written, nothing replaced, no temporary file


def test_an_output_never_names_the_configuration_file(work, monkeypatch):
    monkeypatch.chdir(work)
    (work / "pyproject.toml").write_text("[tool.anglesmooth.gates]\nmin_angle = 0.1\n")
    before = snapshot(work)
    for argv in (["check", "in.vtu", "--json", "pyproject.toml"], ["in.vtu", "out.vtu", "--plot", "pyproject.toml"]):
        r = invoke(*argv)
        assert r.exit_code == 2, r.stderr
        assert "is the same file as the configuration file" in error_line(r.stderr)
    assert snapshot(work) == before


def test_force_still_allows_output_to_be_a_link_to_the_input(work, monkeypatch):
    monkeypatch.chdir(work)
    old = digest(work / "in.vtu")
    r = invoke("in.vtu", "sym.vtu", "--force", "-q")
    assert r.exit_code == 0, r.stderr
    # the link is followed: its target (the input) is replaced, the link stays a link
    assert os.readlink(work / "sym.vtu") == "in.vtu"
    assert digest(work / "in.vtu") != old
    # a hard link is a name of its own: the rename gives it a new file, the input keeps its content
    old = digest(work / "in.vtu")
    r = invoke("in.vtu", "hard.vtu", "--force", "-q")
    assert r.exit_code == 0, r.stderr
    assert digest(work / "in.vtu") == old and digest(work / "hard.vtu") != old
    assert os.stat(work / "in.vtu").st_ino != os.stat(work / "hard.vtu").st_ino


def test_stdin_redirected_from_the_output_file_is_the_input(work):
    """``anglesmooth - in.vtu < in.vtu``: stdin is compared by inode too."""
    with open(work / "in.vtu", "rb") as fh:
        p = subprocess.run([sys.executable, "-m", "anglesmooth", "-", "in.vtu", "--input-format", "vtu"], stdin=fh,
                           cwd=work, capture_output=True, env=env(), timeout=120)
    assert p.returncode == 2
    assert "is the input file" in error_line(p.stderr.decode())


def test_stdout_twice_is_refused(work):
    # OUTPUT '-' and --json /dev/stdout are the same pipe
    p = run_cli("in.vtu", "-", "--output-format", "vtu", "--json", "/dev/stdout", cwd=work)
    assert p.returncode == 2 and p.stdout == b""
    assert "are the same file" in error_line(p.stderr.decode())


# --------------------------------------------------------------------------- 2. special files


@needs_root
def test_a_character_device_is_written_into_not_replaced(work):
    dev = work / "null"
    os.mknod(dev, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    link = work / "to-null.vtu"
    os.symlink("null", link)
    for target, extra in ((dev, ["--output-format", "vtu"]), (link, [])):
        p = run_cli("in.vtu", target.name, *extra, "--json", "null2" if target is link else "null", cwd=work)
        if target is link:  # --json null2 does not exist: a regular JSON file; OUTPUT streams into the device
            assert p.returncode == 0, p.stderr
            (work / "null2").unlink()
        else:  # the same character device twice is allowed (nothing is destroyed)
            assert p.returncode == 0, p.stderr
        st = os.lstat(dev)
        assert stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 3)
        assert os.readlink(link) == "null"
    assert sorted(os.listdir(work)) == ["fix.txt", "gates.toml", "hard.vtu", "in.vtu", "null", "sym.vtu", "to-null.vtu"]


@needs_root
def test_a_full_device_gives_exit_3_and_stays_a_device(work):
    full = work / "full"
    os.mknod(full, 0o666 | stat.S_IFCHR, os.makedev(1, 7))
    p = run_cli("in.vtu", "full", "--output-format", "vtu", cwd=work)
    assert p.returncode == 3
    assert "No space left on device" in error_line(p.stderr.decode())
    assert stat.S_ISCHR(os.lstat(full).st_mode)
    p = run_cli("check", "in.vtu", "--json", "full", "-q", cwd=work)
    assert p.returncode == 3 and "cannot write JSON report 'full'" in error_line(p.stderr.decode())


def test_a_fifo_is_written_into(work, small):
    fifo = work / "pipe.vtu"
    os.mkfifo(fifo)
    got = {}

    def reader():
        with open(fifo, "rb") as fh:
            got["data"] = fh.read()

    t = threading.Thread(target=reader, daemon=True)  # never blocks the test run's exit
    t.start()
    p = run_cli("in.vtu", "pipe.vtu", "-n", "3", cwd=work)
    t.join(60)
    assert p.returncode == 0, p.stderr
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    # the same bytes as a regular output
    assert run_cli("in.vtu", "reg.vtu", "-n", "3", cwd=work).returncode == 0
    assert got["data"] == (work / "reg.vtu").read_bytes()


def test_a_socket_is_not_replaced(work):
    sock_path = work / "s.json"
    srv = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    srv.bind(str(sock_path))
    try:
        p = run_cli("check", "in.vtu", "--json", "s.json", "-q", cwd=work)
        assert p.returncode == 3
        assert "cannot write JSON report 's.json'" in error_line(p.stderr.decode())
        assert stat.S_ISSOCK(os.lstat(sock_path).st_mode)
    finally:
        srv.close()


def test_dev_stdout_is_streamed(work):
    p = run_cli("check", "in.vtu", "--json", "/dev/stdout", "-q", cwd=work)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["passed"] is True
    p = run_cli("in.vtu", "/dev/stdout", "--output-format", "vtu", "-q", "-n", "2", cwd=work)
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith(b"<?xml") or p.stdout.startswith(b"<VTKFile")


def test_library_write_streams_into_a_fifo_too(tmp_path):
    fifo = tmp_path / "f.vtu"
    os.mkfifo(fifo)
    got = {}
    t = threading.Thread(target=lambda: got.setdefault("data", open(fifo, "rb").read()), daemon=True)
    t.start()
    write(random_delaunay(50, seed=1), fifo)
    t.join(30)
    assert got["data"].lstrip().startswith(b"<")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


# --------------------------------------------------------------------------- 3. symlinks and metadata


def test_in_place_follows_a_symlink_and_keeps_it(work, monkeypatch):
    monkeypatch.chdir(work)
    (work / "t.vtu").write_bytes((work / "in.vtu").read_bytes())
    os.symlink("t.vtu", work / "link.vtu")
    r = invoke("link.vtu", "--in-place", "-q")
    assert r.exit_code == 0, r.stderr
    assert os.readlink(work / "link.vtu") == "t.vtu"
    assert invoke("in.vtu", "expected.vtu", "-q").exit_code == 0
    assert digest(work / "t.vtu") == digest(work / "expected.vtu") != digest(work / "in.vtu")


def test_a_dangling_symlink_creates_its_target(work, monkeypatch):
    monkeypatch.chdir(work)
    os.symlink("new.vtu", work / "dangling.vtu")
    r = invoke("in.vtu", "dangling.vtu", "-q")
    assert r.exit_code == 0, r.stderr
    assert os.readlink(work / "dangling.vtu") == "new.vtu" and (work / "new.vtu").is_file()
    os.symlink("/nonexistent-dir/x.vtu", work / "nowhere.vtu")
    r = invoke("in.vtu", "nowhere.vtu")
    assert r.exit_code == 3
    assert "directory '/nonexistent-dir' does not exist" in error_line(r.stderr)


@needs_root
def test_replacing_keeps_owner_group_and_mode_without_setuid(work, monkeypatch):
    monkeypatch.chdir(work)
    out = work / "out.vtu"
    out.write_text("old")
    os.chown(out, 1234, 2345)
    os.chmod(out, 0o6750)
    r = invoke("in.vtu", "out.vtu", "-q", "--json", "r.json")  # out.vtu exists: replaced
    assert r.exit_code == 0, r.stderr
    st = os.stat(out)
    assert (st.st_uid, st.st_gid) == (1234, 2345)
    assert stat.S_IMODE(st.st_mode) == 0o750


def test_new_json_and_plot_follow_the_umask_like_the_mesh(work, monkeypatch):
    monkeypatch.chdir(work)
    old = os.umask(0o027)
    try:
        r = invoke("in.vtu", "out.vtu", "-q", "--json", "r.json", "--plot", "p.png")
    finally:
        os.umask(old)
    assert r.exit_code == 0, r.stderr
    modes = {n: stat.S_IMODE(os.stat(work / n).st_mode) for n in ("out.vtu", "r.json", "p.png")}
    assert modes == {"out.vtu": 0o640, "r.json": 0o640, "p.png": 0o640}


# --------------------------------------------------------------------------- 4. short writes on stdout


def test_a_slow_non_blocking_stdout_pipe_gets_every_byte(large, tmp_path):
    expected = tmp_path / "expected.vtu"
    assert run_cli(large, expected, "-n", "1", "-q").returncode == 0
    r, w = os.pipe()
    os.set_blocking(w, False)
    proc = subprocess.Popen([sys.executable, "-m", "anglesmooth", str(large), "-", "--output-format", "vtu", "-n", "1",
                             "-q"], stdout=w, stderr=subprocess.PIPE, env=env(PYTHONUNBUFFERED="1"))
    os.close(w)
    chunks = []
    while True:
        time.sleep(0.002)  # a slow reader: the pipe fills up and the writer gets EAGAIN
        chunk = os.read(r, 16384)
        if not chunk:
            break
        chunks.append(chunk)
    os.close(r)
    assert proc.wait(60) == 0, proc.stderr.read()
    data = b"".join(chunks)
    assert len(data) == expected.stat().st_size > 500_000  # ~10 pipe buffers
    assert data == expected.read_bytes()


def test_stdout_closed_early_is_141(large, tmp_path):
    cmd = (f"'{sys.executable}' -m anglesmooth '{large}' - --output-format vtu -n 1 -q | head -c 100 > /dev/null; "
           "echo ${PIPESTATUS[0]}")
    p = subprocess.run(["bash", "-c", cmd], capture_output=True, env=env(PYTHONUNBUFFERED="1"), timeout=120)
    assert p.stdout.decode().strip() == "141", p.stderr
    assert p.stderr == b""


def test_write_all_loops_over_short_writes(monkeypatch):
    written = []

    def short(fd, data):
        n = min(len(data), 7)
        written.append(bytes(data[:n]))
        if len(written) == 3:
            raise BlockingIOError(11, "EAGAIN")
        return n

    r, w = os.pipe()
    monkeypatch.setattr(os, "write", short)
    _paths.write_all(w, b"x" * 100)
    os.close(r)
    os.close(w)
    assert sum(len(c) for i, c in enumerate(written) if i != 2) == 100


# --------------------------------------------------------------------------- 5. no exit 4 on ordinary mistakes


def test_json_path_problems_are_exit_3_before_any_work(work, monkeypatch):
    monkeypatch.chdir(work)
    (work / "SOMEDIR").mkdir()
    before = snapshot(work)
    for cmd in (["check", "in.vtu"], ["compare", "in.vtu", "-n", "1"], ["in.vtu", "out.vtu"]):
        for path, needle in (("nodir/r.json", "directory 'nodir' does not exist"), ("/sys/x.json", "cannot create"),
                             ("SOMEDIR", "it is a directory"), ("fix.txt/r.json", "is not a directory")):
            r = invoke(*cmd, "--json", path)
            assert r.exit_code == 3, (cmd, path, r.stderr)
            assert f"cannot write JSON report '{path}'" in error_line(r.stderr) and needle in r.stderr
            assert snapshot(work) == before  # no .SOMEDIR.XXXX.tmp, nothing else


@pytest.mark.parametrize("text, needle", [("[tool.anglesmooth]\ngates = 5\n", "gates must be a table"),
                                          ("tool = {anglesmooth = 3}\n", "[tool.anglesmooth] must be a table"),
                                          ("gates = 5\n", "gates must be a table")])
def test_gate_file_of_the_wrong_shape_is_a_usage_error(work, text, needle):
    (work / "g.toml").write_text(text)
    for cmd in (["check", work / "in.vtu"], [work / "in.vtu", work / "o.vtu"]):
        r = invoke(*cmd, "--gate-file", work / "g.toml")
        assert r.exit_code == 2, r.stderr
        assert needle in error_line(r.stderr)
    assert not (work / "o.vtu").exists()


def test_fix_nodes_too_large_for_int64_is_a_usage_error(work):
    (work / "big.txt").write_text("100000000000000000000000\n")
    r = invoke(work / "in.vtu", work / "o.vtu", "--fix-nodes", work / "big.txt")
    assert r.exit_code == 2
    assert "--fix-nodes: node 100000000000000000000000" in error_line(r.stderr)


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_non_finite_gate_thresholds_are_usage_errors(work, value):
    for opt in ("--min-angle", "--max-angle", "--max-area-ratio", "--max-aspect-ratio"):
        r = invoke("check", work / "in.vtu", f"{opt}={value}")
        assert r.exit_code == 2, (opt, r.stderr)
        assert "is not a finite number" in r.stderr or "not in the range" in r.stderr


SHELL_CASES = [
    ("stdout-closed", "'{py}' -m anglesmooth in.vtu - --output-format vtu >&-", 3, "stdout is closed"),
    ("json-stdout-closed", "'{py}' -m anglesmooth check in.vtu --json - >&-", 3, "stdout is closed"),
    ("stdin-closed", "'{py}' -m anglesmooth - o.vtu --input-format vtu <&-", 3, "standard input is closed"),
    ("stdout-dev-full", "'{py}' -m anglesmooth in.vtu - --output-format vtu > /dev/full", 3, "No space left"),
    ("json-dev-full", "'{py}' -m anglesmooth check in.vtu -q --json - > /dev/full", 3, "No space left"),
    ("numba-threads-0", "NUMBA_NUM_THREADS=0 '{py}' -m anglesmooth in.vtu o.vtu", 2, "NUMBA_NUM_THREADS='0'"),
    ("numba-threads-x", "NUMBA_NUM_THREADS=x '{py}' -m anglesmooth check in.vtu", 2, "NUMBA_NUM_THREADS='x'"),
]


@pytest.mark.parametrize("cmd, code, needle", [c[1:] for c in SHELL_CASES], ids=[c[0] for c in SHELL_CASES])
def test_closed_and_full_streams_are_ordinary_errors(work, cmd, code, needle):
    if "/dev/full" in cmd and not stat.S_ISCHR(os.stat("/dev/full").st_mode):
        pytest.fail("/dev/full is not a character device on this machine")
    before = snapshot(work)
    p = subprocess.run(["bash", "-c", cmd.format(py=sys.executable)], cwd=work, capture_output=True, env=env(),
                       timeout=120)
    assert p.returncode == code, p.stderr
    assert needle in error_line(p.stderr.decode())
    assert snapshot(work) == before


def test_closed_or_read_only_stderr_keeps_the_exit_codes(work):
    """With stderr closed (or, through a shell wrapper, left open read-only) messages are dropped, codes stay."""
    py = sys.executable
    for redirect in ("2>&-", "2</dev/null"):
        for cmd, code in ((f"'{py}' -m anglesmooth in.vtu o.vtu -n 1", 0), (f"'{py}' -m anglesmooth check nope.vtu", 3),
                          (f"'{py}' -m anglesmooth in.vtu - --output-format vtu -n 1 -q", 0)):
            p = subprocess.run(["bash", "-c", f"{cmd} {redirect}"], cwd=work, capture_output=True, env=env(),
                               timeout=120)
            assert p.returncode == code, (cmd, redirect)
    assert (work / "o.vtu").exists()


# --------------------------------------------------------------------------- 6. all outputs or none


def test_an_unwritable_plot_path_is_found_before_the_mesh_is_written(work, monkeypatch):
    monkeypatch.chdir(work)
    before = snapshot(work)
    r = invoke("in.vtu", "p.vtu", "--json", "r.json", "--plot", "nodir/p.png")
    assert r.exit_code == 3
    assert "cannot write plot 'nodir/p.png'" in error_line(r.stderr)
    assert snapshot(work) == before


def test_an_error_while_plotting_leaves_no_output(work, monkeypatch):
    import anglesmooth.plot as plot

    def broken(*a, **k):
        raise RuntimeError("boom")

    monkeypatch.setattr(plot, "plot_smooth", broken)
    monkeypatch.chdir(work)
    before = snapshot(work)
    r = invoke("in.vtu", "out.vtu", "--json", "r.json", "--plot", "p.png")
    assert r.exit_code == 4  # an internal error: a bug in plotting
    assert snapshot(work) == before


LAUNCHER = """
import os, signal, sys, time
from anglesmooth import plot
from anglesmooth.cli import main

def slow_plot(*args, **kwargs):
    print("MARK drawing", file=sys.stderr, flush=True)
    time.sleep(60)

if sys.argv[1] == "plot":
    plot.plot_smooth = slow_plot
elif sys.argv[1] == "kill":  # SIGKILL once the mesh is staged
    from anglesmooth import io
    orig = io._write_meshio
    def write_meshio(tmp, *a, **k):
        orig(tmp, *a, **k)
        if os.path.basename(tmp).startswith(".out.vtu"):  # the staged output, not the format check's sample
            os.kill(os.getpid(), signal.SIGKILL)
    io._write_meshio = write_meshio
main(sys.argv[2:])
"""


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_a_signal_while_the_plot_is_drawn_leaves_no_output(work, sig, code, word):
    (work / "launch.py").write_text(LAUNCHER)
    before = snapshot(work)
    proc = subprocess.Popen([sys.executable, "launch.py", "plot", "in.vtu", "out.vtu", "--json", "r.json", "--plot",
                             "p.png", "-q"], cwd=work, stderr=subprocess.PIPE, text=True, env=env(),
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    line = proc.stderr.readline()
    assert "MARK drawing" in line, line
    proc.send_signal(sig)
    rest = proc.stderr.read()
    assert proc.wait(60) == code
    assert error_line(rest) == PREFIX + word
    assert snapshot(work) == before  # no out.vtu, no r.json, no temporary file


def test_sigkill_leaves_a_recognisable_temporary_file_that_the_next_run_names(work):
    (work / "launch.py").write_text(LAUNCHER)
    p = subprocess.run([sys.executable, "launch.py", "kill", "in.vtu", "out.vtu", "-q"], cwd=work, env=env(),
                       capture_output=True, timeout=120)
    assert p.returncode == -signal.SIGKILL
    left = [n for n in os.listdir(work) if n.startswith(".out.vtu.anglesmooth-")]
    assert len(left) == 1 and not (work / "out.vtu").exists()
    old = time.time() - 5
    os.utime(work / left[0], (old, old))
    p = run_cli("in.vtu", "out.vtu", "-n", "1", cwd=work)
    assert p.returncode == 0
    notes = [line for line in p.stderr.decode().splitlines() if "interrupted earlier run" in line]
    assert len(notes) == 1 and left[0] in notes[0]
    assert (work / left[0]).exists()  # mentioned, not deleted: another run may own it
    # --quiet silences the note like every other note
    assert b"interrupted earlier run" not in run_cli("in.vtu", "out.vtu", "-n", "1", "-q", cwd=work).stderr


# --------------------------------------------------------------------------- 7. corrupt counts, bounded memory


def _limited():
    resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))


def _binary_msh41(path: Path) -> None:
    m = random_delaunay(1200, seed=5)
    meshio.gmsh.write(str(path), meshio.Mesh(np.column_stack([m.points, np.zeros(m.n_points)]),
                                              [("triangle", m.triangles)]), fmt_version="4.1", binary=True)


def test_corrupt_binary_msh41_element_count_is_refused_in_bounded_memory(tmp_path):
    src = tmp_path / "good.msh"
    _binary_msh41(src)
    data = src.read_bytes()
    at = data.index(b"$Elements\n") + len(b"$Elements\n") + 32  # past numEntityBlocks numElements min max
    dim, tag, etype, n = struct.unpack("<3iQ", data[at:at + 20])
    assert (dim, etype) == (2, 2) and n == 1200
    bad = tmp_path / "bad.msh"
    bad.write_bytes(data[:at + 12] + struct.pack("<Q", 280_000_000) + data[at + 20:])  # 280e6 x 4 x 8 = 9 GB
    assert 30_000 < bad.stat().st_size < 60_000
    p = subprocess.run([sys.executable, "-m", "anglesmooth", "check", str(bad)], capture_output=True, env=env(),
                       preexec_fn=_limited, timeout=120)
    assert p.returncode == 3
    line = error_line(p.stderr.decode())
    assert "declares 1,120,000,000 values" in line and "out of memory" not in line
    # the intact file still reads under the same limit
    ok = subprocess.run([sys.executable, "-m", "anglesmooth", "check", str(src), "-q"], capture_output=True, env=env(),
                        preexec_fn=_limited, timeout=120)
    assert ok.returncode == 0, ok.stderr


def test_corrupt_binary_msh41_node_tag_is_refused_in_bounded_memory(tmp_path):
    """One node tag flipped to 10^9: meshio sizes ``np.full(max_tag + 1)`` by it (8 GB, written, so resident)."""
    src = tmp_path / "good.msh"
    _binary_msh41(src)
    data = src.read_bytes()
    at = data.index(b"$Nodes\n") + len(b"$Nodes\n") + 32 + 20  # header, first block header: first node tag
    assert struct.unpack("<Q", data[at:at + 8]) == (1,)
    bad = tmp_path / "bad.msh"
    bad.write_bytes(data[:at] + struct.pack("<Q", 1_000_000_000) + data[at + 8:])
    p = subprocess.run([sys.executable, "-m", "anglesmooth", "check", str(bad)], capture_output=True, env=env(),
                       preexec_fn=_limited, timeout=120)
    assert p.returncode == 3
    line = error_line(p.stderr.decode())
    assert "declares an array of 8,000,000,000 bytes" in line and "out of memory" not in line


def _ascii(tmp_path, name, text) -> Path:
    (tmp_path / name).write_text(text)
    return tmp_path / name


HUGE = [
    ("msh22-ascii-nodes", "h.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n300000000\n1 0 0 0\n$EndNodes\n"),
    ("msh41-ascii-nodes", "h.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 300000000 1 300000000\n"
                                   "2 1 0 300000000\n1\n0 0 0\n$EndNodes\n"),
    ("msh41-ascii-elements", "h.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n"
                                      "0 0 0\n1 0 0\n0 1 0\n$EndNodes\n$Elements\n1 300000000 1 300000000\n"
                                      "2 1 2 300000000\n1 1 2 3\n$EndElements\n"),
    ("msh41-ascii-node-tag", "h.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n"
                                      "300000000000\n0 0 0\n1 0 0\n0 1 0\n$EndNodes\n$Elements\n1 1 1 1\n"
                                      "2 1 2 1\n1 1 2 3\n$EndElements\n"),
    ("vtk-points", "h.vtk", "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                            "POINTS 300000000 double\n0 0 0 1 0 0 0 1 0\nCELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n5\n"),
    ("vtk-cells", "h.vtk", "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                           "POINTS 3 double\n0 0 0 1 0 0 0 1 0\nCELLS 1 300000000\n3 0 1 2\nCELL_TYPES 1\n5\n"),
]


@pytest.mark.parametrize("name, text", [c[1:] for c in HUGE], ids=[c[0] for c in HUGE])
def test_absurd_counts_in_text_formats_are_refused_in_bounded_memory(tmp_path, name, text):
    path = _ascii(tmp_path, name, text)
    p = subprocess.run([sys.executable, "-m", "anglesmooth", "check", str(path)], capture_output=True, env=env(),
                       preexec_fn=_limited, timeout=120)
    assert p.returncode == 3
    line = error_line(p.stderr.decode())
    assert "SizeLimitError" in line and "out of memory" not in line


@pytest.mark.parametrize("fmt", ["msh22-binary", "vtk-binary"])
def test_absurd_counts_in_binary_headers_are_refused_in_bounded_memory(tmp_path, fmt):
    m = random_delaunay(600, seed=6)
    mm = meshio.Mesh(np.column_stack([m.points, np.zeros(m.n_points)]), [("triangle", m.triangles)])
    if fmt == "msh22-binary":
        path = tmp_path / "b.msh"
        meshio.gmsh.write(str(path), mm, fmt_version="2.2", binary=True)
        old, new = f"$Nodes\n{m.n_points}\n".encode(), b"$Nodes\n300000000\n"
    else:
        path = tmp_path / "b.vtk"
        meshio.vtk.write(str(path), mm, binary=True)
        old, new = f"POINTS {m.n_points} ".encode(), b"POINTS 300000000 "
    data = path.read_bytes()
    assert data.count(old) == 1
    path.write_bytes(data.replace(old, new))
    p = subprocess.run([sys.executable, "-m", "anglesmooth", "check", str(path)], capture_output=True, env=env(),
                       preexec_fn=_limited, timeout=120)
    assert p.returncode == 3
    line = error_line(p.stderr.decode())
    assert "SizeLimitError" in line and "out of memory" not in line


def test_xdmf_hdf5_dataset_of_absurd_size_is_refused(tmp_path):
    import h5py

    m = random_delaunay(50, seed=2)
    meshio.xdmf.write(str(tmp_path / "m.xdmf"), meshio.Mesh(np.column_stack([m.points, np.zeros(m.n_points)]),
                                                            [("triangle", m.triangles)]), data_format="HDF")
    h5 = tmp_path / "m.h5"
    with h5py.File(h5, "r+") as f:
        name = next(k for k in f if f[k].ndim == 2 and f[k].shape[1] == 3 and f[k].dtype.kind == "f")
        del f[name]
        f.create_dataset(name, shape=(400_000_000, 3), dtype="f8", chunks=(1024, 3))  # never written: tiny file
    assert h5.stat().st_size < 1_000_000
    p = subprocess.run([sys.executable, "-m", "anglesmooth", "check", str(tmp_path / "m.xdmf")], capture_output=True,
                       env=env(), preexec_fn=_limited, timeout=120)
    assert p.returncode == 3
    line = error_line(p.stderr.decode())
    assert "HDF5 dataset" in line and "declares 9,600,000,000 bytes" in line


# --------------------------------------------------------------------------- 8. smaller ones


def test_zero_passes_leave_every_node_bit_identical_mid_side_nodes_included(tmp_path):
    import gmsh

    path = tmp_path / "q.msh"
    gmsh.initialize(["", "-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addDisk(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
        gmsh.option.setNumber("Mesh.ElementOrder", 2)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    mesh = read(path)
    topo_fixed = np.zeros(mesh.n_points, bool)
    from anglesmooth import build_topology

    topo = build_topology(mesh)
    topo_fixed[:] = topo.fixed
    mid, a, b = mesh.midside.T
    interior = ~(topo_fixed[a] & topo_fixed[b])
    k = int(np.flatnonzero(interior)[0])
    p = mesh.points.copy()
    p[mid[k]] += [0.01, -0.02]  # a curved interior edge
    curved = mesh.with_points(p)
    r = smooth(curved, "angle", passes=0)
    assert np.array_equal(r.points, p)
    out = tmp_path / "out.msh"
    assert invoke(path, out, "-n", "0", "-q").exit_code == 0
    assert np.array_equal(read(out).points, mesh.points)  # and through the CLI, bit for bit


IMPORT_INTERRUPT = """
import os, signal, sys
class Hook:
    def find_spec(self, name, path=None, target=None):
        if name == sys.argv[1]:
            os.kill(os.getpid(), signal.SIGINT)
        return None
sys.meta_path.insert(0, Hook())
from anglesmooth.cli import main
main(sys.argv[2:])
"""


@pytest.mark.parametrize("module", ["numpy", "click", "rich", "anglesmooth.topology"])
def test_ctrl_c_while_the_modules_load_is_one_line_and_130(work, module):
    (work / "launch.py").write_text(IMPORT_INTERRUPT)
    p = subprocess.run([sys.executable, "launch.py", module, "in.vtu", "out.vtu"], cwd=work, capture_output=True,
                       env=env(), timeout=120, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert p.returncode == 130, p.stderr
    assert error_line(p.stderr.decode()) == PREFIX + "interrupted"
    assert not (work / "out.vtu").exists()


def test_xdmf_hdf5_data_is_committed_with_the_other_outputs(work):
    """A run that fails after the mesh is written (here: --json onto a full device) leaves no new .h5
    and keeps the one that was there; a run that succeeds writes both files (a readable mesh)."""
    if not stat.S_ISCHR(os.stat("/dev/full").st_mode):
        pytest.fail("/dev/full is not a character device on this machine")
    (work / "out.h5").write_bytes(b"old")
    p = run_cli(work / "in.vtu", work / "out.xdmf", "--json", "/dev/full")
    assert p.returncode == 3, p.stderr
    assert (work / "out.h5").read_bytes() == b"old"
    assert not (work / "out.xdmf").exists()
    assert not [f for f in os.listdir(work) if ".tmp" in f]
    p = run_cli(work / "in.vtu", work / "out.xdmf")
    assert p.returncode == 0, p.stderr
    assert read(work / "out.xdmf").n_points == read(work / "in.vtu").n_points


def test_a_symlinked_xdmf_output_writes_its_h5_beside_the_target(work, monkeypatch):
    """OUTPUT out.xdmf -> elsewhere/real.xdmf is followed (as every symlinked output): the XDMF replaces real.xdmf
    and its HDF5 data is elsewhere/real.h5, which it refers to and which is checked like the other outputs.  It
    was elsewhere/out.h5, a path nobody checked: there it replaced an input (here the --fix-nodes file), and it
    was written at once instead of being committed with the other outputs."""
    monkeypatch.chdir(work)
    (work / "elsewhere").mkdir()
    (work / "elsewhere" / "out.h5").write_text("1 2\n")  # an input where the .h5 used to go
    os.symlink("elsewhere/real.xdmf", work / "out.xdmf")
    p = run_cli("in.vtu", "out.xdmf", "--fix-nodes", "elsewhere/out.h5", "-q", cwd=work)
    assert p.returncode == 0, p.stderr
    assert (work / "elsewhere" / "out.h5").read_text() == "1 2\n"
    assert sorted(os.listdir(work / "elsewhere")) == ["out.h5", "real.h5", "real.xdmf"]
    assert os.readlink(work / "out.xdmf") == "elsewhere/real.xdmf" and not (work / "out.h5").exists()
    assert read(work / "out.xdmf").n_points == read(work / "in.vtu").n_points  # through the link
    # the .h5 beside the target is checked as an output: it may not be an input
    p = run_cli("in.vtu", "out.xdmf", "--fix-nodes", "elsewhere/real.h5", cwd=work)
    assert p.returncode == 2 and "the .h5 beside OUTPUT" in p.stderr.decode() and \
        "is the same file as --fix-nodes 'elsewhere/real.h5'" in p.stderr.decode(), p.stderr
