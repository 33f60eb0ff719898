"""Commands owned by other packages that are not click commands (router): imported only when invoked."""
from __future__ import annotations

import importlib
from typing import Any

import click

from .common import CliError

__all__ = ["router", "delegate"]

_PASS_THROUGH = {"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []}


def _import(module: str, prog: str) -> Any:
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise CliError(f"'{prog}' is not available: {exc}") from exc


def _run_click(cmd: click.Command, args: list[str], prog: str) -> int:
    rv = cmd.main(args=args, prog_name=prog, standalone_mode=False)
    return rv if isinstance(rv, int) else 0


def _as_click(obj: Any) -> click.Command | None:
    """A click command from a click command, a typer app or a typer-style function."""
    if isinstance(obj, click.Command):
        return obj
    try:
        import typer
    except ImportError:  # pragma: no cover
        return None
    if isinstance(obj, typer.Typer):
        return typer.main.get_command(obj)
    if callable(obj):
        one = typer.Typer(add_completion=False, pretty_exceptions_enable=False)
        one.command()(obj)
        return typer.main.get_command(one)
    return None


def delegate(module: str, name: str, prog: str, args: list[str]) -> int:
    """Run command `name` of `module` with raw `args`, in whatever form it was written."""
    mod = _import(module, prog)
    fn = getattr(mod, f"{name}_main", None)
    if fn is None and module.rsplit(".", 1)[-1] == name:
        fn = getattr(mod, "main", None)
    if callable(fn):
        rv = fn(args)
        return rv if isinstance(rv, int) else 0
    obj = getattr(mod, name, None)
    cmd = _as_click(obj) if obj is not None else None
    if cmd is not None:
        return _run_click(cmd, args, prog)
    group = getattr(mod, "app", None) or getattr(mod, "cli", None)
    cmd = _as_click(group) if group is not None else None
    if isinstance(cmd, click.Group):
        return _run_click(cmd, [name, *args], prog.rsplit(" ", 1)[0])
    raise CliError(f"'{prog}' is not available: {module} defines no '{name}' command")


@click.command("router", context_settings=_PASS_THROUGH, add_help_option=False,
               short_help="Run a Zenoh router.")
@click.pass_context
def router(ctx: click.Context) -> int:
    """Run a Zenoh router for multi-machine graphs (see 'zentf router --help')."""
    return delegate("zentf.router", "router", "zentf router", list(ctx.args))
