"""Broadcast world -> <turtlename> from the turtle's pose, like the tf2 turtle tutorial.

Parameters `turtlename` (default `turtle1`) and `world_frame` (default `world`). Subscribes
`<turtlename>/pose` (relative: the node's namespace applies) and sends one transform per pose with
translation (x, y, 0) and yaw theta, stamped with the node's clock. Prints
`broadcasting world -> <turtlename>` once at start.
"""
from __future__ import annotations

import logging
import math
from typing import Sequence

from ..transport import program
from ..transport.broadcaster import TransformBroadcaster
from ..core.messages import Header, Quaternion, Transform, TransformStamped, TurtlePose, Vector3
from ..transport.options import NodeOptions

log = logging.getLogger("turtle_tf_broadcaster")

PROG = "turtle_tf_broadcaster"


def pose_to_transform(x: float, y: float, theta: float) -> tuple[tuple[float, float, float],
                                                                   tuple[float, float, float, float]]:
    """Planar pose as a 3D translation and a yaw-only quaternion (xyzw)."""
    return (x, y, 0.0), (0.0, 0.0, math.sin(theta / 2.0), math.cos(theta / 2.0))


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        name = str(program.param(node, "turtlename", "turtle1"))
        parent = str(program.param(node, "world_frame", "world"))
        broadcaster = TransformBroadcaster(node)

        def on_pose(msg: TurtlePose) -> None:
            if not all(map(math.isfinite, (msg.x, msg.y, msg.theta))):
                log.warning("ignoring a non-finite pose of %s", name)
                return
            tr, q = pose_to_transform(msg.x, msg.y, msg.theta)
            broadcaster.send_transform(TransformStamped(
                header=Header(stamp=node.get_clock().now(), frame_id=parent), child_frame_id=name,
                transform=Transform(Vector3(*tr), Quaternion(*q))))

        node.create_subscription(f"{name}/pose", TurtlePose, on_pose)
        program.say(f"broadcasting {parent} -> {name}")
        node.spin()


if __name__ == "__main__":
    program.finish(main())
