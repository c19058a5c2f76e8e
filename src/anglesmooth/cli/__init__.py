"""The command line: ``anglesmooth INPUT OUTPUT``, ``anglesmooth check`` and ``anglesmooth compare``.

This package is the only place with a console, progress bars and exit codes.
Tables, warnings and progress go to stderr; stdout carries only data (the mesh
when OUTPUT is ``-``, the JSON report with ``--json -``).

Modules: ``main`` (the group, the default command, the entry point), one module
per command (``smooth``, ``check``, ``compare``), ``options`` (shared click
options), ``outputs`` (console, gate lines, progress, the JSON file),
``meshfiles`` (stdin/stdout, path checks), ``formats`` (how gate results are
reported: ``--format table|github``, ``--junit-xml``), ``schema`` (the ``schema``
command) and ``errors`` (exit codes, the one error line).  ``main`` also merges
the configuration file (:mod:`anglesmooth.config`) under the options.  Imports run one way: commands -> options/outputs/meshfiles -> errors.

Exit codes: 0 success, 1 a quality gate failed, 2 usage error, 3 unreadable /
unsupported / invalid input or unwritable output, 4 internal error (a bug),
130 interrupted (SIGINT), 141 broken pipe, 143 terminated (SIGTERM).
"""

import sys

__all__ = ["cli", "main"]


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point; a Ctrl-C while the modules load exits 130 with one line."""
    try:
        from .main import main as run
    except KeyboardInterrupt:
        if sys.stderr is not None:
            sys.stderr.write("anglesmooth: error: interrupted\n")
        raise SystemExit(130) from None
    run(argv)


def __getattr__(name: str):
    if name == "cli":  # the click group, loaded on first use
        from .main import cli

        return cli
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
