"""Standard streams: closed descriptors at start-up, and the paths that name a descriptor (``-``, ``/dev/stdout``,
``/dev/fd/N``)."""

from __future__ import annotations

import os
import re
import sys

__all__ = ["STDIO", "carries_stdout", "mark_closed_std_fds", "std_fd_closed"]

STDIO = "-"
_CLOSED_STD: set[int] = set()
_STD_NAMES = {"stdin": 0, "stdout": 1, "stderr": 2}
_FD_PATH = re.compile(r"^/(?:dev/fd|proc/self/fd|proc/%d/fd)/(\d+)$" % os.getpid())


def mark_closed_std_fds() -> set[int]:
    """Open ``/dev/null`` on any of fds 0, 1, 2 that is closed, so no file we open takes its number.

    Returns (and remembers, for :func:`std_fd_closed`) the descriptors that were closed.  Called by
    the command line at start-up.
    """
    import fcntl

    for fd in (0, 1, 2):
        try:
            mode = fcntl.fcntl(fd, fcntl.F_GETFL) & os.O_ACCMODE
        except OSError:
            usable = False
        else:  # a descriptor open the wrong way is as good as closed (a shell wrapper's script left on fd 2)
            usable = mode != (os.O_WRONLY if fd == 0 else os.O_RDONLY)
        if usable:
            continue
        _CLOSED_STD.add(fd)
        new = os.open(os.devnull, os.O_RDWR)
        if new != fd:
            os.dup2(new, fd)
            os.close(new)
    return set(_CLOSED_STD)


def std_fd_closed(fd: int) -> bool:
    """True when standard descriptor ``fd`` was closed when the program started."""
    stream = {0: sys.stdin, 1: sys.stdout, 2: sys.stderr}[fd]
    return fd in _CLOSED_STD or stream is None


def _std_fd(path: str) -> int | None:
    """The descriptor a ``/dev/std*``, ``/dev/fd/N`` or ``/proc/self/fd/N`` path (or a symlink chain to one) names."""
    p = os.path.abspath(path)
    for _ in range(40):
        m = _FD_PATH.match(p)
        if m:
            return int(m.group(1))
        if p.startswith("/dev/") and p[5:] in _STD_NAMES:
            return _STD_NAMES[p[5:]]
        try:
            link = os.readlink(p)
        except OSError:
            return None
        p = os.path.normpath(os.path.join(os.path.dirname(p), link))
    return None


def carries_stdout(*paths: str | None) -> bool:
    """Whether an output path of the command line is stdout: ``-``, ``/dev/stdout``, ``/dev/fd/1`` (or a link to one)."""
    return any(p is not None and (os.fspath(p) == STDIO or _std_fd(os.fspath(p)) == 1) for p in paths)
