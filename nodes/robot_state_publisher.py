"""robot_state_publisher: a URDF file's frames on tf_static (fixed joints) and tf (from joint_states).

    python -m nodes.robot_state_publisher configs/robots/my_robot.urdf
    python -m nodes.robot_state_publisher robot.urdf.xacro --frame-prefix robot1/ --publish-frequency 50
    python -m nodes.robot_state_publisher -p robot_description:="$(cat robot.urdf)"

Parameters (``-p NAME:=VALUE`` or launch ``parameters:``): ``publish_frequency`` (Hz, default 20),
``frame_prefix`` (default ''), ``ignore_timestamp`` (default false), ``robot_description`` (URDF
text, used when no file is given), ``package_path`` (os.pathsep-separated). The flags below
override them. A malformed URDF is refused before anything starts (one line, exit 2).
"""
from __future__ import annotations

import argparse
import sys
from typing import Sequence

from nodes import _common
from nodes._robot_model import START_ERRORS, Prepared, own_arguments, prepare
from zentf.urdf import Robot

PROG = "robot_state_publisher"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, allow_abbrev=False,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    own_arguments(p)
    p.add_argument("--frame-prefix", default=None, help="prepended to every frame id (e.g. robot1/)")
    p.add_argument("--publish-frequency", type=float, default=None, metavar="HZ",
                   help="most tf messages per second per joint (default 20)")
    p.add_argument("--ignore-timestamp", action="store_true", default=None,
                   help="publish every joint state, whatever its stamp")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Check everything, then run; a bad argument or model is one line and exit 2."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        p = prepare(PROG, _parser(), argv)
    except START_ERRORS as e:
        print(f"{PROG}: error: {e}", file=sys.stderr, flush=True)
        return 2
    return 0 if p is None else run(p)


def run(p: Prepared) -> int:
    return _common.run(lambda: _run(p.opts, p.robot, p.args), PROG, p.debug)


def _run(opts, robot: Robot, args: argparse.Namespace) -> None:
    from zentf.tools.robot_state_publisher import RobotStatePublisher

    with _common.make_node(opts, PROG) as node:
        prefix = args.frame_prefix if args.frame_prefix is not None else str(_common.param(node, "frame_prefix", ""))
        freq = (args.publish_frequency if args.publish_frequency is not None
                else _common.param_positive(node, "publish_frequency", 20.0))
        if not freq > 0 or freq != freq:
            raise _common.OptionsError(f"--publish-frequency must be > 0, got {freq}")
        ignore = bool(args.ignore_timestamp) or _common.param_bool(node, "ignore_timestamp", False)
        rsp = RobotStatePublisher(node, robot, frame_prefix=prefix, publish_frequency=freq, ignore_timestamp=ignore)
        movable = len(rsp._movable.names)
        _common.say(f"publishing robot '{robot.name}' ({len(robot.links)} links): {len(robot.joints) - movable} "
                    f"fixed joints on tf_static, {movable} movable joints from joint_states on tf")
        node.spin()


if __name__ == "__main__":
    _common.finish(main())
