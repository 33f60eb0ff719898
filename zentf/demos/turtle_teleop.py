"""Scripted teleop: drive a turtle along a fixed pattern instead of reading the keyboard.

Publishes `<turtlename>/cmd_vel` (default turtle1) at `rate` Hz (default 10). Patterns
(`pattern`): `circle` (constant `linear_speed`, default 1.0 m/s, and `angular_speed`, default
0.5 rad/s) or `square` (straight for `side` metres, default 2.0, then a quarter turn in place at
`angular_speed`). Prints the pattern once at start.
"""
from __future__ import annotations

import logging
import math
from typing import Sequence

from ..transport import program
from ..core.messages import Twist, Vector3
from ..transport.options import NodeOptions

log = logging.getLogger("turtle_teleop")

PROG = "turtle_teleop"
PATTERNS = ("circle", "square")


def command_at(pattern: str, t: float, linear: float, angular: float,
               side: float = 2.0) -> tuple[float, float]:
    """(linear, angular) velocity t seconds into the pattern."""
    if pattern == "circle":
        return linear, angular
    if pattern == "square":
        straight = side / abs(linear) if linear else 0.0
        turn = (math.pi / 2.0) / abs(angular) if angular else 0.0
        period = straight + turn
        if period <= 0.0:
            return 0.0, 0.0
        phase = math.fmod(t, period)
        return (linear, 0.0) if phase < straight else (0.0, angular)
    raise ValueError(f"unknown pattern {pattern!r} (choose from {', '.join(PATTERNS)})")


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        name = str(program.param(node, "turtlename", "turtle1"))
        pattern = str(program.param(node, "pattern", "circle"))
        linear = program.param_float(node, "linear_speed", 1.0)
        angular = program.param_float(node, "angular_speed", 0.5)
        side = program.param_positive(node, "side", 2.0)
        rate = program.param_rate(node, "rate", 10.0)
        if pattern not in PATTERNS:
            raise program.OptionsError(f"parameter pattern must be one of {', '.join(PATTERNS)}, "
                                       f"got {pattern!r}")
        pub = node.create_publisher(f"{name}/cmd_vel", Twist)
        clock = node.get_clock()
        start = clock.now().nanoseconds

        def tick() -> None:
            t = (clock.now().nanoseconds - start) / 1e9
            v, w = command_at(pattern, t, linear, angular, side)
            pub.publish(Twist(linear=Vector3(v, 0.0, 0.0), angular=Vector3(0.0, 0.0, w)))

        node.create_timer(1.0 / rate, tick)
        program.say(f"driving {name} in a {pattern} (linear {linear:g} m/s, angular {angular:g} rad/s)")
        node.spin()


if __name__ == "__main__":
    program.finish(main())
