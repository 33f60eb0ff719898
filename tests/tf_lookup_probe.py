"""A listener process for the robot-model tests: prints one JSON line per change of each watched transform.

    python tests/tf_lookup_probe.py [zenoh/node flags] [--static-only] BASE:TARGET [BASE:TARGET ...]

Each line: ``{"pair": "BASE:TARGET", "t": [x, y, z], "q": [x, y, z, w], "stamp": ns}``, printed when
the latest transform of that pair first resolves and whenever its value changes (polled every 10 ms).
"""
from __future__ import annotations

import argparse
import json
import sys
import threading
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from zentf.transport.buffer import Buffer  # noqa: E402
from zentf.core.exceptions import TransformException  # noqa: E402
from zentf.core.time import Time  # noqa: E402
from zentf.transport.listener import TransformListener  # noqa: E402
from zentf.transport.node import Node  # noqa: E402
from zentf.transport.options import NodeOptions, add_node_arguments  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser()
    add_node_arguments(parser)
    parser.add_argument("--static-only", action="store_true")
    parser.add_argument("pairs", nargs="+")
    args = parser.parse_args()
    pairs = [tuple(p.split(":", 1)) for p in args.pairs]
    node = Node("tf_lookup_probe", options=NodeOptions.from_args(args), check_unique=False)
    buffer = Buffer()
    listener = TransformListener(buffer, node, static_only=args.static_only)  # noqa: F841
    last: dict[str, tuple] = {}
    print("probe ready", flush=True)
    stop = threading.Event()
    try:
        while not stop.wait(0.01) and node.ok():
            for base, target in pairs:
                try:
                    ts = buffer.lookup_transform(base, target, Time())
                except TransformException:
                    continue
                t, q = ts.transform.translation, ts.transform.rotation
                value = ((t.x, t.y, t.z), (q.x, q.y, q.z, q.w), ts.header.stamp.nanoseconds)
                key = f"{base}:{target}"
                if last.get(key) != value:
                    last[key] = value
                    print(json.dumps({"pair": key, "t": value[0], "q": value[1], "stamp": value[2]}), flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        node.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
