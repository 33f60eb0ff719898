"""A stranger on the LAN for the network-safety tests: a plain ``zenoh.Config()`` session (peer mode,
multicast scouting, every interface: what anyone gets with two lines of Python).

    python tests/net_intruder.py PARENT CHILD X [--period 0.2]

It subscribes to everything (``**``), asks for zentf's liveliness tokens (``@zentf/**``), and puts a forged
``PARENT -> CHILD`` transform with translation x = X on ``tf_static`` and ``tf`` every period.
One JSON line per period: ``{"samples": n, "tokens": n, "puts": n, "peers": n}`` (samples and
tokens from others; peers = Zenoh sessions it is linked to).
"""
from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import zenoh  # noqa: E402

from zentf.transport.wire import codec as wire  # noqa: E402
from zentf.core.messages import TFMessage  # noqa: E402


MARK = b"net_intruder"


def main() -> int:
    parser = argparse.ArgumentParser(prog="net_intruder")
    parser.add_argument("parent")
    parser.add_argument("child")
    parser.add_argument("x", type=float)
    parser.add_argument("--period", type=float, default=0.2)
    args = parser.parse_args()
    session = zenoh.open(zenoh.Config())
    lock = threading.Lock()
    counts = {"samples": 0, "tokens": 0, "puts": 0}

    def on_sample(sample: zenoh.Sample) -> None:
        if sample.attachment is not None and sample.attachment.to_bytes() == MARK:
            return  # our own put
        with lock:
            counts["samples"] += 1

    session.declare_subscriber("**", on_sample)
    forged = TFMessage.from_dict({"transforms": [{
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": args.parent},
        "child_frame_id": args.child,
        "transform": {"translation": {"x": args.x, "y": 0.0, "z": 0.0},
                      "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}]})
    payload = wire.encode(forged)
    encoding = wire.encoding_for(TFMessage.TYPE_NAME)
    mine = session.zid()
    while True:
        for key in ("tf_static", "tf"):
            session.put(key, payload, encoding=encoding, attachment=MARK)
        with lock:
            counts["puts"] += 2
        tokens = sum(1 for r in session.liveliness().get("@zentf/**", timeout=max(0.05, args.period / 2)) if r.ok)
        with lock:
            counts["tokens"] = tokens
            info = session.info
            peers = len([z for z in (*info.peers_zid(), *info.routers_zid()) if str(z) != str(mine)])
            print(json.dumps({**counts, "peers": peers}), flush=True)
        time.sleep(args.period)


if __name__ == "__main__":
    sys.exit(main())
