"""Where outputs go and how they get there: one place that resolves, checks and commits every output.

The contract (README "Rules"):

* Every path a command writes must differ from every path it reads and from
  every other output.  Paths are compared after resolving them and by inode, so
  a symlink or a hard link to an input *is* that input.  Character devices and
  sockets (``/dev/null``, a terminal) are exempt: reading and writing them does
  not destroy anything.
* A regular file (or a new name) is written atomically: a temporary file
  ``.NAME.anglesmooth-XXXXXXXX<suffix>`` in the directory of the file it
  replaces, fsynced, given the mode (minus set-uid / set-gid) and, when
  permitted, the owner and group of the file it replaces (a new file: 0666
  minus the umask), then renamed over it.  A symlink is followed: its target
  is replaced and the link stays.  Other hard links of a replaced file keep
  the old content (the rename gives the name a new inode).
* Anything that is not a regular file (character or block device, FIFO,
  socket, ``/dev/stdout``, ``/dev/fd/N``) is written *into*, as a stream, and
  never replaced or removed.
* Inside :class:`Outputs` (the command line uses one per command), writes are
  staged and committed together by :meth:`Outputs.commit`: streams first, then
  the renames (a SIGINT / SIGTERM arriving during the renames is acted on
  after them).  An error or signal before the commit leaves no output and no
  temporary file.
* Temporary files left by a killed process (SIGKILL) are found by
  :func:`stale_temporaries` (the command line mentions them, it does not
  delete them: another run may still own them).

Writes to a stream loop until every byte is written (a non-blocking stream is
waited for with ``select``); a closed reader raises ``BrokenPipeError``.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import re
import select
import shutil
import signal
import stat
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from .errors import AngleSmoothError, MeshWriteError

__all__ = ["OutputConflictError", "Outputs", "Target", "active", "atomic_write", "carries_stdout", "check_outputs",
           "mark_closed_std_fds", "resolve_output", "stale_temporaries", "std_fd_closed", "write_all"]

STDIO = "-"
TAG = ".anglesmooth-"
_STARTED = time.time()
_CHUNK = 1 << 20
_CLOSED_STD: set[int] = set()
_STD_NAMES = {"stdin": 0, "stdout": 1, "stderr": 2}
_FD_PATH = re.compile(r"^/(?:dev/fd|proc/self/fd|proc/%d/fd)/(\d+)$" % os.getpid())
_ACTIVE: contextvars.ContextVar[Outputs | None] = contextvars.ContextVar("anglesmooth_outputs", default=None)


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


def active() -> Outputs | None:
    """The :class:`Outputs` whose ``with`` block is running, if any."""
    return _ACTIVE.get()


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


def _ident(st: os.stat_result) -> tuple[int, int]:
    return (st.st_dev, st.st_ino)


def resolve_output(path: str | os.PathLike, what: str = "cannot write", *, stdio: bool = False) -> Target:
    """Resolve an output path and check that it can be written (raises :class:`MeshWriteError`).

    With ``stdio`` (the command line), ``-`` is stdout; otherwise it is a file named ``-``.
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
    if not parent.exists():
        shown = parent if os.path.islink(given) else Path(given).parent  # a dangling link: where it points
        raise target.error(f"directory '{shown}' does not exist")
    if not parent.is_dir():
        raise target.error(f"'{parent}' is not a directory")
    target.path = real
    if st is not None:
        target.ident, target.st_mode = _ident(st), st.st_mode
    try:  # root passes os.access on read-only file systems (and /sys, /proc): creating a file tells
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".anglesmooth-probe-"):
            pass
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
                  may_replace_input: Iterable[str] = (), what: Mapping[str, str] | None = None) -> dict[str, Target]:
    """Resolve every output (``label -> path``), check each can be written and that none is an input or another output.

    ``inputs`` are ``(label, path)`` pairs (``"-"`` is stdin).  Outputs whose label is in
    ``may_replace_input`` may be an input (``--force`` / ``--in-place``).  Raises
    :class:`MeshWriteError` (exit 3) for an unwritable output and :class:`OutputConflictError`
    (exit 2) for a collision.
    """
    what = dict(what or {})
    allowed = set(may_replace_input)
    targets = {label: resolve_output(path, what.get(label, "cannot write"), stdio=True)
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


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------


def write_all(fd: int, data: bytes | memoryview) -> None:
    """Write every byte of ``data`` to ``fd``: loop over short writes, wait on a non-blocking one."""
    view = memoryview(data).cast("B")
    while view:
        try:
            n = os.write(fd, view)
        except BlockingIOError:
            select.select([], [fd], [])
            continue
        view = view[n:]


def _umask_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@dataclass
class _Staged:
    target: Target
    tmp: Path
    private_dir: Path | None = None

    def discard(self) -> None:
        with contextlib.suppress(OSError):
            self.tmp.unlink()
        if self.private_dir is not None:
            shutil.rmtree(self.private_dir, ignore_errors=True)

    def stream(self) -> None:
        """Copy the staged bytes into the stream the target names."""
        t = self.target
        opened = None
        try:
            if t.kind == "stdout":
                stream = sys.stdout
                try:
                    fd = stream.fileno()
                except (AttributeError, OSError, ValueError):  # click's CliRunner: an in-memory stream
                    fd = None
                if fd is None:
                    buf = getattr(stream, "buffer", stream)
                    with open(self.tmp, "rb") as fh:
                        shutil.copyfileobj(fh, buf, _CHUNK)
                    buf.flush()
                    return
                stream.flush()
            elif t.kind == "fd":
                fd = t.fd
            else:
                fd = opened = os.open(t.path, os.O_WRONLY | os.O_NOCTTY)
            with open(self.tmp, "rb") as fh:
                while chunk := fh.read(_CHUNK):
                    write_all(fd, chunk)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise t.error(exc.strerror or str(exc)) from None
        finally:
            if opened is not None:
                with contextlib.suppress(OSError):
                    os.close(opened)

    def rename(self) -> None:
        """Give the staged file the metadata of the file it replaces and rename it over that file."""
        t = self.target
        real = t.path
        try:
            try:
                old = os.stat(real)
            except FileNotFoundError:
                old = None
            if old is not None:
                with contextlib.suppress(OSError):
                    try:
                        os.chown(self.tmp, old.st_uid, old.st_gid)
                    except PermissionError:
                        os.chown(self.tmp, -1, old.st_gid)
                mode = stat.S_IMODE(old.st_mode) & ~(stat.S_ISUID | stat.S_ISGID)
            else:
                mode = _umask_mode()
            os.chmod(self.tmp, mode)
            os.replace(self.tmp, real)
        except OSError as exc:
            raise t.error(exc.strerror or str(exc)) from None
        with contextlib.suppress(OSError):  # make the rename itself durable
            dfd = os.open(real.parent, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)


def _stage(target: Target, suffix: str) -> _Staged:
    if target.kind == "regular":
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{target.path.name}{TAG}", suffix=suffix, dir=target.path.parent)
        except OSError as exc:
            raise target.error(f"cannot create a file in '{target.path.parent}': {exc.strerror or exc}") from None
        os.close(fd)
        return _Staged(target, Path(tmp))
    private = Path(tempfile.mkdtemp(prefix="anglesmooth-"))
    return _Staged(target, private / ("stream" + suffix), private)


def _fsync(path: Path) -> None:
    with open(path, "rb+") as fh:
        os.fsync(fh.fileno())


def atomic_write(path: str | os.PathLike, write: Callable[[str], None], *, suffix: str = ".tmp",
                 what: str = "cannot write") -> None:
    """Write an output through ``write(tmp_path)``: atomically for a regular file, streamed otherwise.

    Inside an active :class:`Outputs` whose outputs include ``path``, the write is staged and
    committed with the others by :meth:`Outputs.commit`.  Errors of ``write`` propagate as they
    are (the staged file is removed); errors of the commit raise :class:`MeshWriteError`.
    """
    tx = _ACTIVE.get()
    target = tx.lookup(path) if tx is not None else None
    deferred = target is not None
    if target is None:
        target = resolve_output(path, what)
    staged = _stage(target, suffix)
    try:
        write(str(staged.tmp))
        if target.kind == "regular":
            _fsync(staged.tmp)
    except BaseException:
        staged.discard()
        raise
    if deferred:
        tx._staged.append(staged)
        return
    try:
        staged.stream() if target.kind != "regular" else staged.rename()
    finally:
        staged.discard()


@contextlib.contextmanager
def _signals_deferred():
    """Hold SIGINT / SIGTERM (Python handlers) until the block is done, then act on them."""
    caught: list[tuple[int, object]] = []
    saved = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            saved[sig] = signal.getsignal(sig)
            signal.signal(sig, lambda s, f: caught.append((s, f)))
    except ValueError:  # not the main thread: signals are not ours to handle
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        saved = {}
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
        for sig, frame in caught[:1]:
            handler = saved.get(sig)
            if callable(handler):
                handler(sig, frame)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), sig)


