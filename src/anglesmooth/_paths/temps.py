"""Temporary files and directories of unfinished writes: made here, tracked until renamed or removed.

Every temporary an output needs (the staged file beside a regular output, the private
directory behind a stream, the XDMF writer's directory, the writability probe) is made
by :func:`make_temp` and listed until :func:`forget` (after its rename) or its removal.
:func:`remove_temporaries` removes all of them at once: what a process that is being
terminated calls when its writes run in another thread than the one that gets the
signal (a Dask worker: see :mod:`anglesmooth.batch`), so that no partial output or
temporary file is left, whatever the writing thread was doing.

A temporary is listed *before* it is created (under the lock), so a sweep can never
miss one that exists; after a sweep every new :func:`make_temp` fails.
"""

from __future__ import annotations

import contextlib
import os
import random
import shutil
import threading
from pathlib import Path

__all__ = ["forget", "make_temp", "remove_temporaries", "remove_temporaries_on_sigterm", "temporary_directory"]

_CHARS = "abcdefghijklmnopqrstuvwxyz0123456789_"
_LIVE: dict[str, bool] = {}  # path -> is a directory
_LOCK = threading.Lock()
_OWNER: list[int | None] = [None]  # the thread inside the lock (a sweep on that thread must not wait for it)
_CLOSED = [False]


class TerminatingError(OSError):
    """A temporary asked for after :func:`remove_temporaries` (the process is being terminated)."""


def make_temp(directory: str | os.PathLike, prefix: str, suffix: str = "", *, is_dir: bool = False) -> Path:
    """Create a new file (mode 0600, closed) or directory (0700) ``prefix + 8 random characters + suffix``
    in ``directory`` and list it (like :func:`tempfile.mkstemp` / :func:`tempfile.mkdtemp`)."""
    rng = random.Random()
    for _ in range(100):
        path = os.path.join(os.fspath(directory), prefix + "".join(rng.choices(_CHARS, k=8)) + suffix)
        with _LOCK:
            _OWNER[0] = threading.get_ident()
            try:
                if _CLOSED[0]:
                    raise TerminatingError("the process is being terminated: no new output is written")
                _LIVE[path] = is_dir
                try:
                    if is_dir:
                        os.mkdir(path, 0o700)
                    else:
                        os.close(os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600))
                except FileExistsError:
                    del _LIVE[path]
                    continue
                except BaseException:
                    del _LIVE[path]
                    raise
                return Path(path)
            finally:
                _OWNER[0] = None
    raise FileExistsError(f"no free temporary name in '{directory}'")


def forget(path: str | os.PathLike) -> None:
    """``path`` is no temporary any more (renamed into place, or removed)."""
    _LIVE.pop(os.fspath(path), None)


def remove(path: str | os.PathLike) -> None:
    """Remove a temporary made by :func:`make_temp` (file or directory) and forget it."""
    p = os.fspath(path)
    if _LIVE.get(p):
        shutil.rmtree(p, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            os.unlink(p)
    forget(p)


@contextlib.contextmanager
def temporary_directory(directory: str | os.PathLike | None = None, prefix: str = "anglesmooth-"):
    """A listed temporary directory, removed at the end (:class:`tempfile.TemporaryDirectory`)."""
    import tempfile

    path = make_temp(directory if directory is not None else tempfile.gettempdir(), prefix, is_dir=True)
    try:
        yield path
    finally:
        remove(path)


def remove_temporaries(timeout: float = 5.0) -> int:
    """Remove every listed temporary (the process is being terminated); later :func:`make_temp` calls fail.

    Waits up to ``timeout`` seconds for another thread that is creating one, never for the calling
    thread (a signal handler running on the thread it interrupted).  Returns how many were removed.
    """
    _CLOSED[0] = True
    locked = _OWNER[0] != threading.get_ident() and _LOCK.acquire(timeout=timeout)
    try:
        items = list(_LIVE.items())
        for path, _ in items:
            remove(path)
        return len(items)
    finally:
        if locked:
            _LOCK.release()


def remove_temporaries_on_sigterm() -> None:
    """From now on SIGTERM (and the interpreter's exit) first removes every temporary (main thread only).

    Then it does what it did before: the previous handler, or the default action (the process ends
    as it would have, status 143).  Nothing changes where SIGTERM is ignored.
    """
    import atexit
    import signal

    previous = signal.getsignal(signal.SIGTERM)
    if previous is signal.SIG_IGN or getattr(previous, "_anglesmooth_cleanup", False):
        return

    def on_sigterm(signum, frame) -> None:
        remove_temporaries()
        if callable(previous):
            previous(signum, frame)
            return
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)

    on_sigterm._anglesmooth_cleanup = True  # type: ignore[attr-defined]
    signal.signal(signal.SIGTERM, on_sigterm)
    atexit.register(remove_temporaries)
