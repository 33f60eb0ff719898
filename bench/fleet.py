"""A fleet through routers: R robots x F frames at H Hz, each robot under its own namespace, side by side
with the same traffic as raw Zenoh puts through the same routers, measured in the same run.

    python bench/fleet.py [--robots 1,10,50,100] [--frames 50] [--hz 30] [--seconds 5] [--procs 2]
                          [--netns] [--wire zentf|ros2] [--raw-ring] [--raw-as-zentf] [--quick] [--json FILE]
                          [--tree DIR]

Every row starts fresh processes, once for zentf and once for raw Zenoh (which first alternates from
row to row):
- the router: one ``zentf router`` on loopback; with ``--netns`` (root) two routers in network
  namespaces, as bench/netns.py does: robots -> their host's router (host a) -> veth -> a central
  router (namespace r) -> veth -> the listeners (host b);
- the robots: robot i is a node in namespace ``robot<i>`` (its own Zenoh session, a client of the
  router) whose TransformBroadcaster sends one TFMessage of F transforms (``robot<i>/base_link`` ->
  ``robot<i>/link_<j>``, a joint turning) every 1/H s, the robots spread evenly over the period.
  The machine has 2 cores, so the robots share ``--procs`` processes (several robots per process, one
  sending thread each), not a process per robot; raw: the same payload bytes (+ a 12-byte stamp and
  robot id) put by a bare session per robot on the same key;
- a per-robot listener (TransformListener on ``/robot0/tf``; raw: a bare callback subscriber on that
  key) and a fleet-wide listener (TransformListener with ``tf_topic="/*/tf"``, what ``--all-namespaces``
  reads; raw: a callback subscriber on ``*/tf``), each a process of its own.
After a warm-up the bench samples each process (CPU from /proc/PID/task/*/schedstat, RSS, the TCP bytes
its sockets received from ``ss -tinp``) and the listeners' counters at the start and end of a ``--seconds``
window; the fleet Buffer's own storage (``memory_bytes()``, a walk under the buffer's lock) after it.
Columns: the per-robot listener's CPU (ms a second) and bytes received (kB/s) must stay flat as R grows
(it receives only its robot); the fleet listener's ingest (transforms/s accepted by its Buffer) and
CPU; the routers' CPU per transform sent; memory per robot (robot processes, routers, the fleet
listener: RSS growth over the process before the robots, divided by R); e2e one-way latency p50/p99
(stamp taken just before encoding to the Buffer's insert callback, robot 0's messages, at both
listeners; the callback does one get_latest_common_time, which the fleet listener pays on every
robot's message); and ``sent`` = messages sent in the window over R x H x seconds (< 100 %: the
robot processes could not keep up). The ratio line is zentf / raw. ``--raw-ring``: the raw listeners
read a drop-oldest ring from a Python thread, the listener's way of receiving, instead of a callback on
Zenoh's thread (to tell a thread hand-off's latency from zentf's own). ``--raw-as-zentf``: the raw robots' puts
carry what zentf's do besides the payload (the node's name as attachment, or rmw_zenoh's attachment, the
wire's encoding, congestion control BLOCK), to tell what the routers pay for those from the rest. ``--tree DIR``: every process
imports zentf from another checkout (before/after runs). Results and details: docs/performance.md.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import select
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "bench"))
sys.path.insert(0, str(REPO / "tests"))

from netns import _die_with_parent, free_port  # noqa: E402  (bench/netns.py's helpers)

sys.path.insert(0, os.environ.get("FLEET_BENCH_TREE") or str(REPO))  # (--tree, in the child processes)

ROUTER_CONF = str(REPO / "configs/zenoh/router.json5")
NS = 1_000_000_000
TREE = str(REPO)  # the zentf the children import (--tree: another checkout, for before/after runs)
PREFIX = struct.Struct("<qI")  # raw payloads: send time (ns, CLOCK_REALTIME), robot id


def rss_kb(pid: int | str = "self") -> int:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def cpu_ns(pid: int) -> int:
    """CPU time of a process's live threads, ns (schedstat: finer than /proc/PID/stat's 10 ms ticks)."""
    total = 0
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except FileNotFoundError:
        return 0
    for tid in tasks:
        try:
            with open(f"/proc/{pid}/task/{tid}/schedstat") as f:
                total += int(f.read().split()[0])
        except (FileNotFoundError, ProcessLookupError, ValueError):
            pass
    return total


def tcp_received(prefix: list[str]) -> dict[int, int]:
    """Bytes received by each process's TCP sockets (pid -> sum of ss's bytes_received), in the network
    namespace ``prefix`` runs in (/proc/PID/io's rchar does not count socket receives)."""
    out = subprocess.run([*prefix, "ss", "-tinp"], capture_output=True, text=True, timeout=20).stdout
    totals: dict[int, int] = {}
    pids: list[int] = []
    for line in out.splitlines():
        if not line.startswith((" ", "\t")):
            pids = [int(p) for p in re.findall(r"pid=(\d+)", line)]
            continue
        m = re.search(r"bytes_received:(\d+)", line)
        if m:
            for pid in set(pids):
                totals[pid] = totals.get(pid, 0) + int(m.group(1))
    return totals


def _zopts(endpoint: str):
    from zentf.transport.options import ZenohOptions

    # zentf's own defaults (no config file: its receive pool and loopback-only rules apply), as a robot's
    # `--connect EP --mode client` gets them
    return ZenohOptions(connect=[endpoint], mode="client", no_multicast=True)


def _node(name: str, namespace: str, args: argparse.Namespace):
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions

    return Node(name, options=NodeOptions(namespace=namespace, zenoh=_zopts(args.endpoint), wire=args.wire),
                check_unique=False)


def _commands():
    """Lines from the main process (stdin); EOF ends the child."""
    for line in sys.stdin:
        yield line.strip()


def _reply(obj: dict) -> None:
    print(json.dumps(obj), flush=True)


def percentiles(lat_ns: list[int]) -> dict:
    s = sorted(lat_ns)
    if not s:
        return {"n": 0, "p50": float("nan"), "p99": float("nan")}
    return {"n": len(s), "p50": s[len(s) // 2] / 1000, "p90": s[int(0.9 * len(s))] / 1000,
            "p99": s[min(len(s) - 1, int(0.99 * len(s)))] / 1000, "top": [x / 1000 for x in s[-5:]]}


# ------------------------------------------------------------------ robots (child process)

def _robot_transforms(i: int, frames: int) -> list:
    from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3

    return [TransformStamped(header=Header(frame_id=f"robot{i}/base_link"), child_frame_id=f"robot{i}/link_{j}",
                             transform=Transform(translation=Vector3(0.1 * j, 0.0, 0.5),
                                                 rotation=Quaternion(0.0, 0.0, 0.0, 1.0)))
            for j in range(frames)]


def _turn(tfs: list, stamp: object, angle: float) -> None:
    """Stamp a robot's transforms and turn its joint to ``angle`` (what each robot sends, zentf or raw)."""
    qz, qw = math.sin(angle / 2), math.cos(angle / 2)
    for ts in tfs:
        ts.header.stamp = stamp
        rot = ts.transform.rotation
        rot.z = qz
        rot.w = qw


def robots(args: argparse.Namespace) -> None:
    """Robots first..first+count-1 of R: print the RSS before and after making them, send on 'go'."""
    from zentf.core.time import Time

    # everything a robot needs is imported before the baseline: memory per robot is what robots add
    import zenoh
    from zentf.ros import encode_tf as cdr_encode_tf
    from zentf.transport import parameters  # noqa: F401  (a node's parameter services)
    from zentf.transport.broadcaster import TransformBroadcaster
    from zentf.transport.wire import codec

    _reply({"imported": True})
    commands = _commands()
    if next(commands, None) != "connect":
        return
    # and Zenoh's runtime (its threads, made by the first session of a process) is up before it too
    _zopts(args.endpoint).open_session().close()
    base = rss_kb()
    senders = []  # (robot id, send(stamp_ns, angle))
    keepalive = []
    for i in range(args.first, args.first + args.count):
        tfs = _robot_transforms(i, args.frames)
        if args.impl == "zentf":
            node = _node("robot", f"robot{i}", args)
            br = TransformBroadcaster(node)
            keepalive.append(node)

            def send(stamp_ns: int, angle: float, tfs=tfs, br=br) -> None:
                _turn(tfs, Time(nanoseconds=stamp_ns), angle)
                br.send_transform(tfs)
        else:
            session = _zopts(args.endpoint).open_session()
            keepalive.append(session)
            encode = codec.encode_tf if args.wire == "zentf" else cdr_encode_tf
            key = f"robot{i}/tf" if args.wire == "zentf" else f"bench/robot{i}/tf"
            extra: dict = {}  # put's keyword arguments
            if args.raw_as_zentf:
                from zentf.core.messages import TFMessage
                from zentf.transport.wire.profiles import make_profile, ros2_attachment

                pub = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK,
                                                encoding=make_profile(args.wire).encoding(TFMessage.TYPE_NAME))
                att = (f"/robot{i}/robot".encode() if args.wire == "zentf"
                       else ros2_attachment(1, time.time_ns(), b"G" * 16))
                extra = {"attachment": zenoh.ZBytes(att)}
            else:
                pub = session.declare_publisher(key)

            def send(stamp_ns: int, angle: float, tfs=tfs, pub=pub, i=i, encode=encode, extra=extra) -> None:
                _turn(tfs, Time(nanoseconds=stamp_ns), angle)
                pub.put(PREFIX.pack(stamp_ns, i) + encode(tfs), **extra)
        senders.append((i, send))
    _reply({"ready": True, "rss_base": base, "rss": rss_kb()})
    state = {"sent": 0, "late": 0, "stop": threading.Event()}

    def run() -> None:
        period = 1.0 / args.hz
        offsets = [(i / args.total) * period for i, _ in senders]
        t0 = time.monotonic() + 0.05
        n = 0
        while not state["stop"].is_set():
            for off, (i, send) in zip(offsets, senders):
                due = t0 + n * period + off
                wait = due - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
                elif wait < -period:
                    state["late"] += 1
                send(time.time_ns(), n * 0.01 + i)
                state["sent"] += 1
                if state["stop"].is_set():
                    return
            n += 1

    thread = threading.Thread(target=run, daemon=True)
    for cmd in commands:
        if cmd == "go":
            thread.start()
        elif cmd == "mark":
            _reply({"sent": state["sent"], "late": state["late"], "rss": rss_kb()})
        elif cmd == "stop":
            state["stop"].set()
            thread.join(5)
            _reply({"stopped": True})
    for k in keepalive:
        (k.shutdown if hasattr(k, "shutdown") else k.close)()


# ------------------------------------------------------------------ listeners (child process)

def listen(args: argparse.Namespace) -> None:
    """One listener, per robot (robot 0's tf) or fleet-wide (every robot's): counters and robot 0's latency."""
    lat: list[int] = []
    counts = {"messages": 0, "bytes": 0}
    if args.impl == "zentf":
        from zentf.transport.buffer import Buffer
        from zentf.transport.listener import TransformListener

        node = _node("bench_listener", "robot0" if args.scope == "robot" else "", args)
        buffer = Buffer()
        listener = TransformListener(buffer, node, tf_topic="tf" if args.scope == "robot" else "/*/tf")
        last = [0]
        latest = buffer.get_latest_common_time

        def on_insert() -> None:
            now = time.time_ns()
            try:
                t = latest("robot0/base_link", "robot0/link_0").nanoseconds
            except Exception:  # robot 0 not seen yet
                return
            if t != last[0]:
                last[0] = t
                lat.append(now - t)

        buffer.add_insert_callback(on_insert)

        def stats() -> dict:
            s = listener.stats()
            return {"messages": s["messages"], "transforms": s["transforms"], "dropped": s["dropped"]}

        def buffer_bytes() -> int:  # walks every frame under the buffer's lock: asked after the window
            return buffer.memory_bytes()
        closer = node.shutdown
    else:
        session = _zopts(args.endpoint).open_session()
        robot = args.wire == "zentf" and "robot0/tf" or "bench/robot0/tf"
        key = robot if args.scope == "robot" else robot.replace("robot0", "*")
        unpack = PREFIX.unpack_from

        def on_sample(sample) -> None:
            now = time.time_ns()
            b = sample.payload.to_bytes()
            counts["messages"] += 1
            counts["bytes"] += len(b)
            stamp, robot_id = unpack(b)
            if robot_id == 0:
                lat.append(now - stamp)

        if args.raw_ring:  # the listener's way of receiving: a drop-oldest ring read by a Python thread
            import zenoh

            sub = session.declare_subscriber(key, zenoh.handlers.RingChannel(16384))

            def drain(recv=sub.handler.recv) -> None:
                while True:
                    try:
                        on_sample(recv())
                    except Exception:  # undeclared
                        return

            threading.Thread(target=drain, daemon=True).start()
        else:
            sub = session.declare_subscriber(key, on_sample)

        def stats() -> dict:
            return {"messages": counts["messages"], "transforms": counts["messages"] * args.frames, "dropped": 0}

        def buffer_bytes() -> int:
            return 0

        def closer() -> None:
            sub.undeclare()
            session.close()
    import zentf

    _reply({"ready": True, "rss": rss_kb(), "zentf": zentf.__file__})
    for cmd in _commands():
        if cmd == "mark":
            out = stats()
            out.update(lat=percentiles(lat), rss=rss_kb())
            lat.clear()
            _reply(out)
        elif cmd == "memory":
            _reply({"buffer_bytes": buffer_bytes()})
    closer()


# ------------------------------------------------------------------ main

class Child:
    """A child process spoken to by lines: commands on stdin, one JSON reply line each on stdout."""

    def __init__(self, name: str, prefix: list[str], argv: list[str]) -> None:
        env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
        env.update(PYTHONUNBUFFERED="1", PYTHONPATH=TREE, FLEET_BENCH_TREE=TREE)
        self.name = name
        self.err = tempfile.TemporaryFile("w+")  # a pipe nobody reads could fill and stall the child
        self.proc = subprocess.Popen([*prefix, sys.executable, *argv], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self.err, text=True, env=env,
                                     cwd=str(REPO), preexec_fn=_die_with_parent)
        self.pid = self.proc.pid  # 'ip netns exec' execs the command: the pid is the program's

    def send(self, cmd: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(cmd + "\n")
        self.proc.stdin.flush()

    def expect(self, word: str, timeout: float = 60.0) -> str:
        """The next stdout line holding ``word`` (other lines are skipped)."""
        assert self.proc.stdout is not None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.proc.stdout], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                break
            line = self.proc.stdout.readline()
            if not line:
                break
            if word in line:
                return line
        self.err.seek(0)
        err = self.err.read()
        raise RuntimeError(f"{self.name}: no '{word}' within {timeout:g} s" + (f": {err.strip()[-800:]}" if err else ""))

    def json(self, timeout: float = 60.0) -> dict:
        return json.loads(self.expect("{", timeout))



def stop_all(children: list[Child]) -> None:
    """End every child: EOF first (robots and listeners close their sessions), routers last, by signal."""
    for c in children:
        try:
            assert c.proc.stdin is not None
            c.proc.stdin.close()
        except (BrokenPipeError, OSError):
            pass
    deadline = time.monotonic() + 3
    for c in children:
        if c.name.startswith("router"):
            continue
        try:
            c.proc.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass
    for c in reversed(children):
        if c.proc.poll() is None:
            c.proc.terminate()
    for c in children:
        try:
            c.proc.wait(5)
        except subprocess.TimeoutExpired:
            c.proc.kill()
            c.proc.wait()


class Sample:
    """CPU, TCP bytes received and RSS of a set of processes at one moment."""

    def __init__(self, pids: dict[str, int], listen_prefix: list[str]) -> None:
        self.t = time.monotonic()
        self.cpu = {k: cpu_ns(p) for k, p in pids.items()}
        received = tcp_received(listen_prefix)
        self.rx = {k: received.get(p, 0) for k, p in pids.items()}
        self.rss = {k: rss_kb(p) for k, p in pids.items()}


def start_routers(args: argparse.Namespace, net, children: list[Child]) -> tuple[list[Child], str, str]:
    """The router(s); returns them and the endpoints of the robots' side and the listeners' side."""
    if net is None:
        ep = f"tcp/127.0.0.1:{free_port()}"
        r = Child("router", [], ["-m", "zentf.cli", "router", "--listen", ep, "--no-multicast"])
        children.append(r)
        r.expect("listening")
        return [r], ep, ep
    central = Child("router r", net.cmd("r"), ["-m", "zentf.cli", "router", "--config", ROUTER_CONF])
    children.append(central)
    central.expect("listening")
    host = Child("router a", net.cmd("a"), ["-m", "zentf.cli", "router", "--listen", "tcp/127.0.0.1:7447",
                                             "--connect", f"tcp/{net.router_ip('a')}:7447", "--no-multicast"])
    children.append(host)
    host.expect("listening")
    return [host, central], "tcp/127.0.0.1:7447", f"tcp/{net.router_ip('b')}:7447"


def run_phase(impl: str, n_robots: int, args: argparse.Namespace, net=None) -> dict:
    """Fresh router(s), listeners and robots for one implementation and R; the window's figures."""
    children: list[Child] = []
    common = ["--impl", impl, "--frames", str(args.frames), "--hz", str(args.hz), "--wire", args.wire,
              *(["--raw-ring"] if args.raw_ring else []), *(["--raw-as-zentf"] if args.raw_as_zentf else [])]
    where_robots = net.cmd("a") if net is not None else []
    where_listen = net.cmd("b") if net is not None else []
    try:
        routers, ep_robots, ep_listen = start_routers(args, net, children)
        listeners = {}
        for scope in ("robot", "fleet"):
            c = Child(f"{scope} listener", where_listen,
                      [__file__, "--role", "listen", "--scope", scope, "--endpoint", ep_listen, *common])
            children.append(c)
            listeners[scope] = c
        n_procs = min(args.procs, n_robots)
        bots = []
        first = 0
        for k in range(n_procs):  # they import meanwhile, and connect when told
            count = n_robots // n_procs + (1 if k < n_robots % n_procs else 0)
            c = Child(f"robots {first}..{first + count - 1}", where_robots,
                      [__file__, "--role", "robots", "--first", str(first), "--count", str(count), "--total",
                       str(n_robots), "--endpoint", ep_robots, *common])
            children.append(c)
            bots.append(c)
            first += count
        for c in [*listeners.values(), *bots]:
            ready = c.json()
            if "zentf" in ready and not ready["zentf"].startswith(TREE + os.sep):
                raise RuntimeError(f"{c.name} imported {ready['zentf']}, not the tree {TREE}")
        pids = {"robot": listeners["robot"].pid, "fleet": listeners["fleet"].pid}
        pids.update({f"router{k}": r.pid for k, r in enumerate(routers)})
        before = Sample(pids, where_listen)  # routers and listeners without robots
        for c in bots:
            c.send("connect")
        made = [c.json(120) for c in bots]
        for c in bots:
            c.send("go")
        time.sleep(args.warmup)

        def mark() -> tuple[Sample, dict, list[dict]]:
            s = Sample(pids, where_listen)
            for c in [*listeners.values(), *bots]:
                c.send("mark")
            return s, {k: c.json() for k, c in listeners.items()}, [c.json() for c in bots]

        s0, l0, b0 = mark()
        time.sleep(args.seconds)
        s1, l1, b1 = mark()
        listeners["fleet"].send("memory")
        fleet_buffer = listeners["fleet"].json()["buffer_bytes"]
        for c in bots:
            c.send("stop")
        for c in bots:
            c.json()
    finally:
        stop_all(children)
    span = s1.t - s0.t
    sent = sum(b["sent"] for b in b1) - sum(b["sent"] for b in b0)
    sent_tf = sent * args.frames
    router_cpu = sum(s1.cpu[k] - s0.cpu[k] for k in pids if k.startswith("router"))
    fleet_tf = l1["fleet"]["transforms"] - l0["fleet"]["transforms"]
    return {
        "sent_pct": 100.0 * sent / (n_robots * args.hz * span),
        "late": sum(b["late"] for b in b1),
        "robot_cpu_ms_s": (s1.cpu["robot"] - s0.cpu["robot"]) / 1e6 / span,
        "robot_kB_s": (s1.rx["robot"] - s0.rx["robot"]) / 1000 / span,
        "robot_msgs_s": (l1["robot"]["messages"] - l0["robot"]["messages"]) / span,
        "fleet_ktf_s": fleet_tf / 1000 / span,
        "fleet_cpu_pct": (s1.cpu["fleet"] - s0.cpu["fleet"]) / 1e9 / span * 100,
        "fleet_us_tf": (s1.cpu["fleet"] - s0.cpu["fleet"]) / 1000 / max(fleet_tf, 1),
        "fleet_kB_s": (s1.rx["fleet"] - s0.rx["fleet"]) / 1000 / span,
        "fleet_dropped": l1["fleet"]["dropped"],
        "router_ns_tf": router_cpu / max(sent_tf, 1),
        "routers_ns_tf": [(s1.cpu[k] - s0.cpu[k]) / max(sent_tf, 1) for k in sorted(pids) if k.startswith("router")],
        "mem_robots_kB": sum(b["rss"] - m["rss_base"] for b, m in zip(b1, made)) / n_robots,
        "mem_router_kB": sum(s1.rss[k] - before.rss[k] for k in pids if k.startswith("router")) / n_robots,
        "mem_fleet_kB": (s1.rss["fleet"] - before.rss["fleet"]) / n_robots,
        "fleet_buffer_kB": fleet_buffer / 1000 / n_robots,
        "lat_robot": l1["robot"]["lat"],
        "lat_fleet": l1["fleet"]["lat"],
    }


COLUMNS = [  # header, width, format of a value (zentf / raw), key
    ("sent%", 6, "{:.0f}", "sent_pct"),
    ("robotL ms/s", 11, "{:.2f}", "robot_cpu_ms_s"),
    ("robotL kB/s", 11, "{:.0f}", "robot_kB_s"),
    ("fleetL ktf/s", 12, "{:.1f}", "fleet_ktf_s"),
    ("fleetL CPU%", 11, "{:.1f}", "fleet_cpu_pct"),
    ("fleetL us/tf", 12, "{:.3f}", "fleet_us_tf"),
    ("router ns/tf", 12, "{:.0f}", "router_ns_tf"),
    ("kB/robot: robots", 16, "{:.0f}", "mem_robots_kB"),
    ("router", 7, "{:.1f}", "mem_router_kB"),
    ("fleetL", 7, "{:.0f}", "mem_fleet_kB"),
    ("buffer", 7, "{:.0f}", "fleet_buffer_kB"),
    ("robotL p50/p99 us", 17, None, "lat_robot"),
    ("fleetL p50/p99 us", 17, None, "lat_fleet"),
]


def _cell(res: dict, key: str, fmt: str | None) -> str:
    v = res[key]
    if fmt is None:
        return f"{v['p50']:.0f}/{v['p99']:.0f}"
    return fmt.format(v)


def _ratio(z: dict, r: dict, key: str, fmt: str | None) -> str:
    if fmt is None:
        a, b = z[key], r[key]
        return f"{a['p50'] / b['p50']:.2f}/{a['p99'] / b['p99']:.2f}" if b["p50"] and b["p99"] else "-"
    if key in ("sent_pct",):
        return ""
    return f"{z[key] / r[key]:.2f}" if r[key] else "-"


def print_header(args: argparse.Namespace, setup: str) -> None:
    print(f"fleet: R robots x {args.frames} frames at {args.hz:g} Hz through {setup}; the robots share "
          f"min(R, {args.procs}) processes (several robots per process: this machine has {os.cpu_count()} cores); "
          f"{args.seconds:g} s window after {args.warmup:g} s warm-up; wire {args.wire}; ratio = zentf / raw"
          + (" (raw listeners: a ring read by a thread)" if args.raw_ring else "")
          + (" (raw puts: zentf's attachment, encoding and congestion control)" if args.raw_as_zentf else ""),
          flush=True)
    print(f"{'R':>4} {'impl':<6}" + "".join(f" {h:>{w}}" for h, w, _, _ in COLUMNS) + "  load", flush=True)


def print_row(n: int, z: dict, r: dict, load: str) -> None:
    for name, res in (("zentf", z), ("raw", r)):
        print(f"{n:>4} {name:<6}" + "".join(f" {_cell(res, k, f):>{w}}" for _, w, f, k in COLUMNS)
              + (f"  {load}" if name == "zentf" else ""), flush=True)
    print(f"{'':>4} {'ratio':<6}" + "".join(f" {_ratio(z, r, k, f):>{w}}" for _, w, f, k in COLUMNS), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--role", default="main", choices=["main", "robots", "listen"], help=argparse.SUPPRESS)
    ap.add_argument("--impl", default="zentf", choices=["zentf", "raw"], help=argparse.SUPPRESS)
    ap.add_argument("--scope", default="robot", choices=["robot", "fleet"], help=argparse.SUPPRESS)
    ap.add_argument("--endpoint", help=argparse.SUPPRESS)
    ap.add_argument("--first", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--count", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--total", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--robots", default=None, help="comma list of R (default 1,10,50,100; --quick: 1,10)")
    ap.add_argument("--frames", type=int, default=50, help="F: transforms per robot message (50)")
    ap.add_argument("--hz", type=float, default=30.0, help="H: messages per robot a second (30)")
    ap.add_argument("--seconds", type=float, default=None, help="measured window per run (5; --quick: 1.5)")
    ap.add_argument("--warmup", type=float, default=None, help="sending before the window (1; --quick: 0.5)")
    ap.add_argument("--procs", type=int, default=2, help="processes the robots share (2)")
    ap.add_argument("--wire", default="zentf", choices=["zentf", "ros2"])
    ap.add_argument("--netns", action="store_true", help="two routers in network namespaces (root)")
    ap.add_argument("--raw-as-zentf", action="store_true",
                    help="the raw puts carry zentf's attachment, encoding and congestion control")
    ap.add_argument("--raw-ring", action="store_true",
                    help="raw listeners read a drop-oldest ring from a Python thread (the listener's way of "
                         "receiving) instead of a callback on Zenoh's thread")
    ap.add_argument("--quick", action="store_true", help="short runs, R = 1,10 unless --robots")
    ap.add_argument("--json", help="write every run's figures to this file")
    ap.add_argument("--tree", help="a zentf checkout the processes import instead of this one (before/after)")
    args = ap.parse_args()
    if args.role == "robots":
        return robots(args)
    if args.role == "listen":
        return listen(args)
    if args.tree:
        global TREE
        TREE = str(Path(args.tree).resolve())
    if args.seconds is None:
        args.seconds = 1.5 if args.quick else 5.0
    if args.warmup is None:
        args.warmup = 0.5 if args.quick else 1.0
    try:
        sizes = [int(x) for x in (args.robots or ("1,10" if args.quick else "1,10,50,100")).split(",")]
        if not sizes or min(sizes) < 1:
            raise ValueError
    except ValueError:
        ap.error(f"--robots: a comma list of robot counts >= 1, got {args.robots!r}")
    if args.procs < 1 or args.frames < 1 or args.hz <= 0 or args.seconds <= 0:
        ap.error("--procs, --frames, --hz and --seconds must be positive")

    net = None
    if args.netns:
        from netns_topology import Topology, unavailable_reason

        reason = unavailable_reason()
        if reason is not None:
            ap.error(f"--netns: {reason}")
        net = Topology(["a", "b"])
        net.create()
    setup = ("two routers in network namespaces (robots -> router in host a -> veth -> router in r -> veth -> "
             "listeners in host b)" if net is not None else "one zentf router on loopback")
    results = []
    try:
        print_header(args, setup)
        for k, n in enumerate(sizes):
            load0 = os.getloadavg()[0]
            order = ("zentf", "raw") if k % 2 == 0 else ("raw", "zentf")
            res = {impl: run_phase(impl, n, args, net) for impl in order}
            load = f"{load0:.1f}-{os.getloadavg()[0]:.1f}"
            print_row(n, res["zentf"], res["raw"], load)
            results.append({"robots": n, "load": load, **res})
    finally:
        if net is not None:
            net.destroy()
    if any(r[i]["fleet_dropped"] for r in results for i in ("zentf", "raw")):
        print("(the fleet listener dropped messages: it fell behind)")
    if args.json:
        Path(args.json).write_text(json.dumps({"args": vars(args), "rows": results}, indent=1))


if __name__ == "__main__":
    main()
