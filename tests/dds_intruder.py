"""A stranger on the LAN for the DDS bridge's network-safety test: a Cyclone DDS participant on the
namespace's ``lan0`` (multicast discovery, and unicast to PEER), what any DDS node on the robot's network is.

    python tests/dds_intruder.py DOMAIN PEER [--period 0.2]

It watches the participants it discovers and writes a forged ``intruder_parent -> intruder_child``
transform on ``rt/tf`` every period (an ordinary, unmarked writer). One JSON line per period:
``{"bridge_seen": bool, "participants": n, "writes": n}`` (bridge_seen: a participant with the zentf
bridge's USER_DATA mark).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from zentf.ros import encode_tf  # noqa: E402
from zentf.tools.dds.cyclone import BRIDGE_MARK, DdsDomain, TopicQos  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("domain", type=int)
    ap.add_argument("peer")
    ap.add_argument("--period", type=float, default=0.2)
    args = ap.parse_args()
    d = DdsDomain(args.domain, lan=True, peers=[args.peer], interfaces=["lan0"], mark=False)
    w = d.writer("rt/tf", "tf2_msgs/msg/TFMessage", TopicQos(depth=100), mark=False)
    forged = encode_tf([{"header": {"stamp": {"sec": 1, "nanosec": 0}, "frame_id": "intruder_parent"},
                         "child_frame_id": "intruder_child",
                         "transform": {"translation": {"x": 666.0, "y": 0.0, "z": 0.0},
                                       "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}])
    participants: dict[bytes, bytes] = {}
    writes = 0
    try:
        while True:
            end = time.monotonic() + args.period
            while time.monotonic() < end:
                d.wait(max(0.0, end - time.monotonic()))
                seen, gone = d.take_participants()
                for p in seen:
                    participants[p.guid] = p.user_data
                for g in gone:
                    participants.pop(g, None)
                d.take_endpoints()
            w.write(forged)
            writes += 1
            others = {g: u for g, u in participants.items() if g != d.guid}
            print(json.dumps({"bridge_seen": any(BRIDGE_MARK in u for u in others.values()),
                              "participants": len(others), "writes": writes}), flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        d.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
