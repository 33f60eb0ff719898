"""End-to-end tf across "machines": host a -> router -> host b in network namespaces (veth links),
side by side with the same three processes on plain loopback, measured in the same run.

    sudo python bench/netns.py [--n-lat 1000] [--seconds 3] [--batch 100]

Each setup runs a router (``zentf router``), a receiver (TransformListener into a Buffer) and a
sender (TransformBroadcaster's publisher), all Zenoh clients of the router (configs/zenoh/client.json5).
Latency: one transform every ~1 ms; one-way time from just before publishing to the moment the
receiver's Buffer has it (insert callback; CLOCK_REALTIME is shared by all namespaces of a host).
Throughput: the sender publishes pre-encoded TFMessages of ``--batch`` transforms as fast as it can
for ``--seconds``; the rate is transforms accepted by the receiver's Buffer per second.
Needs root for the namespaces (the loopback column runs anyway).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))

CLIENT = str(REPO / "configs/zenoh/client.json5")
NS = "bench_net"


def tf_dict(child: str, stamp_ns: int, x: float = 1.0) -> dict:
    return {"header": {"stamp": {"sec": stamp_ns // 1_000_000_000, "nanosec": stamp_ns % 1_000_000_000},
                       "frame_id": "world"}, "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": 0.0, "z": 0.0},
                          "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}


def _node(name: str, endpoint: str):
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions, ZenohOptions

    zopts = ZenohOptions(config_file=CLIENT, connect=[endpoint], mode="client", no_multicast=True)
    return Node(name, options=NodeOptions(namespace=NS, zenoh=zopts), check_unique=False)


def receiver(args: argparse.Namespace) -> None:
    """Print 'ready', then one JSON result line when the sender's 'done' marker (child 'end') arrives."""
    from zentf.transport.buffer import Buffer
    from zentf.transport.listener import TransformListener
    from zentf.core.time import Time

    node = _node("bench_recv", args.endpoint)
    buffer = Buffer(cache_time=60.0)
    lat: list[int] = []
    lock = threading.Lock()
    seen: set[int] = set()
    state = {"first": 0, "last": 0, "end": threading.Event()}
    listener = TransformListener(buffer, node)

    def on_insert() -> None:
        now = time.time_ns()
        if args.kind == "lat":
            try:
                stamp = buffer.lookup_transform("world", "probe", Time()).header.stamp.nanoseconds
            except Exception:
                return
            with lock:
                if stamp not in seen:
                    seen.add(stamp)
                    lat.append(stamp)
                    lat.append(now)
            if buffer.can_transform("world", "end", Time()):
                state["end"].set()
        elif buffer.can_transform("world", "end", Time()):
            state["end"].set()
        else:  # the span ends at the last data message, not at the end marker
            state["first"] = state["first"] or now
            state["last"] = now

    buffer.add_insert_callback(on_insert)
    print("ready", flush=True)
    state["end"].wait(args.timeout)
    stats = listener.stats()
    if args.kind == "lat":
        pairs = list(zip(lat[0::2], lat[1::2]))
        out = {"lat_us": [(r - s) / 1000 for s, r in pairs]}
    else:
        span = max(state["last"] - state["first"], 1) / 1e9
        out = {"transforms": stats["transforms"], "seconds": span}
    print(json.dumps(out), flush=True)
    node.shutdown()


def sender(args: argparse.Namespace) -> None:
    from zentf.transport.broadcaster import TransformBroadcaster
    from zentf.transport.wire import codec as wire

    node = _node("bench_send", args.endpoint)
    pub = TransformBroadcaster(node)._pub
    time.sleep(0.5)  # the receiver's subscription reaches this client through the router
    if args.kind == "lat":
        for i in range(args.n_lat):
            pub.publish_bytes(wire.encode_tf([tf_dict("probe", time.time_ns(), float(i))]))
            time.sleep(0.001)
    else:
        # every message new stamps (a Buffer ignores repeats): patch them into one template cheaply
        template = [tf_dict(f"f{j}", 0) for j in range(args.batch)]
        stamps = [t["header"]["stamp"] for t in template]
        deadline = time.monotonic() + args.seconds
        i = 0
        while time.monotonic() < deadline:
            ns = time.time_ns()
            for st in stamps:
                st["sec"], st["nanosec"] = divmod(ns, 1_000_000_000)
            pub.publish_bytes(wire.pack({"transforms": template}))
            i += 1
        print(json.dumps({"sent": i * args.batch}), flush=True)
    time.sleep(0.2)
    for _ in range(5):
        pub.publish_bytes(wire.encode_tf([tf_dict("end", time.time_ns())]))
        time.sleep(0.05)
    node.shutdown()


