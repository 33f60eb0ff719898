"""Publish one latched transform, with ROS 2 static_transform_publisher's arguments and errors.

    zentf run static_transform_publisher --x 0.4 --z 0.2 --frame-id base_link --child-frame-id laser
    zentf run static_transform_publisher 0.4 0 0.2 0 0 0 base_link laser        # x y z yaw pitch roll
    zentf run static_transform_publisher 0.4 0 0.2 0 0 0 1 base_link laser      # x y z qx qy qz qw

The shared node options (--connect, --name, -p, ...) are accepted too. Differences from ROS 2, all
stricter: a number must be the whole argument ("1.5m" is refused, ROS reads 1.5), it must be finite,
and a quaternion whose squared norm is not within 0.01 of 1 is refused here instead of being
published and then dropped by every receiver. Bad arguments exit with status 2, like every zentf
command.
"""
from __future__ import annotations

import logging
import math
import re
import secrets
import string
import sys
from dataclasses import dataclass
from typing import Callable, Sequence

from ..transport import program
from ..transport.broadcaster import StaticTransformBroadcaster
from ..core.math3d import quaternion_from_rpy
from ..core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
from ..transport.options import NodeOptions, node_options_help

log = logging.getLogger("static_transform_publisher")

PROG = "static_transform_publisher"

USAGE = (
    "usage: static_transform_publisher [--x X] [--y Y] [--z Z] [--qx QX] [--qy QY] "
    "[--qz QZ] [--qw QW] [--roll ROLL] [--pitch PITCH] [--yaw YAW] --frame-id FRAME_ID "
    "--child-frame-id CHILD_FRAME_ID\n"
    "   or: static_transform_publisher x y z yaw pitch roll frame_id child_frame_id\n"
    "   or: static_transform_publisher x y z qx qy qz qw frame_id child_frame_id\n\n"
    "A command line utility for manually sending a static transform.\n\nIf no translation or"
    " orientation is provided, the identity transform will be published.\n\nThe translation offsets"
    " are in meters.\n\nThe rotation may be provided with roll, pitch, yaw euler angles in radians,"
    " or as a quaternion.\n\n"
    "required arguments:\n"
    "  --frame-id FRAME_ID parent frame\n"
    "  --child-frame-id CHILD_FRAME_ID child frame id\n\n"
    "optional arguments:\n"
    "  --x X                 x component of translation\n"
    "  --y Y                 y component of translation\n"
    "  --z Z                 z component of translation\n"
    "  --qx QX               x component of quaternion rotation\n"
    "  --qy QY               y component of quaternion rotation\n"
    "  --qz QZ               z component of quaternion rotation\n"
    "  --qw QW               w component of quaternion rotation\n"
    "  --roll ROLL           roll component Euler rotation\n"
    "  --pitch PITCH         pitch component Euler rotation\n"
    "  --yaw YAW             yaw component Euler rotation"
)


class UsageError(ValueError):
    """Bad command line; the text is ROS 2's wording."""


@dataclass(frozen=True)
class StaticTransformArgs:
    """What the command line asked to publish."""

    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]
    frame_id: str
    child_frame_id: str
    old_style: bool = False


# strtod's decimal and special-value syntax, but anchored at both ends (no trailing junk).
_FLOAT_RE = re.compile(
    r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan(?:\([0-9A-Za-z_]*\))?)",
    re.IGNORECASE)
_HEX_RE = re.compile(r"[+-]?0[xX](?:[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)(?:[pP][+-]?\d+)?")


def parse_float(optname: str, text: str) -> float:
    """Read one number the way std::stod does, refusing junk and non-finite values."""
    s = text.strip()
    value: float | None = None
    if _FLOAT_RE.fullmatch(s):
        low = s.lower()
        value = float("nan") if "nan" in low else float(s)
        if math.isinf(value) and "inf" not in low:  # overflow: stod throws out_of_range
            value = None
    elif _HEX_RE.fullmatch(s):
        try:
            value = float.fromhex(s)
        except (OverflowError, ValueError):
            value = None
    if value is None:
        raise UsageError(f"Failed to parse {optname} argument as float")
    if not math.isfinite(value):
        raise UsageError(f"{optname} argument must be a finite number, got {text!r}")
    return value


