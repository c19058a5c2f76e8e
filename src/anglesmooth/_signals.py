"""Signal handlers that never raise inside numba's compiler (used by the CLI and by batch pool workers).

An exception raised by a signal handler while numba compiles is raised inside
llvmlite's ctypes callbacks: Python prints it as "Exception ignored" and loses
it (the run goes on), or LLVM crashes (exit -11).  :class:`Deferred` wraps the
action of a SIGTERM / SIGINT handler: outside the compiler it acts at once;
inside, it records the signal and looks again every :data:`RETRY_S` seconds
(SIGALRM) until the compiler's frames are gone, then acts.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable

__all__ = ["RETRY_S", "Deferred", "in_compiler"]

_COMPILER_DIRS = tuple(f"{os.sep}{name}{os.sep}" for name in ("numba", "llvmlite"))
#: Seconds between two looks at whether the compiler is done.
RETRY_S = 0.05


def in_compiler(frame) -> bool:
    """Whether ``frame`` or a caller of it runs code of numba or llvmlite."""
    while frame is not None:
        if any(part in frame.f_code.co_filename for part in _COMPILER_DIRS):
            return True
        frame = frame.f_back
    return False


class Deferred:
    """A signal handler calling ``act(signum)`` at once, or once numba has finished compiling."""

    def __init__(self, act: Callable[[int], None]):
        self.act = act
        self.pending: list[int] = []

    def __call__(self, signum, frame) -> None:  # pragma: no cover - exercised in subprocesses
        if in_compiler(frame):
            if not self.pending:
                self.pending.append(signum)
                signal.signal(signal.SIGALRM, self.retry)
                signal.setitimer(signal.ITIMER_REAL, RETRY_S)
            return
        self.act(signum)

    def retry(self, signum, frame) -> None:  # pragma: no cover - exercised in subprocesses
        """The SIGALRM handler: act on the pending signal unless the compiler still runs."""
        if in_compiler(frame):
            signal.setitimer(signal.ITIMER_REAL, RETRY_S)
            return
        self.act(self.pending.pop())
