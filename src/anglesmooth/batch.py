"""Many files at once: :func:`smooth_files` and :func:`check_files`, in this process, a pool or a Dask cluster.

A *task* is one file: read it, measure (and smooth and write) it, and return a
small picklable :class:`FileResult`; an unreadable file gives an error result
and the other files go on.  One executor interface runs the tasks:

* ``jobs=1`` (the default): one after the other in this process;
* ``jobs=N`` (``0`` = every core this process may use): a
  :class:`concurrent.futures.ProcessPoolExecutor` of ``min(N, files)`` spawned
  workers, each limited to ``cores // workers`` numba threads (so workers x
  threads never exceeds the cores);
* ``client=``: a Dask ``distributed.Client``; each worker reads and writes the
  files itself, so the paths must name the same files there (a shared file
  system mounted at the same place; paths are made absolute before they are
  sent).

The same task function runs in all three, on the same arguments, so the
results and the written files are the same bit for bit.  Results come back
in input order, and ``on_result(index, result)`` is called in input order too
(as soon as every earlier file is done), so messages built from it are stable.

Interruption: a ``KeyboardInterrupt`` (or the CLI's SIGTERM exception) while a
pool runs cancels the files not started and sends SIGTERM to the workers; a
worker in the middle of a write removes its temporary file and exits 143, so no
partial output is left (every output is written atomically); a worker that gets
SIGTERM while numba compiles acts on it once the compiler is done, as the CLI
does (:mod:`anglesmooth._signals`).  A Dask worker terminated (SIGTERM) while one of
its threads writes removes the temporary files of the write before it ends
(:func:`_guard_worker_thread`).  Files finished before the interruption keep
their complete outputs.

>>> import os, tempfile
>>> from anglesmooth.generate import structured_quads
>>> from anglesmooth.io import write
>>> d = tempfile.mkdtemp()
>>> write(structured_quads(4, 4), os.path.join(d, "a.vtu"))
>>> [r.exit_code for r in smooth_files([os.path.join(d, "a.vtu"), os.path.join(d, "no.vtu")], output_dir=d,
...                                   suffix="_s", passes=2)]
[0, 3]
>>> sorted(os.listdir(d))
['a.vtu', 'a_s.vtu']
>>> check_files([os.path.join(d, "a_s.vtu")], thresholds={"min_angle": 30})[0].passed
True
>>> for f in os.listdir(d): os.remove(os.path.join(d, f))
>>> os.rmdir(d)
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import io as _stdio
import multiprocessing
import os
import signal
import sys
import threading
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from . import _paths
from ._signals import Deferred
from .errors import AngleSmoothError
from .fixing import fixed_mask
from .filesets import MESH_SUFFIXES, BatchError, find_mesh_files, make_dirs, output_name, plan_outputs

__all__ = [
    "MESH_SUFFIXES",
    "BatchError",
    "FileResult",
    "check_file",
    "check_files",
    "cores",
    "find_mesh_files",
    "output_name",
    "smooth_files",
]

@dataclass(frozen=True)
class FileResult:
    """The outcome of one file (picklable; the same from every back end).

    Attributes
    ----------
    input, output : str
        The paths as given (``output`` is None for a check).
    report : dict or None
        Smoothing: the JSON document of :func:`anglesmooth.report.smooth_json`;
        check: the quality summary.  None when the file failed.
    gates : list[dict]
        ``{name, threshold, value, passed}`` per gate.
    passed : bool or None
        All gates passed (None when the file failed).
    error : str or None
        The one-line message of a failure.
    exit_code : int
        0 done, 1 a gate failed, 2 an option that does not fit this file
        (e.g. an unknown fix group), 3 unreadable input or unwritable output,
        4 an internal error.
    messages : tuple[str, ...]
        One line per failed gate.
    elapsed_s : float
        Wall time of the task.
    traceback : str or None
        The traceback of a failure (for ``--debug``).
    """

    input: str
    output: str | None
    report: dict | None = None
    gates: list = field(default_factory=list)
    passed: bool | None = None
    error: str | None = None
    exit_code: int = 0
    messages: tuple = ()
    elapsed_s: float = 0.0
    traceback: str | None = None

    @property
    def error_line(self) -> str | None:
        """The error as one line that names the input."""
        if self.error is None:
            return None
        return self.error if self.input in self.error else f"{self.input}: {self.error}"

    @property
    def entry(self) -> dict[str, Any]:
        """The check form: ``{input, report, gates, passed, error}`` (see ``anglesmooth.report.check_json``)."""
        return {"input": self.input, "report": self.report, "gates": self.gates, "passed": self.passed,
                "error": self.error}


def cores() -> int:
    """The number of cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


