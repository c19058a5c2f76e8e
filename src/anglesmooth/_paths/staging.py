"""Writing: every byte to a stream, atomic replacement of a regular file, and :class:`Outputs`, which stages the
writes of one command and commits them together."""

from __future__ import annotations

import contextlib
import contextvars
import os
import select
import shutil
import signal
import stat
import sys
import tempfile
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from . import temps
from .targets import TAG, Target, check_outputs, resolve_output

__all__ = ["Outputs", "active", "atomic_write", "write_all"]

_CHUNK = 1 << 20
_ACTIVE: contextvars.ContextVar[Outputs | None] = contextvars.ContextVar("anglesmooth_outputs", default=None)


def active() -> Outputs | None:
    """The :class:`Outputs` whose ``with`` block is running, if any."""
    return _ACTIVE.get()


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
        temps.remove(self.tmp)
        if self.private_dir is not None:
            temps.remove(self.private_dir)

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
            temps.forget(self.tmp)
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
            tmp = temps.make_temp(target.path.parent, f".{target.path.name}{TAG}", suffix)
        except OSError as exc:
            raise target.error(f"cannot create a file in '{target.path.parent}': {exc.strerror or exc}") from None
        return _Staged(target, tmp)
    private = temps.make_temp(tempfile.gettempdir(), "anglesmooth-", is_dir=True)
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
