"""Two drones flying in `world`: av1 on the unit circle facing along it, av2 on a figure in the x-z plane.

At time t (seconds of the node's clock): av1 at (cos t, sin t, 0) with yaw t; av2 at
(sin t, 0, cos 2t) without rotation. Seen from av1, av2 then traces an ellipse of semi-axes 1/2
and sqrt(5)/2 in the plane 2y - z + 1 = 0.

Parameters: `rate` (Hz, default 50), `static` (default false), `frame_prefix` (default "", e.g.
`robot1/` names the drones robot1/av1 and robot1/av2 so robots share `world` without clashes).
With `static:=true` the two poses at t = 0 (av1 at (1, 0, 0), av2 at (0, 0, 1)) are published once
on tf_static (latched) and the node then just keeps them alive.
"""
from __future__ import annotations

import logging
import math
from typing import Sequence

from ..transport import program
from ..transport.broadcaster import StaticTransformBroadcaster, TransformBroadcaster
from ..core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
from ..transport.options import NodeOptions

log = logging.getLogger("frames_publisher")

PROG = "frames_publisher"
Pose7 = tuple[str, str, tuple[float, float, float], tuple[float, float, float, float]]


def drone_poses(t: float) -> list[Pose7]:
    """(parent, child, translation, quaternion xyzw) of both drones at time t."""
    half = 0.5 * t
    return [
        ("world", "av1", (math.cos(t), math.sin(t), 0.0), (0.0, 0.0, math.sin(half), math.cos(half))),
        ("world", "av2", (math.sin(t), 0.0, math.cos(2.0 * t)), (0.0, 0.0, 0.0, 1.0)),
    ]


def av2_in_av1(t: float) -> tuple[float, float, float]:
    """Closed form of av2 seen from av1 (what a listener should find)."""
    u = 2.0 * t
    return (-1.0 + 0.5 * math.sin(u), -0.5 + 0.5 * math.cos(u), math.cos(u))


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _stamped(stamp: object, poses: list[Pose7], prefix: str = "") -> list:
    return [TransformStamped(header=Header(stamp=stamp, frame_id=p), child_frame_id=prefix + c,
                             transform=Transform(Vector3(*tr), Quaternion(*q)))
            for p, c, tr, q in poses]


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        clock = node.get_clock()
        prefix = str(program.param(node, "frame_prefix", "") or "")
        if program.param_bool(node, "static", False):
            StaticTransformBroadcaster(node).send_transform(_stamped(clock.now(), drone_poses(0.0), prefix))
            program.say("published static poses of av1 and av2 (t = 0) on tf_static")
            node.spin()
            return
        rate = program.param_rate(node, "rate", 50.0)
        broadcaster = TransformBroadcaster(node)

        def tick() -> None:
            now = clock.now()
            if now.nanoseconds == 0:  # sim time before the first /clock message
                return
            broadcaster.send_transform(_stamped(now, drone_poses(now.nanoseconds / 1e9), prefix))

        node.create_timer(1.0 / rate, tick)
        program.say(f"publishing {prefix}av1 and {prefix}av2 in world at {rate:g} Hz")
        node.spin()


if __name__ == "__main__":
    program.finish(main())
