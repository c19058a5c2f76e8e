"""The ``anglesmooth`` group: ``smooth`` as the default command, ``check``, ``compare``; the entry point."""

from __future__ import annotations

import contextlib
import signal

import click

from ..__about__ import __version__
from .check import check_cmd
from .compare import compare_cmd
from .errors import classify, error, on_sigterm, prepare_std_streams
from .smooth import smooth_cmd


class DefaultGroup(click.Group):
    """A group that runs ``smooth`` when the first argument is not a command name."""

    default_command = "smooth"

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in [*ctx.help_option_names, "--version"]:
            args = [self.default_command, *args]
        return super().parse_args(ctx, args)

    def format_usage(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        formatter.write_usage(ctx.command_path, "INPUT [OUTPUT] [SMOOTH OPTIONS]")
        formatter.write_usage(ctx.command_path, "COMMAND [ARGS]...", prefix="   or: ")


@click.group(cls=DefaultGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="anglesmooth")
def cli() -> None:
    """Smooth 2D triangle/quad meshes with the angle-based method of Zhou & Shimada (2000).

    \b
    anglesmooth INPUT OUTPUT [OPTIONS]     smooth a mesh (same as 'anglesmooth smooth ...')
    anglesmooth check INPUT... [GATES]     report quality, gate CI on it
    anglesmooth compare INPUT              run every method, paper-style table

    Exit codes: 0 ok, 1 a quality gate failed, 2 usage error, 3 bad input or
    unwritable output, 4 internal error, 130 interrupted, 143 terminated.
    See 'anglesmooth smooth --help' for the smoothing options.
    """


for _command in (smooth_cmd, check_cmd, compare_cmd):
    cli.add_command(_command)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: install the SIGTERM handler, guard closed std streams, run the group.

    A Ctrl-C or SIGTERM that arrives outside a command (while click parses the arguments) exits
    130 / 143 with one line, like one inside a command.
    """
    with contextlib.suppress(ValueError):  # not in the main thread
        signal.signal(signal.SIGTERM, on_sigterm)
    prepare_std_streams()
    try:
        code = cli.main(args=argv, prog_name="anglesmooth", standalone_mode=False)
    except (click.exceptions.Abort, KeyboardInterrupt) as exc:
        code, message = classify(exc if isinstance(exc, KeyboardInterrupt) else exc.__context__ or KeyboardInterrupt())
        error(message)
    except click.exceptions.ClickException as exc:
        exc.show()
        code = exc.exit_code
    raise SystemExit(code if isinstance(code, int) else 0)
