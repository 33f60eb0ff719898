"""`zentf robot-state-publisher` and `zentf joint-state-publisher`: the node programs under the CLI.

Start-up problems (bad flags, a malformed URDF) are one `zentf: error:` line with exit code 2 before
anything starts; then the program runs as `python -m nodes.<name>` would.
"""
from __future__ import annotations

import click

from .common import CliError

__all__ = ["robot_state_publisher", "joint_state_publisher"]

_PASS_THROUGH = {"ignore_unknown_options": True, "allow_extra_args": True, "help_option_names": []}


def _programs():
    try:
        from nodes import _robot_model, joint_state_publisher, robot_state_publisher
    except ImportError as exc:  # the nodes package is not installed
        raise CliError(f"the robot model programs are not available: {exc}") from exc
    return _robot_model, robot_state_publisher, joint_state_publisher


@click.command("robot-state-publisher", add_help_option=False, context_settings=_PASS_THROUGH,
               short_help="Publish a URDF robot's frames from joint_states.")
@click.pass_context
def robot_state_publisher(ctx: click.Context) -> int:
    """robot_state_publisher: URDF + joint_states -> tf, tf_static, robot_description."""
    model, rsp, _ = _programs()
    try:
        p = model.prepare(rsp.PROG, rsp._parser(), list(ctx.args))
    except model.START_ERRORS as exc:
        raise CliError(str(exc), code=2) from exc
    return 0 if p is None else rsp.run(p)


@click.command("joint-state-publisher", add_help_option=False, context_settings=_PASS_THROUGH,
               short_help="Publish joint_states for a URDF (values, --sweep, --gui sliders).")
@click.pass_context
def joint_state_publisher(ctx: click.Context) -> int:
    """joint_state_publisher (and its GUI as a local web page)."""
    model, _, jsp = _programs()
    try:
        p = model.prepare(jsp.PROG, jsp._parser(), list(ctx.args), model_optional=True)
        if p is None:
            return 0
        initial = jsp.check(p)
    except model.START_ERRORS as exc:
        raise CliError(str(exc), code=2) from exc
    return jsp.run(p, initial)
