"""Interrupting a run (SIGINT, SIGTERM) leaves no partial output and exits non-zero.

The command line runs as a real subprocess on a generated 200 000-triangle mesh
with a huge number of passes.  the CLI documents exit 130 for SIGINT and 143 for
SIGTERM and one ``anglesmooth: error: interrupted`` / ``terminated`` line.

Three moments are tested:

* a fixed delay after start with the plain ``python -m anglesmooth`` (wherever
  the run is, the guarantee must hold);
* during the passes: a thin launcher wraps ``anglesmooth.cli.smooth.run_smooth`` so that every
  pass prints a marker line on stderr, and the signal is sent after the first
  marker;
* during the write: the launcher makes the meshio write print a marker once the
  temporary file is complete and then sleep, so the signal arrives while the
  temporary file exists next to the (absent) output.

After the signal the directory must hold exactly the input, unchanged (sha256),
and an existing output must be untouched.
"""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from anglesmooth._signals import RETRY_S
from anglesmooth.generate import random_delaunay
from anglesmooth.io import write

EXIT = {signal.SIGINT: (130, "interrupted"), signal.SIGTERM: (143, "terminated")}
SIGNALS = [signal.SIGINT, signal.SIGTERM]
MARK = "signal-test:"

LAUNCHER = f"""
import sys, time
from anglesmooth import io
from anglesmooth.cli import main, smooth as cli

def run_smooth(*args, callback=None, **kwargs):
    def cb(k, points, displacement):
        print("{MARK} pass", k, file=sys.stderr, flush=True)
        if callback is not None:
            callback(k, points, displacement)
    return orig_smooth(*args, callback=cb, **kwargs)

def write_meshio(tmp, *args, **kwargs):
    orig_write(tmp, *args, **kwargs)
    if "anglesmooth-check-" in str(tmp):  # the output-format check's sample, not the staged output
        return
    print("{MARK} written", tmp, file=sys.__stderr__, flush=True)  # io silences sys.stderr while writing
    time.sleep(60)

orig_smooth, orig_write = cli.run_smooth, io._write_meshio
cli.run_smooth = run_smooth
if sys.argv[1] == "write":
    io._write_meshio = write_meshio
main(sys.argv[2:])
"""


@pytest.fixture(scope="module")
def big(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("big") / "big.vtu"
    write(random_delaunay(200_000, seed=7), path)
    return path


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _start(argv: list[str], cwd: Path) -> subprocess.Popen:
    # restore SIGINT's default disposition: a shell may start background jobs with SIGINT ignored,
    # and Python only installs its KeyboardInterrupt handler when SIGINT is not ignored
    return subprocess.Popen(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _wait_for(proc: subprocess.Popen, needle: str, timeout: float = 600.0) -> list[str]:
    """Read stderr lines until one contains ``needle``; return the lines read."""
    lines: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        lines.append(line)
        if needle in line:
            return lines
    proc.kill()
    raise AssertionError(f"never saw {needle!r}; stderr so far: {''.join(lines)}")


def _finish(proc: subprocess.Popen, sig: signal.Signals, earlier: list[str]) -> None:
    proc.send_signal(sig)
    stdout, rest = proc.communicate(timeout=600)  # generous: a loaded machine, a deferred signal
    stderr = "".join(earlier) + rest
    code, word = EXIT[sig]
    assert proc.returncode == code, stderr
    assert stdout == ""
    assert "Traceback" not in stderr
    # a cold kernel cache adds the one "compiling kernels once" notice line (issue 17); it is not an error
    errors = [line for line in stderr.splitlines()
              if line.strip() and not line.startswith(MARK) and not line.startswith("compiling kernels once")]
    assert errors == [f"anglesmooth: error: {word}"], stderr


def _setup(big: Path, tmp_path: Path) -> tuple[Path, Path, str]:
    src = tmp_path / "in.vtu"
    src.write_bytes(big.read_bytes())
    return src, tmp_path / "out.vtu", _digest(src)


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: s.name)
def test_signal_after_a_fixed_delay(big, tmp_path, sig):
    src, out, digest = _setup(big, tmp_path)
    proc = _start([sys.executable, "-m", "anglesmooth", str(src), str(out), "--passes", "100000"], tmp_path)
    time.sleep(4.0)
    assert proc.poll() is None, proc.communicate()
    _finish(proc, sig, [])
    assert sorted(os.listdir(tmp_path)) == ["in.vtu"]
    assert _digest(src) == digest


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: s.name)
def test_signal_during_the_passes(big, tmp_path, sig):
    src, out, digest = _setup(big, tmp_path)
    proc = _start([sys.executable, "-c", LAUNCHER, "smooth", str(src), str(out), "--passes", "100000"], tmp_path)
    lines = _wait_for(proc, f"{MARK} pass 1")
    _finish(proc, sig, lines)
    assert sorted(os.listdir(tmp_path)) == ["in.vtu"]
    assert _digest(src) == digest


