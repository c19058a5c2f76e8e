"""click's CliRunner with stderr kept apart (import with ``from cli_runner import cli_runner``)."""

from __future__ import annotations

from click.testing import CliRunner


def cli_runner() -> CliRunner:
    try:  # click < 8.2 mixes stderr into stdout unless told not to
        return CliRunner(mix_stderr=False)
    except TypeError:  # click >= 8.2 always keeps it apart
        return CliRunner()
