"""Test helper: a process whose nodes publish transforms with staged problems, for the tf doctor's tests.

    python tests/tf_stager.py '{"nodes": [{"name": "dup_a", "sends": [{"parent": "world", "child": "payload",
                                "rate": 20, "offset": 0.0, "static": false}]}]}'

Each node (its own Zenoh session, ZENTF_* env for the rest) sends its transforms at ``rate`` Hz on tf,
stamped ``offset`` seconds from its clock's now (negative: behind), or once on tf_static
(``"static": true``). ``"translation"`` gives a fixed translation (default: one moving with time);
``"stop_on": "SIGUSR1"`` stops that send when the process gets SIGUSR1 (a publisher going silent);
a node's ``"namespace"`` replaces ZENTF_NAMESPACE.
Prints ``staged`` once every publisher is declared, then runs until SIGTERM.
"""
from __future__ import annotations

import json
import math
import signal
import sys
import threading
import time


def main() -> int:
    from zentf import Node
    from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
    from zentf.core.time import Time
    from zentf.transport.broadcaster import StaticTransformBroadcaster, TransformBroadcaster
    from zentf.transport.options import NodeOptions

    spec = json.loads(sys.argv[1])
    nodes, jobs = [], []
    for n in spec["nodes"]:
        opts = NodeOptions.from_env()
        opts.name = n["name"]
        if "namespace" in n:
            opts.namespace = n["namespace"]
        node = Node(options=opts, check_unique=False)
        nodes.append(node)
        dyn = TransformBroadcaster(node)
        static = None
        for s in n["sends"]:
            if s.get("static"):
                static = static or StaticTransformBroadcaster(node)
                jobs.append((node, static, s, None))
            else:
                jobs.append((node, dyn, s, 1.0 / float(s.get("rate", 20.0))))
    # after the nodes: a node takes SIGINT/SIGTERM for itself, and this loop must see them
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    silenced = threading.Event()
    signal.signal(signal.SIGUSR1, lambda *_: silenced.set())

    def stamped(node: object, s: dict, now_ns: int) -> TransformStamped:
        t = now_ns / 1e9
        tr = s.get("translation") or [math.cos(t), math.sin(t), 0.5]
        stamp = Time(nanoseconds=max(0, now_ns + round(float(s.get("offset", 0.0)) * 1e9)))
        return TransformStamped(header=Header(stamp=stamp, frame_id=s["parent"]), child_frame_id=s["child"],
                                transform=Transform(Vector3(*tr), Quaternion(0.0, 0.0, 0.0, 1.0)))

    for node, pub, s, period in jobs:
        if period is None:
            pub.send_transform(stamped(node, s, node.get_clock().now().nanoseconds))
    print("staged", flush=True)
    due = [time.monotonic()] * len(jobs)
    while not stop.is_set():
        now = time.monotonic()
        for i, (node, pub, s, period) in enumerate(jobs):
            if period is not None and now >= due[i]:
                if not (s.get("stop_on") and silenced.is_set()):  # silenced: keep the schedule, send nothing
                    pub.send_transform(stamped(node, s, node.get_clock().now().nanoseconds))
                due[i] += period
                if due[i] < now:
                    due[i] = now + period
        stop.wait(max(0.0, min(due[i] for i in range(len(jobs)) if jobs[i][3] is not None) - time.monotonic())
                  if any(j[3] is not None for j in jobs) else 0.5)
    for node in nodes:
        node.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
