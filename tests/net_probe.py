"""A watching listener for the network tests: prints one JSON line of what its Buffer holds per tick.

    python tests/net_probe.py [zenoh/node flags] [--tf-topic tf] [--static PARENT:CHILD] [--period 0.1]

Each line: ``{"frames": [...], "av1_ns": latest stamp of world->av1 or null, "checked": n, "bad": n,
"static": bool, "count": {child: transforms received}}``. ``checked``/``bad``: av2 seen from av1 at
an exact sample time compared with frames_publisher's closed form (the latest one every tick, and
again every earlier one still in the buffer) - ``bad`` > 0 means the buffer was corrupted. ``count``
comes from a plain subscription on the tf topic (rate of each publisher's frames).
"""
from __future__ import annotations

import argparse
import collections
import json
import logging
import math
import sys
import threading
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from zentf.demos.frames_publisher import av2_in_av1  # noqa: E402
from zentf.transport.buffer import Buffer  # noqa: E402
from zentf.core.exceptions import TransformException  # noqa: E402
from zentf.transport.listener import TransformListener  # noqa: E402
from zentf.transport.node import Node  # noqa: E402
from zentf.transport.options import NodeOptions, add_node_arguments  # noqa: E402
from zentf.core.time import Time  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(prog="net_probe")
    add_node_arguments(parser)
    parser.add_argument("--tf-topic", default="tf")
    parser.add_argument("--tf-static-topic", default="tf_static")
    parser.add_argument("--static", default=None, help="PARENT:CHILD static pair to look up")
    parser.add_argument("--prefix", default="", help="frame prefix of the drones to check")
    parser.add_argument("--period", type=float, default=0.1)
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    opts = NodeOptions.from_args(args, parser=parser)
    node = Node(opts.name or "net_probe", options=opts, check_unique=False)
    buffer = Buffer()
    TransformListener(buffer, node, tf_topic=args.tf_topic, tf_static_topic=args.tf_static_topic)
    counts: collections.Counter[str] = collections.Counter()
    lock = threading.Lock()

    def on_raw(sample: object) -> None:
        import msgpack

        try:
            msg = msgpack.unpackb(sample.payload, raw=False)  # type: ignore[attr-defined]
            children = [t["child_frame_id"] for t in msg["transforms"]]
        except Exception:
            return
        with lock:
            counts.update(children)

    node.create_raw_subscription(args.tf_topic, on_raw)
    seen: collections.deque[int] = collections.deque(maxlen=200)
    av1, av2 = args.prefix + "av1", args.prefix + "av2"
    stop = threading.Event()
    import signal

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    checked = bad = 0

    def check(stamp_ns: int) -> bool:
        ts = buffer.lookup_transform(av1, av2, Time(nanoseconds=stamp_ns))
        tr = ts.transform.translation
        want = av2_in_av1(stamp_ns / 1e9)
        return all(math.isfinite(g) and abs(g - w) < 1e-6 for g, w in zip((tr.x, tr.y, tr.z), want))

    while not stop.wait(args.period):
        av1_ns = None
        try:
            av1_ns = buffer.lookup_transform("world", av1, Time()).header.stamp.nanoseconds
        except TransformException:
            pass
        try:
            latest = buffer.lookup_transform(av1, av2, Time()).header.stamp.nanoseconds
            if not seen or seen[-1] != latest:
                seen.append(latest)
        except TransformException:
            pass
        for stamp in list(seen):  # every exact sample time still in the buffer must still be right
            try:
                ok = check(stamp)
            except TransformException:
                continue  # aged out of the cache (or cleared): not corruption
            checked += 1
            bad += not ok
        static_ok = False
        if args.static:
            parent, _, child = args.static.partition(":")
            static_ok = buffer.can_transform(parent, child, Time())
        with lock:
            count = dict(counts)
        frames = sorted(i["frame"] for i in buffer.frame_info())
        print(json.dumps({"frames": frames, "av1_ns": av1_ns, "checked": checked, "bad": bad,
                          "static": static_ok, "count": count}), flush=True)
    node.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
