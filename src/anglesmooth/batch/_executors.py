"""The executors of :mod:`anglesmooth.batch`: run tasks in this process, a process pool or a Dask cluster.

Each gives the results in input order (:class:`_InOrder`).  Pool workers stop cleanly on SIGTERM (the task
unwinds, removing its temporary files, and the worker exits 143); a Dask worker's thread makes the worker's
SIGTERM remove the temporaries of a write first (:func:`_guard_worker_thread`).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import os
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from .. import _paths
from .._memory import release_free_memory
from .._signals import Deferred
from ..errors import AngleSmoothError

if TYPE_CHECKING:
    from ._tasks import FileResult, _Task

__all__ = ["cores"]


def cores() -> int:
    """The number of cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


# per process: set in pool workers by _init_worker; "stop" once SIGTERM arrived
_WORKER = {"busy": False, "stop": False, "guarded": False, "pool": False}


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
    _WORKER["pool"] = True
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
        if _WORKER["pool"]:  # our own worker process: give the file's freed memory back before the next file
            release_free_memory()


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
