"""Trails of the two drones as line strips: av1 and av2 in `world`, and av2 as seen from `av1`.

Listens to tf with a Buffer, looks the three up at the latest common time `rate` times a second,
keeps the last `trail_length` points of each and publishes a MarkerArray on `visual_markers`
(namespace `trails`, ids 0 = av1 in world, 1 = av2 in world, 2 = av2 in av1; LINE_STRIP).

Parameters: `rate` (Hz, default 10), `trail_length` (points, default 200), `topic` (default
`visual_markers`), `frame_prefix` (default "", as frames_publisher's: `robot1/` follows robot1/av1
and robot1/av2). Prints `av2 in av1: (x, y, z)` for every new sample of that trail.
"""
from __future__ import annotations

import collections
import logging
from typing import Sequence

from ..transport import program
from ..transport.buffer import Buffer
from ..core.exceptions import TransformException
from ..transport.listener import TransformListener
from ..core.messages import ColorRGBA, Header, Marker, MarkerArray, Point, Vector3
from ..core.ratelimit import RateLimitedLogger
from ..transport.options import NodeOptions
from ..core.time import Time

log = logging.getLogger("plots_publisher")

PROG = "plots_publisher"

#: (marker id, target frame, source frame, rgba)
TRAILS = (
    (0, "world", "av1", (1.0, 0.2, 0.2, 1.0)),
    (1, "world", "av2", (0.2, 0.4, 1.0, 1.0)),
    (2, "av1", "av2", (0.2, 0.9, 0.2, 1.0)),
)


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        rate = program.param_rate(node, "rate", 10.0)
        length = int(program.param_positive(node, "trail_length", 200))
        topic = str(program.param(node, "topic", "visual_markers"))
        prefix = str(program.param(node, "frame_prefix", "") or "")
        buffer = Buffer()
        listener = TransformListener(buffer, node)  # noqa: F841  (kept alive by this frame)
        pub = node.create_publisher(topic, MarkerArray)
        trails = {tid: collections.deque(maxlen=length) for tid, *_ in TRAILS}
        last_stamp: dict[int, int] = {}
        complain = RateLimitedLogger(log, 5.0)

        def tick() -> None:
            markers = []
            for tid, target, source, rgba in TRAILS:
                target = target if target == "world" else prefix + target
                source = prefix + source
                try:
                    ts = buffer.lookup_transform(target, source, Time())
                except TransformException as e:
                    complain.log(logging.INFO, (target, source), "waiting for %s in %s: %s", source, target, e)
                    continue
                stamp = ts.header.stamp.nanoseconds
                tr = ts.transform.translation
                if last_stamp.get(tid) != stamp:
                    last_stamp[tid] = stamp
                    trails[tid].append(Point(tr.x, tr.y, tr.z))
                    if tid == 2:
                        program.say(f"av2 in av1: ({tr.x:.4f}, {tr.y:.4f}, {tr.z:.4f})")
                markers.append(Marker(
                    header=Header(stamp=ts.header.stamp, frame_id=target), ns="trails", id=tid,
                    type=Marker.LINE_STRIP, action=Marker.ADD, scale=Vector3(0.02, 0.0, 0.0),
                    color=ColorRGBA(*rgba), points=list(trails[tid]), text=f"{source} in {target}"))
            if markers:
                pub.publish(MarkerArray(markers=markers))

        node.create_timer(1.0 / rate, tick)
        node.spin()


if __name__ == "__main__":
    program.finish(main())