@pytest.mark.parametrize("sig", SIGNALS, ids=lambda s: s.name)
def test_signal_during_the_write_keeps_the_old_output(big, tmp_path, sig):
    src, out, digest = _setup(big, tmp_path)
    out.write_bytes(b"previous result")
    # --force: an existing OUTPUT of the input's format is otherwise refused (the rule for existing outputs)
    proc = _start([sys.executable, "-c", LAUNCHER, "write", str(src), str(out), "--passes", "1", "--force"], tmp_path)
    lines = _wait_for(proc, f"{MARK} written")
    tmp = Path(lines[-1].split("written", 1)[1].strip())
    assert tmp.parent == tmp_path and tmp.exists() and tmp.stat().st_size > 0  # the write really was under way
    _finish(proc, sig, lines)
    assert sorted(os.listdir(tmp_path)) == ["in.vtu", "out.vtu"]
    assert out.read_bytes() == b"previous result"
    assert _digest(src) == digest


def _frame(filename, back=None):
    import types

    return types.SimpleNamespace(f_code=types.SimpleNamespace(co_filename=filename), f_back=back)


#: A signal arriving while numba compiles: llvmlite's frames on top of numba's on top of ours.
COMPILING = _frame(f"{os.sep}site-packages{os.sep}llvmlite{os.sep}binding{os.sep}executionengine.py",
                   _frame(f"{os.sep}site-packages{os.sep}numba{os.sep}core{os.sep}compiler.py", _frame("driver.py")))


def _deferring(monkeypatch, handler, raised, sig=signal.SIGTERM):
    """``handler`` (a ``_signals.Deferred``) defers ``sig`` while compiling, then raises ``raised``."""
    armed = []
    monkeypatch.setattr(signal, "setitimer", lambda which, seconds: armed.append(seconds))
    monkeypatch.setattr(signal, "signal", lambda sig, handler: None)
    monkeypatch.setattr(handler, "pending", [])
    handler(sig, COMPILING)  # deferred: no exception inside the compiler
    assert handler.pending == [sig] and armed == [RETRY_S]
    handler.retry(signal.SIGALRM, COMPILING)  # still compiling: look again later
    assert armed == [RETRY_S] * 2
    with pytest.raises(raised):
        handler.retry(signal.SIGALRM, _frame("driver.py"))
    assert handler.pending == []


def test_a_signal_while_numba_compiles_is_acted_on_once_it_is_done(monkeypatch):
    """SIGTERM during the first run's compile was raised inside llvmlite's ctypes callback: printed as
    'Exception ignored', lost (the run went on), or exit -11. The handler now waits until the compiler's
    frames are gone (SIGALRM every 50 ms), then raises."""
    from anglesmooth.cli import errors as cli_errors

    _deferring(monkeypatch, cli_errors.on_signal, cli_errors.Terminated)
    with pytest.raises(KeyboardInterrupt):
        cli_errors.on_signal(signal.SIGINT, _frame("driver.py"))
    with pytest.raises(cli_errors.Terminated):
        cli_errors.on_signal(signal.SIGTERM, _frame("driver.py"))


def test_a_pool_worker_defers_sigterm_while_numba_compiles(monkeypatch):
    """A batch pool worker's SIGTERM handler raised at once, inside numba's compiler too (lost there: the
    worker smoothed on, and the parent waited 30 s per worker before SIGKILL); it now defers like the CLI's,
    then unwinds the task (the atomic write removes its temporary file) and exits 143."""
    from anglesmooth import batch

    monkeypatch.setitem(batch._executors._WORKER, "busy", True)
    monkeypatch.setitem(batch._executors._WORKER, "stop", False)
    _deferring(monkeypatch, batch._executors._on_stop, batch._executors._Stop)
    assert batch._executors._WORKER["stop"]