# -------------------------------------------------------------------------------------------------- tasks


def _failure(exc: BaseException) -> tuple[int, str]:
    if isinstance(exc, AngleSmoothError):
        return int(getattr(exc, "exit_code", 3)), str(exc)
    if isinstance(exc, MemoryError):
        return 3, "out of memory (the mesh is too large for this machine)"
    return 4, f"internal error: {type(exc).__name__}: {exc} (please report it; --debug shows the traceback)"


def _read(path: str, input_format: str | None):
    from .io import read

    with contextlib.redirect_stdout(_stdio.StringIO()):  # meshio prints blank lines; stdout may carry JSON
        return read(path, file_format=input_format)


@dataclass(frozen=True)
class _Task:
    name: str  # as given, for messages and results
    path: str  # where to read (absolute for a cluster)
    input_format: str | None
    thresholds: dict

    def failed(self, exc: BaseException, elapsed: float, tb: str | None = None) -> FileResult:
        code, message = _failure(exc)
        for where, given in self._renames():  # a cluster gets absolute paths: report the names given
            if where != given and os.path.isabs(where):
                message = message.replace(where, given)
        return FileResult(self.name, self._output_name(), error=message, exit_code=code, elapsed_s=elapsed,
                          traceback=tb)

    def _output_name(self) -> str | None:
        return None

    def _renames(self) -> list[tuple[str, str]]:
        return [(self.path, self.name)]

    def __call__(self) -> FileResult:
        import time

        t0 = time.perf_counter()
        try:
            return self.run(t0)
        except Exception as exc:  # one file's failure is its result; interrupts propagate
            if _WORKER["stop"]:
                raise
            return self.failed(exc, time.perf_counter() - t0, traceback.format_exc())


@dataclass(frozen=True)
class _CheckTask(_Task):
    reader: Callable | None = None

    def run(self, t0: float) -> FileResult:
        import time

        from .gates import evaluate
        from .quality import summarize
        from .topology import build_cell_topology

        mesh = (self.reader or _read)(self.path, self.input_format)
        topo = build_cell_topology(mesh)  # no smoothing tables needed
        summary = summarize(mesh.points, topo)
        gates = evaluate(summary, self.thresholds, mesh.points, topo)
        return FileResult(self.name, None, report=summary, gates=[g.to_dict() for g in gates],
                          passed=all(g.passed for g in gates),
                          exit_code=0 if all(g.passed for g in gates) else 1,
                          messages=tuple(g.message(self.name) for g in gates if not g.passed),
                          elapsed_s=time.perf_counter() - t0)


