"""Exit codes and the one place that turns an exception into one stderr line and a code.

Exit codes: 0 success, 1 a quality gate failed, 2 usage error, 3 unreadable /
unsupported / invalid input or unwritable output, 4 internal error (a bug),
130 interrupted (SIGINT), 141 broken pipe, 143 terminated (SIGTERM).
"""

from __future__ import annotations

import contextlib
import errno
import functools
import os
import signal
import sys
import traceback
from collections.abc import Callable

import click

from .._signals import Deferred
from ..errors import AngleSmoothError

EXIT_OK, EXIT_GATE, EXIT_USAGE, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3, 4
EXIT_SIGINT, EXIT_SIGTERM = 130, 143
EXIT_PIPE = 141


class Usage(Exception):
    """A usage problem found after parsing (exit 2, one line)."""


class Terminated(KeyboardInterrupt):
    """Raised by the SIGTERM handler so that cleanup (atomic writes) runs as for Ctrl-C."""


def _raise_for(signum: int) -> None:
    if signum == signal.SIGTERM:
        raise Terminated()
    raise KeyboardInterrupt()


#: SIGTERM / SIGINT: raise :class:`Terminated` / KeyboardInterrupt, at once, or when numba has finished compiling
#: (checked every 50 ms with SIGALRM; see :mod:`anglesmooth._signals`), so that the run stops and cleans up.
on_signal = Deferred(_raise_for)
on_sigterm = on_signal  # the name main installs


def error(message: str) -> None:
    """The one line every error gets on stderr."""
    click.echo(f"anglesmooth: error: {' '.join(str(message).split())}", err=True)


def handle_errors(fn: Callable) -> Callable:
    """Turn every exception of a command into one stderr line and an exit code (traceback with --debug)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        debug = kwargs.get("debug", False)
        try:
            check_environment()
            return fn(*args, **kwargs)
        except (click.exceptions.ClickException, click.exceptions.Exit, click.exceptions.Abort):
            raise
        except BaseException as exc:
            if isinstance(exc, SystemExit):
                raise
            if debug:
                traceback.print_exc(file=sys.stderr)
            code, message = classify(exc)
            if message:
                error(message)
            raise click.exceptions.Exit(code) from None

    return wrapper


def classify(exc: BaseException) -> tuple[int, str]:
    """The exit code and the message of an exception."""
    if isinstance(exc, Terminated):
        return EXIT_SIGTERM, "terminated"
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_SIGINT, "interrupted"
    if isinstance(exc, Usage):
        return EXIT_USAGE, str(exc)
    if isinstance(exc, AngleSmoothError):
        return int(getattr(exc, "exit_code", EXIT_INPUT)), str(exc)
    if isinstance(exc, MemoryError):
        return EXIT_INPUT, "out of memory (the mesh is too large for this machine)"
    if isinstance(exc, BrokenPipeError):
        with contextlib.suppress(OSError, AttributeError, ValueError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_PIPE, ""
    if isinstance(exc, OSError):  # the environment, not a bug: a full disk, a closed or failing stream
        where = f" '{exc.filename}'" if exc.filename else ""
        reason = "no space left on device" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        return EXIT_INPUT, f"input/output error{where}: {reason}"
    return EXIT_INTERNAL, f"internal error: {type(exc).__name__}: {exc} (please report it; --debug shows the traceback)"


def check_environment() -> None:
    """Settings from the environment that would fail deep inside a library are usage errors up front."""
    threads = os.environ.get("NUMBA_NUM_THREADS")
    if threads is not None and threads.strip():
        try:
            ok = int(threads) > 0
        except ValueError:
            ok = False
        if not ok:
            raise Usage(f"NUMBA_NUM_THREADS={threads!r} must be a positive integer (the threads numba may use)")


def prepare_std_streams() -> None:
    """Closed stdin / stdout / stderr (``<&-``, ``>&-``): park /dev/null on the descriptor.

    No file the command opens can then take descriptor 0, 1 or 2; writing the mesh or the JSON to
    a closed stdout is refused (exit 3), and messages to a closed stderr are dropped.
    """
    from .. import _paths

    closed = _paths.mark_closed_std_fds()
    if 2 in closed or sys.stderr is None:
        sys.stderr = open(os.devnull, "w")  # noqa: SIM115 - lives as long as the process
    if 1 in closed or sys.stdout is None:
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115
