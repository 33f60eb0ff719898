"""`zentf static-transform-publisher`: the static_transform_publisher program (zentf.tools), under the CLI."""
from __future__ import annotations

import click

__all__ = ["static_transform_publisher"]


@click.command("static-transform-publisher", add_help_option=False,
               context_settings={"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []},
               short_help="Publish a static transform.")
@click.pass_context
def static_transform_publisher(ctx: click.Context) -> int:
    """tf2_ros static_transform_publisher: flags or positional forms, plus the node options."""
    from ..tools.static_transform_publisher import main as node_main

    from .common import outer_argv

    rv = node_main([*outer_argv(), *ctx.args])
    return rv if isinstance(rv, int) else 0
