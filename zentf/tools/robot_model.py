"""What robot_state_publisher and joint_state_publisher share: the URDF argument, its options, loading."""
from __future__ import annotations

import argparse
import os
from typing import Sequence

from ..transport import program
from ..transport.options import node_options_help
from ..urdf import Robot, URDFError, XacroBudget, load_urdf, parse_urdf, parse_xacro_budget

__all__ = ["own_arguments", "ArgError", "parse_own", "xacro_mappings", "load_model", "Prepared", "prepare",
           "START_ERRORS"]


def own_arguments(parser: argparse.ArgumentParser) -> None:
    """The URDF argument and options shared by robot_state_publisher and joint_state_publisher."""
    parser.epilog = node_options_help()
    parser.add_argument("urdf", nargs="?", metavar="URDF", help="a .urdf or .xacro file")
    parser.add_argument("--package-path", action="append", default=[], metavar="DIR",
                        help="where package:// meshes are looked up (repeat; also $ZENTF_PACKAGE_PATH)")
    parser.add_argument("--xacro-arg", action="append", default=[], metavar="NAME:=VALUE",
                        help="xacro argument (repeat)")
    parser.add_argument("--xacro-budget", default=None, metavar="SECONDSs[,MEGABYTESMB]",
                        help="CPU and memory a .xacro expansion may use (default 10s,512MB; e.g. 60s,2GB)")
    parser.add_argument("--xacro-env", action="append", default=[], metavar="NAME",
                        help="an environment variable a .xacro model may read with $(env)/$(optenv) (repeat; none "
                             "by default)")


class ArgError(ValueError):
    """A bad command line (one line)."""


def parse_own(parser: argparse.ArgumentParser, rest: Sequence[str]) -> argparse.Namespace | None:
    """Parse a program's own arguments; None for --help; ArgError with one line otherwise."""
    def error(message: str) -> None:
        raise ArgError(message)

    parser.error = error  # type: ignore[method-assign]
    if "-h" in rest or "--help" in rest:
        parser.print_help()
        return None
    return parser.parse_args(list(rest))


def xacro_mappings(items: Sequence[str]) -> dict[str, str]:
    out = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name:
            raise ArgError(f"--xacro-arg expects NAME:=VALUE, got {item!r}")
        out[name] = value
    return out


def xacro_budget(text: str | None) -> XacroBudget | None:
    if text is None:
        return None
    try:
        return parse_xacro_budget(text)
    except ValueError as e:
        raise ArgError(str(e)) from None


def load_model(urdf: str | None, package_path: list[str], xacro_args: dict[str, str],
               description: object, *, optional: bool = False, budget: XacroBudget | None = None,
               env_names: Sequence[str] = ()) -> Robot | None:
    """The robot from a file, else from the robot_description parameter text (None if optional)."""
    if urdf:
        env = {n: os.environ[n] for n in env_names if n in os.environ}
        return load_urdf(urdf, package_path=package_path, xacro_args=xacro_args, xacro_budget=budget, xacro_env=env)
    if isinstance(description, str) and description.strip():
        return parse_urdf(description, source="robot_description", package_path=package_path)
    if optional:
        return None
    raise ArgError("no robot model: give a URDF file (or the robot_description parameter)")


class Prepared:
    """What start-up checked: node options, the program's arguments, the robot model."""

    def __init__(self, opts, debug: bool, args: argparse.Namespace, robot: Robot | None,
                 package_path: list[str]) -> None:
        self.opts, self.debug, self.args, self.robot = opts, debug, args, robot
        self.package_path = package_path


def prepare(prog: str, parser: argparse.ArgumentParser, argv: Sequence[str], *,
            model_optional: bool = False) -> Prepared | None:
    """Options and the model, before anything starts; None for --help. Raises ArgError/URDFError/OptionsError.
    With ``model_optional`` no file and no parameter is allowed (the model comes from the topic later)."""
    opts, debug, rest = program.split_node_options(prog, argv)
    args = parse_own(parser, rest)
    if args is None:
        return None
    params = opts.resolved_params(opts.name or prog)
    package_path = [*args.package_path, *[d for d in str(params.get("package_path", "")).split(os.pathsep) if d]]
    robot = load_model(args.urdf, package_path, xacro_mappings(args.xacro_arg), params.get("robot_description"),
                       optional=model_optional, budget=xacro_budget(args.xacro_budget), env_names=args.xacro_env)
    return Prepared(opts, debug, args, robot, package_path)


#: What ``prepare`` raises for a bad start (one line each).
START_ERRORS = (ArgError, program.OptionsError, URDFError)
