"""`zentf robot-state-publisher` and `zentf joint-state-publisher`: the node programs under the CLI.

Start-up problems (bad flags, a malformed URDF) are one `zentf: error:` line with exit code 2 before
anything starts; then the program runs as `zentf run <name>` would.
"""
from __future__ import annotations

import importlib
from typing import Any

import click

from .common import CliError, outer_argv

__all__ = ["robot_state_publisher", "joint_state_publisher"]

_PASS_THROUGH = {"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []}


def _start(name: str, args: list[str], *, model_optional: bool = False, check: bool = False) -> tuple[Any, Any, Any]:
    """(program module, prepared options or None for --help, what the program's ``check`` returned or None):
    a start-up problem is one ``zentf: error:`` line, exit 2, before anything runs."""
    from ..tools import robot_model as model

    program = importlib.import_module(f"zentf.tools.{name}")
    try:
        p = model.prepare(program.PROG, program._parser(), args, model_optional=model_optional)
        checked = program.check(p) if check and p is not None else None
    except model.START_ERRORS as exc:
        raise CliError(str(exc), code=2) from exc
    return program, p, checked


@click.command("robot-state-publisher", add_help_option=False, context_settings=_PASS_THROUGH,
               short_help="Publish a URDF robot's frames from joint_states.")
@click.pass_context
def robot_state_publisher(ctx: click.Context) -> int:
    """robot_state_publisher: URDF + joint_states -> tf, tf_static, robot_description."""
    rsp, p, _ = _start("robot_state_publisher", [*outer_argv(), *ctx.args])
    return 0 if p is None else rsp.run(p)


@click.command("joint-state-publisher", add_help_option=False, context_settings=_PASS_THROUGH,
               short_help="Publish joint_states for a URDF (values, --sweep, --gui sliders).")
@click.pass_context
def joint_state_publisher(ctx: click.Context) -> int:
    """joint_state_publisher (and its GUI as a local web page)."""
    jsp, p, initial = _start("joint_state_publisher", [*outer_argv(), *ctx.args], model_optional=True, check=True)
    return 0 if p is None else jsp.run(p, initial)
