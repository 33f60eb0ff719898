"""Print each obstacle point in `base_link`, delivered by a MessageFilter once it is transformable.

Subscribes `laser_point` (PointStamped), waits through a MessageFilter (target `base_link`, queue
10) and prints `obstacle in base_link: (x, y, z)` for every point. Parameters: `topic` (default
`laser_point`), `target_frame` (default `base_link`), `queue_size` (default 10), `timeout`
(seconds a message may wait for its transform, default 1.0).
"""
from __future__ import annotations

import logging
from typing import Sequence

from ..transport import program
from ..transport.buffer import Buffer
from ..core.exceptions import TransformException
from ..transport.listener import TransformListener
from ..transport.message_filter import MessageFilter
from ..core.messages import PointStamped
from ..transport.options import NodeOptions

log = logging.getLogger("point_listener")

PROG = "point_listener"


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        topic = str(program.param(node, "topic", "laser_point"))
        target = str(program.param(node, "target_frame", "base_link"))
        queue_size = int(program.param_positive(node, "queue_size", 10))
        timeout = program.param_rate(node, "timeout", 1.0, period=True)  # (a wait: bounded as a period)
        buffer = Buffer()
        listener = TransformListener(buffer, node)  # noqa: F841  (kept alive by this frame)

        def on_point(msg: PointStamped) -> None:
            try:
                p = buffer.transform(msg, target)
            except TransformException as e:
                log.warning("could not transform the obstacle: %s", e)
                return
            program.say(f"obstacle in {target}: ({p.point.x:.3f}, {p.point.y:.3f}, {p.point.z:.3f})")

        flt = MessageFilter(topic, buffer, target, queue_size, timeout, node=node, msg_type=PointStamped)
        flt.register_callback(on_point)  # drops are logged by the filter with their reason
        node.spin()


if __name__ == "__main__":
    program.finish(main())