def parse_args(args: Sequence[str]) -> StaticTransformArgs | None:
    """Parse the program's own arguments (no program name); None means --help was asked."""
    if len(args) < 1:
        raise UsageError("Not enough arguments to parse")
    trans = [0.0, 0.0, 0.0]
    quat = [0.0, 0.0, 0.0, 1.0]
    rpy = [0.0, 0.0, 0.0]
    frames = ["", ""]
    saw = {"frame": False, "quat": False, "rpy": False, "trans": False}
    help_asked = False

    def setter(store: list, index: int, flag: str) -> Callable[[str, str], None]:
        def visit(optname: str, text: str) -> None:
            store[index] = parse_float(optname, text)
            saw[flag] = True
        return visit

    def frame_setter(index: int) -> Callable[[str, str], None]:
        def visit(optname: str, text: str) -> None:
            frames[index] = text
            saw["frame"] = True
        return visit

    options: dict[str, Callable[[str, str], None]] = {
        "--qx": setter(quat, 0, "quat"), "--qy": setter(quat, 1, "quat"),
        "--qz": setter(quat, 2, "quat"), "--qw": setter(quat, 3, "quat"),
        "--roll": setter(rpy, 0, "rpy"), "--pitch": setter(rpy, 1, "rpy"),
        "--yaw": setter(rpy, 2, "rpy"),
        "--x": setter(trans, 0, "trans"), "--y": setter(trans, 1, "trans"),
        "--z": setter(trans, 2, "trans"),
        "--frame-id": frame_setter(0), "--child-frame-id": frame_setter(1),
    }
    positional: list[str] = []
    i = 0
    while i < len(args):
        name = args[i]
        if name in ("--help", "-h"):
            help_asked = True
        elif name in options:
            if i == len(args) - 1:
                raise UsageError(f"Not enough arguments for {name}")
            i += 1
            options[name](name, args[i])
        else:
            positional.append(name)
        i += 1
    if help_asked:
        return None
    if saw["rpy"] and saw["quat"]:
        raise UsageError("Cannot specify both quaternion and Euler rotations")
    if saw["rpy"]:
        quat = list(quaternion_from_rpy(*rpy))
    old_style = len(positional) in (8, 9)
    if old_style:
        log.info("Old-style arguments are deprecated; see --help for new-style arguments")
        if saw["frame"] or saw["trans"] or saw["quat"]:
            raise UsageError("Cannot specify both new-style (flags) and old-style (arguments)")
        trans = [parse_float(n, positional[k]) for k, n in enumerate(("x", "y", "z"))]
        if len(positional) == 8:
            yaw, pitch, roll = (parse_float(n, positional[3 + k])
                                for k, n in enumerate(("yaw", "pitch", "roll")))
            quat = list(quaternion_from_rpy(roll, pitch, yaw))
            frames = positional[6:8]
        else:
            quat = [parse_float(n, positional[3 + k]) for k, n in enumerate(("qx", "qy", "qz", "qw"))]
            frames = positional[7:9]
    elif positional:
        raise UsageError("Extra unparsed arguments on command-line")
    if frames[0] == "":
        raise UsageError("Frame id must not be empty")
    if frames[1] == "":
        raise UsageError("Child frame id must not be empty")
    norm2 = sum(c * c for c in quat)
    if abs(norm2 - 1.0) >= 0.01:
        raise UsageError(
            "Quaternion ({:g}, {:g}, {:g}, {:g}) is not normalized (squared norm {:g}); "
            "every receiver would drop it".format(*quat, norm2))
    return StaticTransformArgs((trans[0], trans[1], trans[2]), (quat[0], quat[1], quat[2], quat[3]),
                               frames[0], frames[1], old_style)


def default_node_name() -> str:
    """ROS 2's anonymous name: the program name plus 16 random alphanumerics."""
    alphabet = string.ascii_letters + string.digits
    return PROG + "_" + "".join(secrets.choice(alphabet) for _ in range(16))


def describe(a: StaticTransformArgs) -> str:
    """ROS 2's start-up message, on one line."""
    (x, y, z), (qx, qy, qz, qw) = a.translation, a.rotation
    return (f"Spinning until stopped - publishing transform translation: ('{x:f}', '{y:f}', '{z:f}') "
            f"rotation: ('{qx:f}', '{qy:f}', '{qz:f}', '{qw:f}') "
            f"from '{a.frame_id}' to '{a.child_frame_id}'")


def main(argv: Sequence[str] | None = None) -> int:
    """Parse, publish once on tf_static, spin until stopped; returns the exit status."""
    if argv is None:
        argv = sys.argv[1:]
    try:
        opts, debug, rest = program.split_node_options(PROG, argv)
        parsed = parse_args(rest)
    except (UsageError, program.OptionsError) as e:
        program.error_line(PROG, str(e), "error parsing command line arguments: ")
        return 2  # a usage error, like every zentf command (docs/cli.md)
    if parsed is None:
        print(f"{USAGE}\n\n{node_options_help()}", flush=True)
        return 0
    if parsed.frame_id == parsed.child_frame_id:
        program.error_line(PROG, f"from '{parsed.frame_id}' to '{parsed.child_frame_id}', exiting",
                           "cannot publish static transform ")
        return 2
    return program.run(lambda: _publish(opts, parsed), PROG, debug)


def _publish(opts: NodeOptions, a: StaticTransformArgs) -> None:
    """Send the one transform on tf_static and spin; the broadcaster keeps it latched."""
    with program.make_node(opts, default_node_name()) as node:
        ts = TransformStamped(
            header=Header(stamp=node.get_clock().now(), frame_id=a.frame_id),
            child_frame_id=a.child_frame_id,
            transform=Transform(Vector3(*a.translation), Quaternion(*a.rotation)))
        broadcaster = StaticTransformBroadcaster(node)
        broadcaster.send_transform(ts)
        program.say(describe(a))
        node.spin()


if __name__ == "__main__":
    program.finish(main())
