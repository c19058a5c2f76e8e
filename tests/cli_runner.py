"""Helpers of the CLI tests: click's CliRunner with stderr kept apart (``from cli_runner import cli_runner``),
and what a run left behind (``snapshot``, ``digest``, ``error_line``)."""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

from click.testing import CliRunner


def cli_runner() -> CliRunner:
    try:  # click < 8.2 mixes stderr into stdout unless told not to
        return CliRunner(mix_stderr=False)
    except TypeError:  # click >= 8.2 always keeps it apart
        return CliRunner()


# --------------------------------------------------------------------------- what a run left behind

#: The start of the one line a bad input gives on stderr.
PREFIX = "anglesmooth: error: "


def digest(path) -> str:
    """sha256 of a file's content."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def snapshot(d: Path) -> dict:
    """Every path under ``d``: a file's sha256, a link's ``->target``, the file type of anything else
    (directory, device, fifo, socket), to compare before and after a run."""
    out = {}
    for p in sorted(Path(d).rglob("*")):
        if p.is_symlink():
            out[str(p.relative_to(d))] = "->" + os.readlink(p)
        elif p.is_file():
            out[str(p.relative_to(d))] = digest(p)
        else:
            out[str(p.relative_to(d))] = stat.S_IFMT(p.lstat().st_mode)
    return out


def error_line(stderr: str) -> str:
    """The one non-blank line of ``stderr``: an ``anglesmooth: error:`` line, no traceback."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    assert lines[0].startswith(PREFIX), stderr
    assert "Traceback" not in stderr
    return lines[0]
