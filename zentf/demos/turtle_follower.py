"""Spawn turtle2 and steer it toward turtle1 using only a tf lookup, like the tf2 turtle tutorial.

Every 1/`rate` s (default 10 Hz) looks up `target_frame` (default turtle1) in the follower's frame
(`turtlename`, default turtle2) and publishes `<turtlename>/cmd_vel` with angular
4*atan2(y, x) and linear 0.5*sqrt(x^2 + y^2). First, as the tutorial's listener does, it waits for
the `spawn` service and calls it (at `spawn_x`, `spawn_y`, `spawn_theta`, default 4, 2, 0); a turtle
of that name that already exists (a restarted follower) is taken over.
Prints `distance to <target>: d` once per second (`print_period`).
"""
from __future__ import annotations

import logging
import math
import time
from typing import Sequence

from ..transport import program
from ..transport.buffer import Buffer
from ..core.exceptions import TransformException
from ..transport.listener import TransformListener
from ..core.messages import TurtlePose, Twist, Vector3
from ..core.services import Spawn
from ..core.ratelimit import RateLimitedLogger
from ..transport.options import NodeOptions
from ..transport.service import ServiceException, ServiceTimeoutError, ServiceUnavailableError
from ..core.time import Time

log = logging.getLogger("turtle_follower")

PROG = "turtle_follower"


def follow_command(x: float, y: float) -> tuple[float, float]:
    """(linear, angular) toward a target at (x, y) in the follower's frame."""
    return 0.5 * math.sqrt(x * x + y * y), 4.0 * math.atan2(y, x)


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, PROG) as node:
        me = str(program.param(node, "turtlename", "turtle2"))
        target = str(program.param(node, "target_frame", "turtle1"))
        rate = program.param_rate(node, "rate", 10.0)
        print_period = program.param_rate(node, "print_period", 1.0, period=True)
        spawn = Spawn.Request(x=program.param_float(node, "spawn_x", 4.0),
                             y=program.param_float(node, "spawn_y", 2.0),
                             theta=program.param_float(node, "spawn_theta", 0.0), name=me)
        buffer = Buffer()
        listener = TransformListener(buffer, node)  # noqa: F841  (kept alive by this frame)
        complain = RateLimitedLogger(log, 2.0)
        cmd = node.create_publisher(f"{me}/cmd_vel", Twist)
        last_print = [-math.inf]
        alive = [False]

        def on_my_pose(_msg: TurtlePose) -> None:
            if not alive[0]:
                alive[0] = True
                program.say(f"{me} is alive")

        node.create_subscription(f"{me}/pose", TurtlePose, on_my_pose)
        if not _spawn(node, spawn):
            return

        def tick() -> None:
            try:
                ts = buffer.lookup_transform(me, target, Time())
            except TransformException as e:
                complain.log(logging.INFO, "lookup", "could not transform %s to %s: %s", target, me, e)
                return
            x, y = ts.transform.translation.x, ts.transform.translation.y
            linear, angular = follow_command(x, y)
            cmd.publish(Twist(linear=Vector3(linear, 0.0, 0.0), angular=Vector3(0.0, 0.0, angular)))
            now = time.monotonic()
            if now - last_print[0] >= print_period:
                last_print[0] = now
                program.say(f"distance to {target}: {math.hypot(x, y):.3f}")

        node.create_timer(1.0 / rate, tick)
        node.spin()


def _spawn(node: object, request: Spawn.Request) -> bool:
    """rospy.wait_for_service('spawn'), then call it; False if the node was stopped meanwhile."""
    client = node.create_client("spawn", Spawn)  # type: ignore[attr-defined]
    waited = False
    while not client.wait_for_service(timeout=1.0):
        if not node.ok():  # type: ignore[attr-defined]
            return False
        if not waited:
            waited = True
            log.info("waiting for service spawn")
    while node.ok():  # type: ignore[attr-defined]
        try:
            name = client.call(request, timeout=5.0).name
            log.info("spawned %s", name)
            return True
        except (ServiceTimeoutError, ServiceUnavailableError) as e:  # turtlesim restarting: try again
            log.warning("%s; retrying", e)
            client.wait_for_service(timeout=1.0)
        except ServiceException as e:
            if "already exists" in str(e):
                log.info("%s exists already: following with it", request.name)
                return True
            raise ValueError(f"spawn refused: {e}") from None
    return False


if __name__ == "__main__":
    program.finish(main())
