"""A client with a valid certificate whose name is in no role of configs/zenoh/router-acl.json5, trying what
the access-control tests say it must not do (raw Zenoh, what anyone with a certificate can write):

    python tests/acl_intruder.py ENDPOINT NAMESPACE [--period 0.2]

Every period it puts a forged ``world -> tower`` (x = 666, zentf wire) and ``world -> tower2`` (ROS 2 wire)
and a Clock of 666 s on wildcard keys (``**``, ``t$*``, ``clo$*``, ``<ns>/**``...), queries the sim clock's
control with wildcards (``@zentf/*/control``...) with ``pause`` and ``rate 100`` and parameter services with
wildcards, and reads the graph: a ``**`` subscription, liveliness subscribers and queries on ``@zentf/**``,
``@ros2_lv/**`` and ``**``. One JSON line per period: ``{"puts": n, "queries": n, "samples": n,
"replies": n, "tokens": n}`` (samples, replies and tokens are what reached it from others).
Run in a directory whose certs/ holds its certificate (tests/security_helpers.py).
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

from zentf.core.messages import Clock, TFMessage  # noqa: E402
from zentf.ros import encode_tf  # noqa: E402
from zentf.transport.wire import codec as wire  # noqa: E402
from zentf.transport.wire.profiles import make_profile  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
MARK = b"acl_intruder"


def _tf(child: str) -> list[dict]:
    return [{"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "world"}, "child_frame_id": child,
             "transform": {"translation": {"x": 666.0, "y": 0.0, "z": 0.0},
                           "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}]


def main() -> int:
    ap = argparse.ArgumentParser(prog="acl_intruder")
    ap.add_argument("endpoint")
    ap.add_argument("namespace")
    ap.add_argument("--period", type=float, default=0.2)
    ap.add_argument("--watch", action="store_true",
                    help="be a listed listener instead: subscribe to NAMESPACE/tf, /tf_static and clock (both wires) "
                         "and count the samples that arrive on wildcard keys ({\"wildcard\": n, \"samples\": n})")
    args = ap.parse_args()
    ns = args.namespace.strip("/")
    cfg = zenoh.Config.from_file(str(REPO / "configs/zenoh/client-tls.json5"))
    cfg.insert_json5("connect/endpoints", json.dumps([args.endpoint]))
    for key, file in (("root_ca_certificate", "ca.pem"), ("connect_certificate", "client.pem"),
                      ("connect_private_key", "client.key")):
        cfg.insert_json5(f"transport/link/tls/{key}", json.dumps(str(Path.cwd() / "certs" / file)))
    session = zenoh.open(cfg)
    lock = threading.Lock()
    counts = {"puts": 0, "queries": 0, "samples": 0, "replies": 0, "tokens": 0}

    def seen(what: str) -> None:
        with lock:
            counts[what] += 1

    def on_sample(sample: zenoh.Sample) -> None:
        if sample.attachment is None or sample.attachment.to_bytes() != MARK:
            seen("samples")

    if args.watch:
        def on_watched(sample: zenoh.Sample) -> None:
            seen("samples")
            if "*" in str(sample.key_expr):
                seen("wildcard")

        counts["wildcard"] = 0
        tf2 = "tf2_msgs::msg::dds_::TFMessage_/*"
        keys = (f"{ns}/tf", f"{ns}/tf_static", "clock", f"0/{ns}/tf/{tf2}", f"0/{ns}/tf_static/{tf2}",
                "0/clock/rosgraph_msgs::msg::dds_::Clock_/*")
        watched = [session.declare_subscriber(k, on_watched) for k in keys]  # noqa: F841 (kept alive)
        while True:
            time.sleep(args.period)
            with lock:
                print(json.dumps({"wildcard": counts["wildcard"], "samples": counts["samples"]}), flush=True)
    subs = [session.declare_subscriber("**", on_sample),
            *(session.liveliness().declare_subscriber(k, lambda s: seen("tokens"), history=True)
              for k in ("**", "@zentf/**", "@ros2_lv/**"))]
    zentf_tf = wire.encode(TFMessage.from_dict({"transforms": _tf("tower")}))
    tf_enc = wire.encoding_for(TFMessage.TYPE_NAME)
    ros2_tf = encode_tf(_tf("tower2"))
    clock = Clock.from_dict({"clock": {"sec": 666, "nanosec": 0}})
    zentf_clock, clock_enc = wire.encode(clock), wire.encoding_for(Clock.TYPE_NAME)
    ros2_clock = make_profile("ros2").encode(clock, Clock.TYPE_NAME)
    puts = [  # (key, payload, encoding)
        *((k, zentf_tf, tf_enc) for k in ("**", "t$*", "*", f"{ns}/**", f"{ns}/t$*", f"{ns}/*", "**/tf",
                                          "**/tf_static")),
        *((k, ros2_tf, None) for k in ("**", "0/**", f"0/{ns}/t$*/**", f"0/{ns}/tf/*/*", f"0/{ns}/tf_static/**")),
        *((k, zentf_clock, clock_enc) for k in ("**", "clo$*", "*", "**/clock")),
        *((k, ros2_clock, None) for k in ("0/clo$*/**", "0/clock/*/*")),
    ]
    queries = [f"@zentf/{k}/control" for k in ("*", "clo$*", "**")] + ["@zentf/**", "**"] + \
              [f"{ns}/{k}" for k in ("*/set_parameters", "**/set_parameters", "**", "*/$*_parameters")]
    while True:
        for key, payload, enc in puts:
            session.put(key, payload, encoding=enc, attachment=MARK)
        for key in queries:
            for command in (b"pause", b"rate 100"):
                for reply in session.get(key, payload=command, timeout=args.period / 4):
                    if reply.ok is not None or not _timed_out(reply):  # an answer, or an error from a server
                        seen("replies")
        for key in ("**", "@zentf/**", "@ros2_lv/**"):
            for reply in session.liveliness().get(key, timeout=args.period / 4):
                if reply.ok is not None:
                    seen("tokens")
        with lock:
            counts["puts"] += len(puts)
            counts["queries"] += 2 * len(queries)
            print(json.dumps(counts), flush=True)
        time.sleep(args.period)
    return 0  # pragma: no cover - runs until stopped (subs kept alive above)


def _timed_out(reply) -> bool:
    """Zenoh's own error reply when a query's timeout passes before the router said it was done (a loaded
    machine): nobody answered it."""
    try:
        return reply.err.payload.to_string() == "Timeout"
    except Exception:  # noqa: BLE001
        return False


if __name__ == "__main__":
    sys.exit(main())
