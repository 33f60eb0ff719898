"""Commands whose code lives outside the CLI package (router): imported only when invoked."""
from __future__ import annotations

import click

__all__ = ["router"]

_PASS_THROUGH = {"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []}


@click.command("router", context_settings=_PASS_THROUGH, add_help_option=False,
               short_help="Run a Zenoh router.")
@click.pass_context
def router(ctx: click.Context) -> int:
    """Run a Zenoh router for multi-machine graphs (see 'zentf router --help')."""
    from ..transport.router import main

    from .common import outer_argv

    return main([*outer_argv(("zenoh",)), *ctx.args], prog="zentf router")
