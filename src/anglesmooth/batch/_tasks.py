"""The tasks of :mod:`anglesmooth.batch`: one file each (read, measure, smooth, write), and their result.

A task is a small frozen dataclass, picklable, so that this process, a process pool and a Dask cluster run the
same code on the same arguments; calling it returns a :class:`FileResult` (a file's failure is its result).
"""

from __future__ import annotations

import contextlib
import io as _stdio
import os
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ..errors import AngleSmoothError
from ..fixing import fixed_mask
from ._executors import _WORKER

__all__ = ["FileResult"]


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


def _failure(exc: BaseException) -> tuple[int, str]:
    if isinstance(exc, AngleSmoothError):
        return int(getattr(exc, "exit_code", 3)), str(exc)
    if isinstance(exc, MemoryError):
        return 3, "out of memory (the mesh is too large for this machine)"
    return 4, f"internal error: {type(exc).__name__}: {exc} (please report it; --debug shows the traceback)"


def _read(path: str, input_format: str | None):
    from ..io import read

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

        from ..gates import evaluate
        from ..quality import summarize
        from ..topology import build_cell_topology

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

        from .. import report
        from ..driver import smooth
        from ..gates import evaluate
        from ..io import check_output, write
        from ..quality import summarize
        from ..topology import build_topology

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
