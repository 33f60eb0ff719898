"""An obstacle seen by the laser: a PointStamped in `laser` on `laser_point`, moving away along x.

Every `period` seconds (default 0.1) x grows by `step` (default 0.004) from `start_x` (default
0.3); y = 0, z = 0.1. Prints `obstacle in laser: (x, y, z)` every `print_every` messages
(default 10; 0 = never).
"""
from __future__ import annotations

import logging
from typing import Sequence

from ..transport import program
from ..core.messages import Header, Point, PointStamped
from ..transport.options import NodeOptions

log = logging.getLogger("point_publisher")

PROG = "point_publisher"


def obstacle_position(k: int, start_x: float = 0.3, step: float = 0.004) -> tuple[float, float, float]:
    """Position of the k-th published obstacle, in `laser`."""
    return (start_x + step * k, 0.0, 0.1)


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        period = program.param_rate(node, "period", 0.1, period=True)
        start_x = program.param_float(node, "start_x", 0.3)
        step = program.param_float(node, "step", 0.004)
        frame = str(program.param(node, "frame_id", "laser"))
        topic = str(program.param(node, "topic", "laser_point"))
        every = int(program.param_float(node, "print_every", 10))
        pub = node.create_publisher(topic, PointStamped)
        count = [0]

        def tick() -> None:
            k = count[0]
            count[0] += 1
            x, y, z = obstacle_position(k, start_x, step)
            pub.publish(PointStamped(header=Header(stamp=node.get_clock().now(), frame_id=frame),
                                     point=Point(x, y, z)))
            if every > 0 and k % every == 0:
                program.say(f"obstacle in {frame}: ({x:.3f}, {y:.3f}, {z:.3f})")

        node.create_timer(period, tick)
        node.spin()


if __name__ == "__main__":
    program.finish(main())
