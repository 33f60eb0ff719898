"""Every second, look up where the laser is as seen from the camera, and print it.

Parameters: `target_frame` (default `camera`), `source_frame` (default `laser`), `period`
(seconds, default 1.0), `tf_topic` / `tf_static_topic` (default `tf` / `tf_static`; `/*/tf` and
`/*/tf_static` watch every robot namespace). Prints
`laser in camera: translation (x, y, z) rotation (qx, qy, qz, qw)` per successful lookup, and
logs why a lookup failed otherwise.
"""
from __future__ import annotations

import logging
from typing import Sequence

from ..transport import program
from ..transport.buffer import Buffer
from ..core.exceptions import TransformException
from ..transport.listener import TransformListener
from ..transport.options import NodeOptions
from ..core.time import Time

log = logging.getLogger("frame_listener")

PROG = "frame_listener"


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        target = str(program.param(node, "target_frame", "camera"))
        source = str(program.param(node, "source_frame", "laser"))
        period = program.param_rate(node, "period", 1.0, period=True)
        buffer = Buffer()
        listener = TransformListener(  # noqa: F841  (kept alive by this frame)
            buffer, node, tf_topic=str(program.param(node, "tf_topic", "tf")),
            tf_static_topic=str(program.param(node, "tf_static_topic", "tf_static")))

        def tick() -> None:
            try:
                ts = buffer.lookup_transform(target, source, Time())
            except TransformException as e:
                log.info("could not transform %s to %s: %s", source, target, e)
                return
            t, q = ts.transform.translation, ts.transform.rotation
            program.say(f"{source} in {target}: translation ({t.x:.3f}, {t.y:.3f}, {t.z:.3f}) "
                        f"rotation ({q.x:.3f}, {q.y:.3f}, {q.z:.3f}, {q.w:.3f})")

        node.create_timer(period, tick)
        node.spin()


if __name__ == "__main__":
    program.finish(main())
