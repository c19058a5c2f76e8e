"""Resolving outputs and checking them before any work: writable, not an input, not another output; the
temporary files a killed run left."""

from __future__ import annotations

import contextlib
import errno
import os
import re
import stat
import sys
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from ..errors import AngleSmoothError, MeshWriteError
from . import temps
from .stdio import STDIO, _std_fd, std_fd_closed

__all__ = ["OutputConflictError", "Target", "check_outputs", "resolve_output", "stale_temporaries"]

TAG = ".anglesmooth-"
_STARTED = time.time()


class OutputConflictError(AngleSmoothError):
    """An output path that names an input or another output (a usage error, exit 2)."""

    exit_code = 2


@dataclass
class Target:
    """One resolved output.

    ``kind`` is ``"regular"`` (replaced atomically: ``path`` is the real file, symlinks followed),
    ``"special"`` (a device, FIFO or socket written into: ``path``), ``"fd"`` (``/dev/stdout``,
    ``/dev/fd/N``: file descriptor ``fd``) or ``"stdout"`` (``-``: ``sys.stdout``).
    """

    given: str
    kind: str
    path: Path | None = None
    fd: int | None = None
    ident: tuple[int, int] | None = None
    st_mode: int = 0
    what: str = "cannot write"

    @property
    def exempt(self) -> bool:
        """Character devices and sockets may be shared (a terminal, ``/dev/null``)."""
        return stat.S_ISCHR(self.st_mode) or stat.S_ISSOCK(self.st_mode)

    def error(self, reason: str) -> MeshWriteError:
        return MeshWriteError(f"{self.what} '{self.given}': {reason}")


def _ident(st: os.stat_result) -> tuple[int, int]:
    return (st.st_dev, st.st_ino)


def resolve_output(path: str | os.PathLike, what: str = "cannot write", *, stdio: bool = False,
                   created: Iterable[str] = ()) -> Target:
    """Resolve an output path and check that it can be written (raises :class:`MeshWriteError`).

    With ``stdio`` (the command line), ``-`` is stdout; otherwise it is a file named ``-``.  ``created``:
    directories the command creates (with their parents) before it writes (``--output-dir``); an output in
    one of them may have a missing directory, checked at its nearest existing ancestor instead.
    """
    given = os.fspath(path)
    if given == STDIO and stdio:
        target = Target(given="<stdout>", kind="stdout", fd=1, what=what)
        if std_fd_closed(1):
            raise target.error("stdout is closed")
        with contextlib.suppress(OSError, AttributeError, ValueError):
            st = os.fstat(sys.stdout.fileno())
            target.ident, target.st_mode = _ident(st), st.st_mode
        return target
    fd = _std_fd(given)
    if fd is not None:
        target = Target(given=given, kind="fd", fd=fd, what=what)
        if fd in (0, 1, 2) and std_fd_closed(fd):
            raise target.error(f"standard {'input' if fd == 0 else 'output' if fd == 1 else 'error'} is closed")
        try:
            st = os.fstat(fd)
        except OSError as exc:
            raise target.error(exc.strerror or str(exc)) from None
        target.ident, target.st_mode = _ident(st), st.st_mode
        return target
    target = Target(given=given, kind="regular", what=what)
    try:
        st = os.stat(given)  # follows symlinks
    except FileNotFoundError:
        st = None
    except OSError as exc:
        if exc.errno == errno.ENOTDIR:
            raise target.error(f"'{Path(given).parent}' is not a directory") from None
        raise target.error(exc.strerror or str(exc)) from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise target.error("it is a directory")
    if st is not None and not stat.S_ISREG(st.st_mode):
        target.kind, target.path = "special", Path(given)
        target.ident, target.st_mode = _ident(st), st.st_mode
        if not os.access(given, os.W_OK):
            raise target.error("permission denied")
        return target
    real = Path(os.path.realpath(given))  # a symlink (even a dangling one) is followed to its target
    if given.endswith("/"):
        raise target.error("it is a directory")
    parent = real.parent
    if not parent.exists() and parent in {d for c in created for d in (Path(os.path.realpath(c)),
                                                                      *Path(os.path.realpath(c)).parents)}:
        while not parent.exists():  # made before the write: check where it will be made
            parent = parent.parent
    if not parent.exists():
        shown = parent if os.path.islink(given) else Path(given).parent  # a dangling link: where it points
        raise target.error(f"directory '{shown}' does not exist")
    if not parent.is_dir():
        raise target.error(f"'{parent}' is not a directory")
    target.path = real
    if st is not None:
        target.ident, target.st_mode = _ident(st), st.st_mode
    try:  # root passes os.access on read-only file systems (and /sys, /proc): creating a file tells
        temps.remove(temps.make_temp(parent, ".anglesmooth-probe-"))
    except OSError as exc:
        raise target.error(f"cannot create a file in '{parent}': {exc.strerror or exc}") from None
    return target


