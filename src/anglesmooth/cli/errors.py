"""Exit codes and the one place that turns an exception into one stderr line and a code.

Exit codes: 0 success, 1 a quality gate failed, 2 usage error, 3 unreadable /
unsupported / invalid input or unwritable output, 4 internal error (a bug),
130 interrupted (SIGINT), 141 broken pipe, 143 terminated (SIGTERM).
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import traceback
from collections.abc import Callable

import click

from ..errors import AngleSmoothError

EXIT_OK, EXIT_GATE, EXIT_USAGE, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3, 4
EXIT_SIGINT, EXIT_SIGTERM = 130, 143
EXIT_PIPE = 141


class Usage(Exception):
    """A usage problem found after parsing (exit 2, one line)."""


class Terminated(KeyboardInterrupt):
    """Raised by the SIGTERM handler so that cleanup (atomic writes) runs as for Ctrl-C."""


def on_sigterm(signum, frame):  # pragma: no cover - exercised in a subprocess
    raise Terminated()


def error(message: str) -> None:
    """The one line every error gets on stderr."""
    click.echo(f"anglesmooth: error: {' '.join(str(message).split())}", err=True)


def handle_errors(fn: Callable) -> Callable:
    """Turn every exception of a command into one stderr line and an exit code (traceback with --debug)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        debug = kwargs.get("debug", False)
        try:
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
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_PIPE, ""
    return EXIT_INTERNAL, f"internal error: {type(exc).__name__}: {exc} (please report it; --debug shows the traceback)"
