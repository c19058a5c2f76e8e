"""The ``anglesmooth`` group: ``smooth`` as the default command, ``check``, ``compare``; the entry point."""

from __future__ import annotations

import contextlib
import signal

import click

from ..__about__ import __version__
from ..config import ConfigFileError, discover, load_config
from ..smoothers._leanload import lean_load
from .check import check_cmd
from .compare import compare_cmd
from .errors import EXIT_USAGE, classify, error, on_sigterm, prepare_std_streams
from .meshfiles import CONFIG_PATH
from .outputs import CONFIG_GATES
from .schema import schema_cmd
from .smooth import smooth_cmd


class DefaultGroup(click.Group):
    """A group that runs ``smooth`` when the first argument is not a command name."""

    default_command = "smooth"

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and args[0] not in self.commands and args[0] not in [*ctx.help_option_names, "--version"]:
            args = [self.default_command, *args]
        if args and args[0] in CONFIGURABLE:
            configure(ctx, args[0], args[1:])
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
    anglesmooth schema DOCUMENT            JSON Schema of a --json report

    Exit codes: 0 ok, 1 a quality gate failed, 2 usage error, 3 bad input or
    unwritable output, 4 internal error, 130 interrupted, 143 terminated.
    See 'anglesmooth smooth --help' for the smoothing options.
    """


for _command in (smooth_cmd, check_cmd, compare_cmd, schema_cmd):
    cli.add_command(_command)

# ------------------------------------------------------------------ configuration files

#: Commands that read ``[tool.anglesmooth]`` / ``anglesmooth.toml`` (see anglesmooth.config).
CONFIGURABLE = {"smooth": smooth_cmd, "check": check_cmd, "compare": compare_cmd}

for _command in CONFIGURABLE.values():
    _command.params += [
        click.Option(["--config", "config_file"], metavar="FILE", expose_value=False,
                     help="Settings from FILE (anglesmooth.toml, or a pyproject.toml's [tool.anglesmooth]) instead "
                          "of the one found from the working directory up; options override them."),
        click.Option(["--no-config"], is_flag=True, expose_value=False,
                     help="Ignore anglesmooth.toml and [tool.anglesmooth] in pyproject.toml."),
    ]


def _config_args(args: list[str]) -> tuple[bool, str | None, bool]:
    """``--no-config``, ``--config FILE`` and whether help is asked for, from a command's arguments."""
    no_config, path, wants_help = False, None, False
    for i, arg in enumerate(args):
        if arg == "--":
            break
        if arg == "--no-config":
            no_config = True
        elif arg == "--config" and i + 1 < len(args):
            path = args[i + 1]
        elif arg.startswith("--config="):
            path = arg.split("=", 1)[1]
        elif arg in ("--help", "-h"):
            wants_help = True
    return no_config, path, wants_help


def configure(ctx: click.Context, name: str, args: list[str]) -> None:
    """Make the configuration file the defaults of command ``name`` (click's ``default_map``), before it parses.

    The settings the command has an option for become its defaults (the command
    line overrides them); the gate thresholds go to ``ctx.meta`` for
    ``outputs.gate_thresholds`` (below a ``--gate-file`` and the options).  A bad
    file is a usage error (exit 2) naming the key and the file.
    """
    no_config, path, wants_help = _config_args(args)
    if no_config or wants_help:
        return
    try:
        config = load_config(path) if path is not None else discover()
    except ConfigFileError as exc:
        error(str(exc))
        raise click.exceptions.Exit(EXIT_USAGE) from None
    if config is None:
        return
    defaults = {}
    for cmd_name, command in CONFIGURABLE.items():  # every setting is checked, whichever command runs
        by_option = {opt[2:]: p for p in command.params for opt in p.opts if opt.startswith("--")}
        for key, value in config.settings.items():
            param = by_option.get(key)
            if param is None:
                continue  # a setting of another command
            try:
                param.type_cast_value(ctx, value)
            except click.BadParameter as exc:
                error(f"configuration '{config.path}': {key}: {exc.message}")
                raise click.exceptions.Exit(EXIT_USAGE) from None
            if cmd_name == name:
                defaults[param.name] = value
    ctx.default_map = {name: defaults}
    ctx.meta[CONFIG_GATES] = config.gates
    ctx.meta[CONFIG_PATH] = config.path  # an input: no output may name it


#: click >= 8.2 raises this usage error, holding the whole help text, for a group called without arguments.
_NO_ARGS = getattr(click.exceptions, "NoArgsIsHelpError", ())


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: install the SIGTERM handler, guard closed std streams, run the group.

    A Ctrl-C or SIGTERM that arrives outside a command (while click parses the arguments) exits
    130 / 143 with one line, like one inside a command.
    """
    with contextlib.suppress(ValueError):  # not in the main thread
        signal.signal(signal.SIGTERM, on_sigterm)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:  # not when SIGINT is ignored
            signal.signal(signal.SIGINT, on_sigterm)
    prepare_std_streams()
    if argv is None:  # the process's own command line: it runs no other compiled code (0.2 s a run)
        lean_load()
    try:
        code = cli.main(args=argv, prog_name="anglesmooth", standalone_mode=False)
    except (click.exceptions.Abort, KeyboardInterrupt) as exc:
        code, message = classify(exc if isinstance(exc, KeyboardInterrupt) else exc.__context__ or KeyboardInterrupt())
        error(message)
    except _NO_ARGS as exc:  # no arguments at all: the help text (exit 2)
        exc.show()
        code = exc.exit_code
    except click.exceptions.UsageError as exc:  # one line, as every other error (click prints three)
        where = exc.ctx.command_path if exc.ctx is not None else "anglesmooth"
        error(f"{exc.format_message()} (see '{where} --help')")
        code = exc.exit_code
    except click.exceptions.ClickException as exc:
        exc.show()
        code = exc.exit_code
    raise SystemExit(code if isinstance(code, int) else 0)
