"""BufferServer bench: N BufferClient processes against N full TransformListener processes, same tf load.

    python bench/buffer_server.py [--clients 20] [--frames 1000] [--rate 100] [--lookup-rate 100]
                                  [--duration 10] [--warmup 3]

One publisher sends ``--frames`` transforms (a tree of depth ~5 under ``world``) at ``--rate`` Hz on
``tf`` through a router (every process is a Zenoh client of it). Phase 1: one ``buffer_server`` node
(it alone subscribes to ``tf``) and ``--clients`` BufferClient processes, each looking up a random
leaf in ``world`` at ``--lookup-rate`` Hz. Phase 2: ``--clients`` processes each with its own Buffer
and TransformListener (what tf2_ros users do by default), each doing the same lookups locally.
CPU = utime + stime from /proc/<pid>/stat of every process of the set over the measured window
(% of one core); lookup latency = wall time of one ``lookup_transform`` call as the caller sees it.
Noisy on a shared machine: compare the rows of one run.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

NS = 1_000_000_000
TICK = os.sysconf("SC_CLK_TCK")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def parent_of(i: int) -> str:
    return "world" if i == 0 else f"f{(i - 1) // 4}"


def leaves(frames: int) -> list[str]:
    return [f"f{i}" for i in range(frames) if 4 * i + 1 >= frames]


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process (all its threads) from /proc/<pid>/stat."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def node_options(endpoint: str, name: str):
    from zentf.transport.options import NodeOptions, ZenohOptions

    return NodeOptions(name=name, namespace="bench_bs",
                       zenoh=ZenohOptions(connect=[endpoint], mode="client", no_multicast=True))


# ------------------------------------------------------------------ children

def run_publisher(a: argparse.Namespace) -> None:
    from zentf.transport.broadcaster import TransformBroadcaster
    from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
    from zentf.core.time import Time
    from zentf.transport.node import Node

    node = Node(options=node_options(a.endpoint, "bench_tf_pub"))
    br = TransformBroadcaster(node)
    msgs = [TransformStamped(Header(Time(), parent_of(i)), f"f{i}",
                             Transform(Vector3(0.1 * (i % 7), 0.2, 0.3), Quaternion(0.0, 0.0, 0.0, 1.0)))
            for i in range(a.frames)]
    print("ready", flush=True)
    period = 1.0 / a.rate
    nxt = time.monotonic()
    sent = 0
    while time.time() < a.stop_at:
        now = Time(nanoseconds=time.time_ns())
        for m in msgs:
            m.header.stamp = now
        br.send_transform(msgs)  # blocks while the network is congested (tf is a BLOCK publisher)
        if a.start_at <= time.time() < a.stop_at - 1:
            sent += 1
        nxt += period
        time.sleep(max(0.0, nxt - time.monotonic()))
    print("RESULT " + json.dumps({"sent": sent}), flush=True)
    node.shutdown()


def _lookups(a: argparse.Namespace, lookup, received=lambda: 0) -> None:
    """Look up a random leaf in world at the lookup rate; latencies (and tf messages received) inside
    the measured window."""
    rng = random.Random(os.getpid())
    names = leaves(a.frames)
    lat: list[int] = []
    ok = failed = 0
    period = 1.0 / a.lookup_rate
    print("ready", flush=True)
    nxt = time.monotonic()
    r0 = None
    while time.time() < a.stop_at:
        if r0 is None and time.time() >= a.start_at:
            r0 = received()
        frame = rng.choice(names)
        t0 = time.perf_counter_ns()
        try:
            lookup(frame)
            good = True
        except Exception:
            good = False
        dt = time.perf_counter_ns() - t0
        if time.time() >= a.start_at:
            lat.append(dt)
            ok += good
            failed += not good
        nxt += period
        time.sleep(max(0.0, nxt - time.monotonic()))
    tf = received() - (r0 or 0)
    print("RESULT " + json.dumps({"lat": lat, "ok": ok, "failed": failed, "tf": tf}), flush=True)


def run_client(a: argparse.Namespace) -> None:
    from zentf.transport.buffer_server import BufferClient
    from zentf.core.time import Time
    from zentf.transport.node import Node

    node = Node(options=node_options(a.endpoint, f"bench_client_{os.getpid()}"), start_parameter_services=False)
    client = BufferClient(node)
    client.wait_for_server(30)
    _lookups(a, lambda f: client.lookup_transform("world", f, Time()))
    node.shutdown()


def run_listener(a: argparse.Namespace) -> None:
    from zentf.transport.buffer import Buffer
    from zentf.core.time import Time
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node

    node = Node(options=node_options(a.endpoint, f"bench_listener_{os.getpid()}"), start_parameter_services=False)
    buffer = Buffer()
    listener = TransformListener(buffer, node)
    _lookups(a, lambda f: buffer.lookup_transform("world", f, Time()), lambda: listener.messages)
    node.shutdown()


def run_server(a: argparse.Namespace) -> None:
    from zentf.transport.buffer import Buffer
    from zentf.transport.buffer_server import BufferServer
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node

    node = Node(options=node_options(a.endpoint, "tf2_buffer_server"), start_parameter_services=False)
    buffer = Buffer(node=node)
    listener = TransformListener(buffer, node)
    server = BufferServer(buffer, node)
    print("ready", flush=True)
    time.sleep(max(0.0, a.start_at - time.time()))
    r0, q0 = listener.messages, server.requests
    time.sleep(max(0.0, a.stop_at - 1 - time.time()))
    print("RESULT " + json.dumps({"requests": server.requests - q0, "tf": listener.messages - r0}), flush=True)
    while time.time() < a.stop_at:
        time.sleep(0.2)
    node.shutdown()


# ------------------------------------------------------------------ orchestration

def child(role: str, a: argparse.Namespace, start_at: float, stop_at: float) -> subprocess.Popen:
    args = [sys.executable, __file__, "--role", role, "--endpoint", a.endpoint, "--frames", str(a.frames),
            "--rate", str(a.rate), "--lookup-rate", str(a.lookup_rate), "--start-at", repr(start_at),
            "--stop-at", repr(stop_at)]
    env = {**os.environ, "PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env,
                            stdin=subprocess.DEVNULL)


def wait_line(p: subprocess.Popen, prefix: str, timeout: float) -> str:
    deadline = time.monotonic() + timeout
    assert p.stdout is not None
    while time.monotonic() < deadline:
        line = p.stdout.readline()
        if not line:
            raise RuntimeError(f"child {p.args[3]} exited (rc={p.wait()}) before '{prefix}'")
        if line.startswith(prefix):
            return line
    raise RuntimeError(f"child {p.args[3]} gave no '{prefix}' within {timeout} s")


def phase(a: argparse.Namespace, router_pid: int, mode: str) -> dict:
    """Start the set, let it warm up, measure CPU of every process over the window, collect latencies."""
    startup = 20.0 + 1.5 * a.clients  # 2 shared cores: many interpreters take a while to start
    t_start = time.time() + startup + a.warmup
    t_stop = t_start + a.duration
    procs: dict[str, list[subprocess.Popen]] = {"publisher": [child("publisher", a, t_start, t_stop + 1)]}
    if mode == "server":
        procs["server"] = [child("server", a, t_start, t_stop + 1)]
        wait_line(procs["server"][0], "ready", startup)
    procs["lookup"] = [child("client" if mode == "server" else "listener", a, t_start, t_stop)
                       for _ in range(a.clients)]
    try:
        for key, group in procs.items():
            for p in group:
                if key != "server":  # (the server was awaited before the clients started)
                    wait_line(p, "ready", startup)
        if time.time() > t_start:
            raise RuntimeError("start-up took longer than planned: raise --warmup")
        time.sleep(max(0.0, t_start - time.time()))
        pids = {k: [p.pid for p in g] for k, g in procs.items()}
        c0 = {k: sum(cpu_seconds(pid) for pid in v) for k, v in pids.items()}
        r0 = cpu_seconds(router_pid)
        w0 = time.monotonic()
        time.sleep(max(0.0, t_stop - time.time()))
        wall = time.monotonic() - w0
        c1 = {k: sum(cpu_seconds(pid) for pid in v) for k, v in pids.items()}
        router = (cpu_seconds(router_pid) - r0) / wall * 100
        cpu = {k: (c1[k] - c0[k]) / wall * 100 for k in c0}
        lat: list[int] = []
        ok = failed = 0
        tf: list[int] = []
        for p in procs["lookup"]:
            r = json.loads(wait_line(p, "RESULT ", 60 + a.duration)[7:])
            lat += r["lat"]
            ok += r["ok"]
            failed += r["failed"]
            tf.append(r["tf"])
        if mode == "server":
            tf = [json.loads(wait_line(procs["server"][0], "RESULT ", 60)[7:])["tf"]]
        sent = json.loads(wait_line(procs["publisher"][0], "RESULT ", 60)[7:])["sent"]
        return {"cpu": cpu, "router": router, "lat": sorted(lat), "ok": ok, "failed": failed,
                "tf_in": statistics.mean(tf) / a.duration, "tf_out": sent / a.duration}
    finally:
        for group in procs.values():
            for p in group:
                if p.poll() is None:
                    p.terminate()
        for group in procs.values():
            for p in group:
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(5)


def pct(values: list[int], q: float) -> float:
    if not values:
        return float("nan")
    return values[min(len(values) - 1, int(q * len(values)))] / 1000.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=20, help="BufferClient processes = listener processes")
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--rate", type=float, default=100.0, help="tf publish rate (Hz)")
    ap.add_argument("--lookup-rate", type=float, default=100.0, help="lookups per second per process")
    ap.add_argument("--duration", type=float, default=10.0, help="measured seconds per phase")
    ap.add_argument("--warmup", type=float, default=3.0)
    ap.add_argument("--role", choices=("publisher", "server", "client", "listener"), help=argparse.SUPPRESS)
    ap.add_argument("--endpoint", help=argparse.SUPPRESS)
    ap.add_argument("--start-at", type=float, default=0.0, help=argparse.SUPPRESS)
    ap.add_argument("--stop-at", type=float, default=0.0, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.role:
        {"publisher": run_publisher, "server": run_server, "client": run_client,
         "listener": run_listener}[a.role](a)
        return
    a.endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = subprocess.Popen([sys.executable, "-m", "zentf.transport.router", "--listen", a.endpoint, "--no-multicast"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              env={**os.environ, "PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1"})
    try:
        wait_line(router, "", 30)  # its first line says where it listens
        res = {"server": phase(a, router.pid, "server"), "listeners": phase(a, router.pid, "listeners")}
    finally:
        router.terminate()
        router.wait(10)
    s, li = res["server"], res["listeners"]
    s_total = s["cpu"]["server"] + s["cpu"]["lookup"]
    l_total = li["cpu"]["lookup"]
    print(f"# zentf buffer server bench  (python {sys.version.split()[0]}, {os.cpu_count()} cpus; "
          f"{a.frames} frames at {a.rate:g} Hz on tf, {a.clients} processes looking up at {a.lookup_rate:g} Hz, "
          f"{a.duration:g} s measured)")
    print()
    want = a.clients * a.lookup_rate * a.duration
    print("| set | CPU of the set (% of one core) | lookup p50 (µs) | lookup p99 (µs) | lookups ok / failed "
          f"(of {want:.0f} asked) | tf msgs/s sent / received per tf subscriber |")
    print("|---|---|---|---|---|---|")
    print(f"| 1 buffer_server + {a.clients} BufferClients | {s_total:.0f} (server {s['cpu']['server']:.0f}, "
          f"clients {s['cpu']['lookup']:.0f}) | {pct(s['lat'], 0.5):.0f} | {pct(s['lat'], 0.99):.0f} | "
          f"{s['ok']} / {s['failed']} | {s['tf_out']:.0f} / {s['tf_in']:.0f} |")
    print(f"| {a.clients} TransformListeners (reference: tf2_ros default) | {l_total:.0f} | "
          f"{pct(li['lat'], 0.5):.0f} | {pct(li['lat'], 0.99):.0f} | {li['ok']} / {li['failed']} | "
          f"{li['tf_out']:.0f} / {li['tf_in']:.0f} |")
    ratio = l_total / s_total if s_total > 0 else float("nan")
    print(f"| ratio listeners / server set | {ratio:.1f}x | "
          f"{pct(li['lat'], 0.5) / pct(s['lat'], 0.5):.2f}x | | | |")
    print()
    print(f"Outside the sets: tf publisher {s['cpu']['publisher']:.0f}% / {li['cpu']['publisher']:.0f}%, "
          f"router {s['router']:.0f}% / {li['router']:.0f}% (server phase / listener phase).")
    print("Noisy on a shared machine; compare the rows of one run, not runs with each other.")


if __name__ == "__main__":
    main()