def _die_with_parent() -> None:  # runs in the child before exec: SIGTERM when this bench dies
    import ctypes
    import signal

    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except Exception:
        pass


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _spawn(prefix: list[str], *argv: str) -> subprocess.Popen:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PYTHONUNBUFFERED="1", PYTHONPATH=str(REPO))
    return subprocess.Popen([*prefix, sys.executable, *argv], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            text=True, env=env, cwd=str(REPO), preexec_fn=_die_with_parent)


def _expect(p: subprocess.Popen, word: str, timeout: float = 30) -> str:
    deadline = time.monotonic() + timeout
    assert p.stdout is not None
    while time.monotonic() < deadline:
        line = p.stdout.readline()
        if not line:
            break
        if word in line:
            return line
    raise RuntimeError(f"no '{word}' from {p.args}")


def run_case(setup: str, kind: str, args: argparse.Namespace, net=None) -> dict:
    """One router + receiver + sender run; ``net`` = a Topology for the namespace setup."""
    if net is None:
        ep_a = ep_b = f"tcp/127.0.0.1:{free_port()}"
        where = {"r": [], "a": [], "b": []}
        router_args = ["-m", "zentf.cli", "router", "--listen", ep_a, "--no-multicast"]
    else:
        ep_a, ep_b = f"tcp/{net.router_ip('a')}:7447", f"tcp/{net.router_ip('b')}:7447"
        where = {h: net.cmd(h) for h in ("r", "a", "b")}
        router_args = ["-m", "zentf.cli", "router", "--config", str(REPO / "configs/zenoh/router.json5")]
    common = ["--kind", kind, "--n-lat", str(args.n_lat), "--seconds", str(args.seconds), "--batch",
              str(args.batch)]
    procs = []
    try:
        router = _spawn(where["r"], *router_args)
        procs.append(router)
        _expect(router, "listening")
        recv = _spawn(where["b"], __file__, "--role", "recv", "--endpoint", ep_b, *common)
        procs.append(recv)
        _expect(recv, "ready")
        send = _spawn(where["a"], __file__, "--role", "send", "--endpoint", ep_a, *common)
        procs.append(send)
        return json.loads(_expect(recv, "{", args.seconds + args.n_lat / 500 + 60))
    finally:
        for p in reversed(procs):
            p.terminate()
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                p.kill()


def pct(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))] if s else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--role", default="main", choices=["main", "recv", "send"])
    ap.add_argument("--kind", default="lat", choices=["lat", "thr"])
    ap.add_argument("--endpoint")
    ap.add_argument("--n-lat", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--batch", type=int, default=100)
    ap.add_argument("--timeout", type=float, default=120.0)
    args = ap.parse_args()
    if args.role == "recv":
        return receiver(args)
    if args.role == "send":
        return sender(args)

    from netns_topology import Topology, unavailable_reason

    results: dict[str, dict] = {}
    for kind in ("lat", "thr"):
        results.setdefault("loopback", {})[kind] = run_case("loopback", kind, args)
    reason = unavailable_reason()
    if reason is None:
        with Topology(["a", "b"]) as net:
            for kind in ("lat", "thr"):
                results.setdefault("netns", {})[kind] = run_case("netns", kind, args, net)
    else:
        print(f"(netns column skipped: {reason})")

    def row(name: str, f) -> None:
        vals = {s: f(r) for s, r in results.items()}
        lo = vals.get("loopback")
        ns = vals.get("netns")
        ratio = f"{ns / lo:.2f}x" if lo and ns else "-"
        print(f"{name:<34} {lo:>12.1f} {ns if ns is not None else float('nan'):>12.1f} {ratio:>8}")

    print(f"host a -> router -> host b, zentf tf ({args.n_lat} single transforms at ~1 kHz; "
          f"{args.seconds:g} s of {args.batch}-transform messages)")
    print(f"{'':<34} {'loopback':>12} {'netns+veth':>12} {'ratio':>8}")
    for q in (0.5, 0.9, 0.99):
        row(f"latency p{int(q * 100)} (us)", lambda r, q=q: pct(r["lat"]["lat_us"], q))
    row("latency mean (us)", lambda r: statistics.fmean(r["lat"]["lat_us"]) if r["lat"]["lat_us"] else float("nan"))
    row("received of sent (latency run, %)", lambda r: 100.0 * len(r["lat"]["lat_us"]) / args.n_lat)
    row("throughput (k transforms/s)", lambda r: r["thr"]["transforms"] / r["thr"]["seconds"] / 1000)


if __name__ == "__main__":
    main()
