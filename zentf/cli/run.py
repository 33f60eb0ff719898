"""`zentf run NAME [ARGS]`: start one of zentf's programs, like `ros2 run` (`--list` names them)."""
from __future__ import annotations

import importlib

import click

from ..tools.programs import PROGRAMS, module_of
from .common import CliError, outer_argv

__all__ = ["run"]

_USAGE = """Usage: zentf run NAME [ARGS]...
       zentf run --list

  Start one of zentf's programs (like `ros2 run`); ARGS go to it (`zentf run NAME --help`).
  Every program takes the shared node options (--name, --namespace, -p NAME:=VALUE, --connect, ...)."""


@click.command("run", add_help_option=False, short_help="Start a program: zentf run NAME [ARGS] (--list).",
               context_settings={"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []})
@click.pass_context
def run(ctx: click.Context) -> int:
    """Start a program (`zentf run --list` names them)."""
    args = list(ctx.args)
    if not args or args[0] in ("-h", "--help"):
        click.echo(_USAGE)
        return 0
    if args[0] == "--list":
        if len(args) > 1:
            raise click.UsageError(f"--list takes no arguments, got {' '.join(args[1:])!r}")
        width = max(map(len, PROGRAMS))
        for name, (_, line) in PROGRAMS.items():
            click.echo(f"{name:<{width}}  {line}")
        return 0
    name = args[0]
    if name.startswith("-"):
        raise click.UsageError(f"no such option: {name} (zentf run NAME [ARGS]; --list names the programs)")
    try:
        module = importlib.import_module(module_of(name))
    except KeyError as exc:
        raise CliError(str(exc.args[0]), code=2) from None
    from ..transport.program import finish

    finish(module.main([*outer_argv(), *args[1:]]))