def _input_ident(path: str) -> tuple[tuple[int, int] | None, int, str | None]:
    """(inode, mode, real path) of an input, or (None, 0, None) when it does not exist (its read fails later)."""
    if path == STDIO:
        if std_fd_closed(0):
            return None, 0, None
        try:
            st = os.fstat(sys.stdin.fileno())
        except (OSError, AttributeError, ValueError):
            return None, 0, None
        return _ident(st), st.st_mode, None
    try:
        st = os.stat(path)
    except OSError:
        return None, 0, None
    return _ident(st), st.st_mode, os.path.realpath(path)


def _same(t: Target, ident, mode: int, real: str | None) -> bool:
    if t.exempt or stat.S_ISCHR(mode) or stat.S_ISSOCK(mode):
        return False
    if t.ident is not None and ident is not None and t.ident == ident:
        return True
    return t.kind == "regular" and real is not None and t.path is not None and str(t.path) == real


def check_outputs(outputs: Mapping[str, str | None], inputs: Iterable[tuple[str, str | None]], *,
                  may_replace_input: Iterable[str] = (), what: Mapping[str, str] | None = None,
                  created: Iterable[str] = ()) -> dict[str, Target]:
    """Resolve every output (``label -> path``), check each can be written and that none is an input or another output.

    ``inputs`` are ``(label, path)`` pairs (``"-"`` is stdin).  Outputs whose label is in
    ``may_replace_input`` may be an input (``--force`` / ``--in-place``).  Raises
    :class:`MeshWriteError` (exit 3) for an unwritable output and :class:`OutputConflictError`
    (exit 2) for a collision.  ``created``: directories the command makes before writing (see
    :func:`resolve_output`).
    """
    what = dict(what or {})
    allowed = set(may_replace_input)
    created = tuple(created)
    targets = {label: resolve_output(path, what.get(label, "cannot write"), stdio=True, created=created)
               for label, path in outputs.items() if path is not None}
    ins = [(label, path, *_input_ident(path)) for label, path in inputs if path is not None]
    for label, t in targets.items():
        for in_label, in_path, ident, mode, real in ins:
            if label not in allowed and _same(t, ident, mode, real):
                shown = "<stdin>" if in_path == STDIO else in_path
                if label == "OUTPUT" and in_label == "INPUT":
                    raise OutputConflictError(f"OUTPUT '{t.given}' is the input file; "
                                              "pass --force or --in-place to overwrite it")
                raise OutputConflictError(f"{label} '{t.given}' is the same file as {in_label} '{shown}'; "
                                          f"writing it would destroy an input")
    labels = list(targets)
    for i, a in enumerate(labels):
        for b in labels[i + 1:]:
            ta, tb = targets[a], targets[b]
            real_b = str(tb.path) if tb.kind == "regular" and tb.path is not None else None
            if _same(ta, tb.ident, tb.st_mode, real_b) or (ta.kind == tb.kind == "stdout"):
                raise OutputConflictError(f"{a} '{ta.given}' and {b} '{tb.given}' are the same file; "
                                          "every output needs its own path")
    return targets


def stale_temporaries(targets: Iterable[Target]) -> list[Path]:
    """Temporary files of earlier runs (killed before they could clean up) for these outputs."""
    out = []
    for t in targets:
        if t.kind != "regular" or t.path is None:
            continue
        with contextlib.suppress(OSError):
            for p in t.path.parent.glob(f".{glob_escape(t.path.name)}{TAG}*"):
                with contextlib.suppress(OSError):
                    if p.is_file() and p.stat().st_mtime < _STARTED:
                        out.append(p)
    return sorted(out)


def glob_escape(name: str) -> str:
    return re.sub(r"([*?\[])", r"[\1]", name)
