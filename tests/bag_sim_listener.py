"""A use_sim_time listener for the bag play tests: fills a Buffer from the network while a bag plays with
--clock, waits until the played /clock reaches ``--until`` (ns), then answers the queries of a JSON file
(``[[target, source, stamp_ns], ...]``) with one JSON line: a list of [x, y, z, qx, qy, qz, qw] or the
exception's class name per query.

    python tests/bag_sim_listener.py [zenoh/node flags] --until NS --queries FILE [--timeout S]
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from zentf.transport.buffer import Buffer  # noqa: E402
from zentf.core.exceptions import TransformException  # noqa: E402
from zentf.core.time import Duration, Time  # noqa: E402
from zentf.transport.listener import TransformListener  # noqa: E402
from zentf.transport.node import Node  # noqa: E402
from zentf.transport.options import NodeOptions, add_node_arguments  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(prog="bag_sim_listener")
    add_node_arguments(parser)
    parser.add_argument("--until", type=int, required=True)
    parser.add_argument("--queries", required=True)
    parser.add_argument("--timeout", type=float, default=120.0)
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    opts = NodeOptions.from_args(args, parser=parser)
    node = Node(opts.name or "bag_sim_listener", options=opts, check_unique=False)
    try:
        buffer = Buffer(cache_time=Duration(nanoseconds=300 * 10**9))  # the whole 97 s run
        listener = TransformListener(buffer, node)  # noqa: F841
        clock = node.get_clock()
        print(json.dumps({"ready": True, "sim": clock.ros_time_is_active}), flush=True)
        if not clock.sleep_until(Time(nanoseconds=args.until), timeout=args.timeout):
            print(json.dumps({"error": f"sim time stayed at {clock.now_ns()} ns"}), flush=True)
            return 1
        out = []
        for target, source, stamp in json.loads(Path(args.queries).read_text()):
            try:
                ts = buffer.lookup_transform(target, source, Time(nanoseconds=stamp))
                tr, q = ts.transform.translation, ts.transform.rotation
                out.append([tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w])
            except TransformException as e:
                out.append(type(e).__name__)
        print(json.dumps({"at": clock.now_ns(), "answers": out}), flush=True)
        return 0
    finally:
        node.shutdown()


if __name__ == "__main__":
    sys.exit(main())