@dataclass(frozen=True)
class _SmoothTask(_Task):
    output: str = ""  # where to write
    output_display: str = ""
    output_format: str | None = None
    method: str = "angle"
    passes: int = 10
    tol: float | None = None
    guard: bool = True
    order: str = "colour"
    fix_groups: tuple = ()
    fix_nodes: tuple | None = None

    def _output_name(self) -> str | None:
        return self.output_display

    def _renames(self) -> list[tuple[str, str]]:
        return [(self.output, self.output_display), (self.path, self.name)]

    def run(self, t0: float) -> FileResult:
        import time

        from . import report
        from .driver import smooth
        from .gates import evaluate
        from .io import check_output, write
        from .quality import summarize
        from .topology import build_topology

        mesh = _read(self.path, self.input_format)
        with contextlib.redirect_stdout(_stdio.StringIO()):  # before smoothing, as one file: can OUTPUT hold it?
            check_output(mesh, self.output, file_format=self.output_format)
        topo = build_topology(mesh, fixed_mask(mesh, self.fix_groups, self.fix_nodes))
        before = summarize(mesh.points, topo)
        result = smooth(mesh, self.method, self.passes, tol=self.tol, guard=self.guard, order=self.order,
                        topology=topo)
        after = summarize(result.points, topo)
        gates = evaluate(after, self.thresholds, result.points, topo)
        passed = all(g.passed for g in gates)
        document = report.smooth_json(
            input=self.name, output=self.output_display, method=self.method, guard=self.guard, order=self.order,
            passes=result.passes, passes_requested=self.passes, tol=self.tol, displacements=result.displacements,
            rejected=result.rejected, before=before, after=after, elapsed_s=result.elapsed_s, gates=gates,
            passed=passed)
        write(mesh, self.output, points=result.points, file_format=self.output_format)
        return FileResult(self.name, self.output_display, report=document, gates=document["gates"], passed=passed,
                          exit_code=0 if passed else 1,
                          messages=tuple(g.message(self.output_display) for g in gates if not g.passed),
                          elapsed_s=time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------------- executors

# per process: set in pool workers by _init_worker; "stop" once SIGTERM arrived
_WORKER = {"busy": False, "stop": False, "guarded": False}


class _Stop(BaseException):
    """Raised in a pool worker by SIGTERM: unwinds the task (removing temporary files) and ends the worker."""


def _stop(signum: int) -> None:  # pragma: no cover - runs in worker processes
    if _WORKER["stop"]:  # a second SIGTERM while the first unwinds: the unwinding removes the temporaries
        return
    _WORKER["stop"] = True
    if _WORKER["busy"]:
        raise _Stop()
    _paths.remove_temporaries()
    os._exit(128 + signum)


#: The workers' SIGTERM handler: as the CLI's, it never raises inside numba's compiler (the exception was lost
#: there, and the worker smoothed on), but once the compiler is done (see :mod:`anglesmooth._signals`).
_on_stop = Deferred(_stop)


def _init_worker(threads: int) -> None:  # pragma: no cover - runs in worker processes
    """Pool worker set-up: Ctrl-C is the parent's business, SIGTERM stops cleanly, numba gets ``threads``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _on_stop)
    user = os.environ.get("NUMBA_NUM_THREADS", "")
    threads = min(threads, int(user)) if user.isdigit() and int(user) > 0 else threads
    os.environ["NUMBA_NUM_THREADS"] = str(threads)  # read when numba is first imported
    if "numba" in sys.modules:
        sys.modules["numba"].set_num_threads(threads)


def _execute(task: _Task) -> FileResult:
    if threading.current_thread() is not threading.main_thread():
        _guard_worker_thread()
    _WORKER["busy"] = True
    try:
        return task()
    except BaseException:
        if _WORKER["stop"]:  # pragma: no cover - runs in worker processes
            _paths.remove_temporaries()
            os._exit(128 + signal.SIGTERM)
        raise
    finally:
        _WORKER["busy"] = False


def _guard_worker_thread() -> None:
    """In a Dask worker's thread: the worker's loop (main thread) makes SIGTERM remove our temporaries first
    (:func:`._paths.remove_temporaries_on_sigterm`; the signal ended the process there mid-write), once."""
    if _WORKER["guarded"]:
        return
    _WORKER["guarded"] = True
    try:
        from distributed import get_worker

        loop = get_worker().loop
    except Exception:  # noqa: BLE001 - not in a Dask worker (or no distributed)
        return
    done = threading.Event()

    def install() -> None:  # nothing when the loop is not the main thread (a cluster of threads)
        try:
            with contextlib.suppress(ValueError):
                _paths.remove_temporaries_on_sigterm()
        finally:
            done.set()

    loop.add_callback(install)
    done.wait(10)


class _InOrder:
    """Collect results by index and hand them to ``on_result`` in input order."""

    def __init__(self, n: int, on_result: Callable[[int, FileResult], None] | None):
        self.results: list[FileResult | None] = [None] * n
        self.next = 0
        self.on_result = on_result

    def add(self, i: int, result: FileResult) -> None:
        self.results[i] = result
        while self.next < len(self.results) and self.results[self.next] is not None:
            if self.on_result is not None:
                self.on_result(self.next, self.results[self.next])
            self.next += 1


def _stop_pool(pool: cf.ProcessPoolExecutor) -> None:
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        with contextlib.suppress(Exception):
            p.terminate()  # SIGTERM: the worker removes its temporary file and exits
    for p in processes:
        with contextlib.suppress(Exception):
            p.join(timeout=30)
            if p.is_alive():
                p.kill()


def _run_pool(tasks: Sequence[_Task], jobs: int, collect: _InOrder) -> None:
    workers = min(jobs, len(tasks))
    pool = cf.ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=_init_worker, initargs=(max(1, cores() // workers),))
    try:
        futures = {pool.submit(_execute, t): i for i, t in enumerate(tasks)}
        for future in cf.as_completed(futures):
            i = futures[future]
            try:
                result = future.result()
            except cf.process.BrokenProcessPool:
                result = tasks[i].failed(AngleSmoothError("a worker process died (killed, or out of memory) "
                                                          "before this file was done"), 0.0)
            except Exception as exc:
                result = tasks[i].failed(exc, 0.0)
            collect.add(i, result)
    except BaseException:
        _stop_pool(pool)
        raise
    pool.shutdown(wait=True)


def _run_dask(tasks: Sequence[_Task], client, collect: _InOrder) -> None:
    from distributed import as_completed

    futures = [client.submit(_execute, t, pure=False) for t in tasks]
    index = {f.key: i for i, f in enumerate(futures)}
    try:
        for future in as_completed(futures):
            i = index[future.key]
            try:
                result = future.result()
            except Exception as exc:
                result = tasks[i].failed(exc, 0.0)
            collect.add(i, result)
            future.release()
    except BaseException:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        raise


def _run(tasks: Sequence[_Task], jobs: int, client, on_result) -> list[FileResult]:
    collect = _InOrder(len(tasks), on_result)
    jobs = cores() if jobs == 0 else jobs
    if jobs < 0:
        raise ValueError("jobs must be >= 0")
    if client is not None:
        _run_dask(tasks, client, collect)
    elif jobs == 1 or len(tasks) <= 1:
        for i, task in enumerate(tasks):
            collect.add(i, _execute(task))
    else:
        _run_pool(tasks, jobs, collect)
    return collect.results  # type: ignore[return-value]


def _where(path: str, client) -> str:
    return os.path.abspath(path) if client is not None else path


# ------------------------------------------------------------------------------------------------- public


def check_file(path: str, *, input_format: str | None = None, thresholds: dict | None = None,
               reader: Callable | None = None, name: str | None = None) -> FileResult:
    """Measure one file and apply the gates.

    ``reader(path, input_format)`` replaces :func:`anglesmooth.read`; ``name``
    is the file's name in the result and its messages (default: ``path``).
    """
    return _execute(_CheckTask(str(name or path), str(path), input_format, dict(thresholds or {}), reader))


def check_files(paths: Sequence[str], *, input_format: str | None = None, thresholds: dict | None = None,
                jobs: int = 1, client=None, on_result: Callable[[int, FileResult], None] | None = None,
                reader: Callable | None = None, names: Sequence[str] | None = None) -> list[FileResult]:
    """:func:`check_file` for every path, one result per path in input order (see the module docstring).

    ``reader`` must be a module-level function when ``jobs`` or ``client``
    runs the files elsewhere (it is pickled).
    """
    names = [str(p) for p in paths] if names is None else [str(n) for n in names]
    tasks = [_CheckTask(n, _where(str(p), client), input_format, dict(thresholds or {}), reader)
             for p, n in zip(paths, names)]
    return _run(tasks, jobs, client, on_result)


def smooth_files(
    paths: Sequence[str],
    outputs: Sequence[str] | None = None,
    *,
    output_dir: str | None = None,
    suffix: str = "",
    extension: str | None = None,
    in_place: bool = False,
    method: str = "angle",
    passes: int = 10,
    tol: float | None = None,
    guard: bool = True,
    order: str = "colour",
    fix_groups: Sequence[str] = (),
    fix_nodes: Sequence[int] | None = None,
    input_format: str | None = None,
    output_format: str | None = None,
    thresholds: dict | None = None,
    jobs: int = 1,
    client=None,
    on_result: Callable[[int, FileResult], None] | None = None,
) -> list[FileResult]:
    """Read, smooth and write every file; one :class:`FileResult` per path, in input order.

    The outputs are ``outputs`` (one per path), or each input rewritten
    (``in_place``), or :func:`output_name` of each path (``output_dir``,
    created if missing, ``suffix``, ``extension``).  Two inputs with one output, or an output
    over an input (unless ``in_place``), raise :class:`BatchError` before any
    work.  The smoothing arguments are those of :func:`anglesmooth.smooth`;
    ``thresholds`` are gates (see :mod:`anglesmooth.gates`) on each result.
    """
    paths = [str(p) for p in paths]
    if outputs is None:
        if in_place:
            outputs = list(paths)
        elif output_dir is None and not suffix and extension is None:
            raise BatchError("give outputs, output_dir, suffix, extension or in_place")
        else:
            outputs = [output_name(p, output_dir=output_dir, suffix=suffix, extension=extension) for p in paths]
    outputs = [str(o) for o in outputs]
    if len(outputs) != len(paths):
        raise BatchError(f"{len(paths)} inputs but {len(outputs)} outputs")
    plan_outputs(paths, outputs, in_place)
    if output_dir is not None:
        make_dirs([output_dir])
    nodes = None if fix_nodes is None else tuple(int(i) for i in fix_nodes)
    tasks = [_SmoothTask(p, _where(p, client), input_format, dict(thresholds or {}), output=_where(o, client),
                         output_display=o, output_format=output_format, method=method, passes=passes, tol=tol,
                         guard=guard, order=order, fix_groups=tuple(fix_groups), fix_nodes=nodes)
             for p, o in zip(paths, outputs)]
    return _run(tasks, jobs, client, on_result)
