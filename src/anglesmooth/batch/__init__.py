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

import os
from collections.abc import Callable, Sequence

from ..filesets import MESH_SUFFIXES, BatchError, find_mesh_files, make_dirs, output_name, plan_outputs
from ._executors import _execute, _run, cores
from ._tasks import FileResult, _CheckTask, _SmoothTask

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


def _where(path: str, client) -> str:
    return os.path.abspath(path) if client is not None else path


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