@dataclass
class Outputs:
    """Every output of one command: checked up front, written staged, committed together.

    >>> import os, tempfile
    >>> d = tempfile.mkdtemp(); out = os.path.join(d, "r.txt")
    >>> outs = Outputs.check({"--json": out}, [])
    >>> with outs:
    ...     atomic_write(out, lambda tmp: open(tmp, "w").write("hi"))
    ...     os.path.exists(out)
    ...     outs.commit()
    False
    >>> open(out).read(), sorted(os.listdir(d))
    ('hi', ['r.txt'])
    >>> os.remove(out); os.rmdir(d)
    """

    targets: dict[str, Target] = field(default_factory=dict)
    _staged: list[_Staged] = field(default_factory=list)
    _token: object = None

    @classmethod
    def check(cls, outputs: Mapping[str, str | None], inputs: Iterable[tuple[str, str | None]], **kwargs) -> Outputs:
        return cls(check_outputs(outputs, inputs, **kwargs))

    def lookup(self, path) -> Target | None:
        given = os.fspath(path)
        for t in self.targets.values():
            if t.kind == "stdout":
                continue
            if t.given == given or os.path.abspath(t.given) == os.path.abspath(given):
                return t
        return None

    def stage_stdout(self, label: str, write: Callable[[str], None], suffix: str = ".tmp") -> None:
        """Stage the bytes for output ``label`` when it is stdout (``-``): ``write(tmp_path)`` makes them."""
        staged = _stage(self.targets[label], suffix)
        try:
            write(str(staged.tmp))
        except BaseException:
            staged.discard()
            raise
        self._staged.append(staged)

    def __enter__(self) -> Outputs:
        self._token = _ACTIVE.set(self)
        return self

    def __exit__(self, *exc) -> None:
        _ACTIVE.reset(self._token)
        self.discard()

    def discard(self) -> None:
        """Remove every staged file (nothing of them was committed)."""
        while self._staged:
            self._staged.pop().discard()

    def commit(self) -> None:
        """Stream the outputs that are streams, then rename the regular ones into place."""
        try:
            for s in self._staged:
                if s.target.kind != "regular":
                    s.stream()
            with _signals_deferred():
                for s in self._staged:
                    if s.target.kind == "regular":
                        s.rename()
        finally:
            self.discard()
