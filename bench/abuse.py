"""Abuse benchmark (issue 10): a listener under a flood of bad and foreign tf samples, in real processes.

    python bench/abuse.py [--flood 1000000] [--per-msg 1] [--frames 100000]

A Zenoh router on loopback (like the tests' router fixture), and client processes on it:
- a **listener** (Buffer + TransformListener, as a user program has it) whose helper thread reads the
  latest stamp of the legitimate edge ``world -> legit`` every 5 ms and records its staleness
  (wall now - stamp of the newest sample in the buffer);
- a **legitimate** broadcaster sending ``world -> legit`` at 50 Hz, stamped with the send time;
- a **flooder**, a raw Zenoh session putting ``--flood`` samples on the same ``tf`` key as fast as it
  can (``--per-msg`` samples per message, attachment ``/flooder``): NaN transforms of the legitimate
  edge, then valid transforms of 1000 other frames (foreign data that costs real inserts).
Reported: staleness p50/p99 with no flood (the reference, same run) and during each flood (target
p99 <= 100 ms); the listener's log bytes per second during the NaN flood (target <= 10 kB/s) against
what one line per refused sample would write (tf2's behaviour); listener RSS above idle once it has
handled ``--frames`` distinct frames offered in 100-transform messages (target <= 50 MB), median and
range over ``--runs`` fresh listeners, with the peak during the flood and the part that is Zenoh
shared memory mapped from other processes, against two references measured the same way: Zenoh's
own defaults (shared-memory transport on, in the router, listener and flooder) with no release of
freed memory after the burst (zentf before it set both), and the frame cap off (``max_frames=None``,
tf2's unbounded buffer).

Forged ROS 2 TFMessages (``--only forged``): a raw session on a ROS 2 graph puts ``--forged`` big CDR
TFMessages (``--forged-size`` bytes, each a new shape, frame names without their closing NUL), then a
valid sentinel; reported for a ``zentf tf echo --wire ros2`` listener and a ``zentf bridge ros2``: peak RSS
above idle and RSS above idle once the sentinel is through (target <= 50 MB), against the same run of
the tree ``--reference-tree`` names (a checkout built in place, e.g. the main branch before the fix).

MCAP decompression bomb (``--only bomb``): a forged MCAP (a few KB) whose one zstd chunk expands to
``--bomb-size`` bytes of zeros (default 1.5 GiB, the reported case); reported for ``zentf bag info`` and
``zentf tf echo --bag`` (each a fresh process, which reads the bag and exits): peak RSS (the kernel's
high-water mark of that process, VmHWM) and the RSS last seen before it exits, in MB, against the same commands
on a valid 1 MiB chunk (the reference without a bomb) and against the ``--reference-tree`` (e.g. main
before the bounded decompression; target for this tree: peak <= +100 MB over the valid chunk).
"""
from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

NS = 1_000_000_000
NAMESPACE = "abuse"
EDGE = ("world", "legit")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def zopts(endpoint: str, config: str | None = None):
    from zentf.transport.options import ZenohOptions

    return ZenohOptions(config_file=config, connect=[endpoint], mode="client", no_multicast=True)


def memory_kb() -> dict[str, int]:
    """This process's RSS, its peak (high-water mark) and the shared memory in it, in kB."""
    out = {}
    with open("/proc/self/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM", "RssShmem"):
                out[key] = int(value.split()[0])
    return out


# ------------------------------------------------------------------ child roles

def role_listener(args: argparse.Namespace) -> None:
    """Commands on stdin, one per line: start / stop (staleness samples) / mark (RSS, stats) / quit."""
    import logging

    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    from zentf.transport.buffer import Buffer
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions

    if args.no_release:  # the reference: freed memory stays with the allocator after a burst
        import zentf.transport.listener

        zentf.transport.listener.RELEASE_AFTER = 1 << 62
    node = Node("abuse_listener", options=NodeOptions(namespace=NAMESPACE, zenoh=zopts(args.endpoint, args.zenoh_config)),
                check_unique=False)
    kw = {} if args.max_frames == "default" else {"max_frames": None if args.max_frames == "none" else int(args.max_frames)}
    buf = Buffer(node=node, **kw)
    tl = TransformListener(buf, node)
    sampling = threading.Event()
    quit_ = threading.Event()
    stale: list[int] = []

    def sampler() -> None:
        while not quit_.is_set():
            if sampling.wait(0.1):
                try:
                    st = buf.lookup_transform(*EDGE, 0).header.stamp.nanoseconds
                    stale.append(time.time_ns() - st)
                except Exception:
                    pass
                time.sleep(0.005)

    threading.Thread(target=sampler, daemon=True).start()
    print("ready", flush=True)
    for line in sys.stdin:
        cmd = line.strip()
        if cmd == "start":
            stale.clear()
            sampling.set()
            print("started", flush=True)
        elif cmd == "stop":
            sampling.clear()
            print("RESULT " + json.dumps({"stale_ns": stale, "stats": tl.stats()}), flush=True)
        elif cmd == "mark":
            print("RESULT " + json.dumps({"mem_kb": memory_kb(), "stats": tl.stats(),
                                          "frames": len(buf.get_frames())}), flush=True)
        elif cmd == "wait_edge":
            ok = buf.can_transform(*EDGE, 0, timeout=30)
            print(f"RESULT {json.dumps({'ok': ok})}", flush=True)
        elif cmd == "quit":
            break
    quit_.set()
    node.shutdown()


def role_legit(args: argparse.Namespace) -> None:
    from zentf.transport.broadcaster import TransformBroadcaster
    from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
    from zentf.core.time import Time
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions

    node = Node("legit_broadcaster", options=NodeOptions(namespace=NAMESPACE, zenoh=zopts(args.endpoint)),
                check_unique=False)
    br = TransformBroadcaster(node)
    print("ready", flush=True)
    period = NS // 50
    nxt = time.monotonic_ns()
    i = 0
    while True:
        i += 1
        br.send_transform(TransformStamped(Header(Time(nanoseconds=time.time_ns()), EDGE[0]), EDGE[1],
                                           Transform(Vector3(float(i), 0.0, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0))))
        nxt += period
        time.sleep(max(0.0, (nxt - time.monotonic_ns()) / NS))


def flood_payloads(kind: str, n_msgs: int, per_msg: int, base: int):
    """Yield TFMessage payloads: 'nan' (NaN legit edge), 'frames' (1000 foreign frames), 'distinct'."""
    import msgpack

    def tf(parent: str, child: str, stamp: int, x: float) -> dict:
        return {"header": {"stamp": {"sec": stamp // NS, "nanosec": stamp % NS}, "frame_id": parent},
                "child_frame_id": child,
                "transform": {"translation": {"x": x, "y": 0.0, "z": 0.0},
                              "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}

    if kind == "nan":
        payload = msgpack.packb({"transforms": [tf(*EDGE, base, float("nan"))] * per_msg})
        for _ in range(n_msgs):
            yield payload
        return
    k = 0
    for i in range(n_msgs):
        items = []
        for _ in range(per_msg):
            if kind == "frames":
                items.append(tf("world", f"other{k % 1000}", base + (k // 1000) * 1000, 1.0))
            else:
                items.append(tf("world", f"distinct_frame_{k:07d}", base, 1.0))
            k += 1
        yield msgpack.packb({"transforms": items})


def role_flood(args: argparse.Namespace) -> None:
    import zenoh

    from zentf.transport.wire import codec as wire
    from zentf.core.messages import TFMessage

    session = zopts(args.endpoint, args.zenoh_config).open_session()
    pub = session.declare_publisher(f"{NAMESPACE}/tf", encoding=wire.encoding_for(TFMessage.TYPE_NAME),
                                    congestion_control=zenoh.CongestionControl.BLOCK)
    while not pub.matching_status.matching:
        time.sleep(0.01)
    n_msgs = args.count // args.per_msg
    att = b"/flooder"
    payloads = list(flood_payloads(args.kind, n_msgs, args.per_msg, time.time_ns() - 2 * NS)) \
        if args.kind != "nan" else None
    print("ready", flush=True)
    sys.stdin.readline()
    t0 = time.perf_counter()
    if payloads is None:
        put = pub.put
        for p in flood_payloads("nan", n_msgs, args.per_msg, time.time_ns()):
            put(p, attachment=att)
    else:
        for p in payloads:
            pub.put(p, attachment=att)
    dt = time.perf_counter() - t0
    print("RESULT " + json.dumps({"secs": dt, "samples": n_msgs * args.per_msg}), flush=True)
    time.sleep(1.0)  # (closing at once can lose the last puts)
    session.close()


def role_forge_ros2(args: argparse.Namespace) -> None:
    """``--count`` CDR TFMessages of ``--forged-size`` bytes on the ROS 2 graph's /tf (``--kind`` forged:
    the parent's NUL replaced; nul: valid), then a valid sentinel world -> sentinel."""
    import struct

    import zenoh

    from zentf.core.messages import TFMessage
    from zentf.transport.wire.profiles import make_profile

    end = b"\0" if args.kind == "nul" else b"!"
    key = make_profile("ros2", os.environ["ROS_DOMAIN_ID"]).data_key("/tf", TFMessage.TYPE_NAME)
    session = zopts(args.endpoint).open_session()
    pub = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
    while not pub.matching_status.matching:
        time.sleep(0.01)

    def element(buf: bytearray, parent: bytes, child: bytes, sec: int, x: float, nul: bytes = b"\0") -> None:
        buf += struct.pack("<iII", sec, 0, len(parent) + 1) + parent + nul
        buf += b"\0" * ((4 - len(buf)) % 4)  # (alignment counts from the end of the 4-byte header)
        buf += struct.pack("<I", len(child) + 1) + child + b"\0"
        buf += b"\0" * ((4 - len(buf)) % 8)
        buf += struct.pack("<7d", x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)

    def message(k: int) -> bytes:
        buf = bytearray(b"\x00\x01\x00\x00\x00\x00\x00\x00")
        n = 0
        while len(buf) < args.forged_size:
            element(buf, b"p%d" % k, b"c%d" % (n % 9000), 100, 1.0, end)
            n += 1
        buf[4:8] = struct.pack("<I", n)
        return bytes(buf)

    gid = b"F" * 16
    print("ready", flush=True)
    sys.stdin.readline()
    for k in range(args.count):
        pub.put(message(k), attachment=struct.pack("<qqB16s", k + 1, time.time_ns(), 16, gid))
    sentinel = bytearray(b"\x00\x01\x00\x00\x01\x00\x00\x00")
    element(sentinel, b"world", b"sentinel", int(time.time()), 7.0)
    pub.put(bytes(sentinel), attachment=struct.pack("<qqB16s", args.count + 1, time.time_ns(), 16, gid))
    print("RESULT {}", flush=True)
    time.sleep(1.0)
    session.close()


def role_zentf_side(args: argparse.Namespace) -> None:
    """A raw subscriber on the zentf graph's 'tf': says when the bridge relayed the sentinel."""
    session = zopts(args.endpoint).open_session()
    seen = threading.Event()

    def on(sample) -> None:
        if b"sentinel" in sample.payload.to_bytes():
            seen.set()

    session.declare_subscriber("tf", on)
    print("ready", flush=True)
    seen.wait(600)
    print("RESULT {}", flush=True)
    session.close()


# ------------------------------------------------------------------ orchestration (this process)

class Child:
    def __init__(self, role: str, endpoint: str, *extra: str, stderr_counter: bool = False) -> None:
        self.p = subprocess.Popen([sys.executable, __file__, "--role", role, "--endpoint", endpoint, *extra],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE if stderr_counter else None, text=True, bufsize=1)
        self.log_bytes = 0
        self.log_lines: list[str] = []
        if stderr_counter:
            threading.Thread(target=self._count, daemon=True).start()
        self.expect("ready")

    def _count(self) -> None:
        assert self.p.stderr is not None
        for line in self.p.stderr:
            self.log_bytes += len(line.encode())
            if len(self.log_lines) < 50:
                self.log_lines.append(line.rstrip())

    def expect(self, word: str) -> str:
        assert self.p.stdout is not None
        line = self.p.stdout.readline()
        while line and not line.startswith(word):
            line = self.p.stdout.readline()
        if not line:
            raise RuntimeError(f"{self.p.args[3]} ended before {word!r}")
        return line

    def ask(self, cmd: str) -> dict:
        assert self.p.stdin is not None
        self.p.stdin.write(cmd + "\n")
        self.p.stdin.flush()
        return json.loads(self.expect("RESULT ")[len("RESULT "):])

    def send(self, cmd: str) -> None:
        assert self.p.stdin is not None
        self.p.stdin.write(cmd + "\n")
        self.p.stdin.flush()

    def stop(self) -> None:
        if self.p.poll() is None:
            self.p.terminate()
            try:
                self.p.wait(5)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait(5)


def start_router(config: str | None = None) -> tuple[subprocess.Popen, str]:
    ep = f"tcp/127.0.0.1:{free_port()}"
    p = subprocess.Popen([sys.executable, "-m", "zentf.transport.router", "--listen", ep, "--no-multicast",
                          *(["--config", config] if config else [])], stdout=subprocess.PIPE, text=True)
    assert p.stdout is not None
    line = p.stdout.readline()
    if "listening" not in line:
        raise RuntimeError(f"router did not start: {line!r}")
    return p, ep


class _Skip(Exception):
    """--only: the part not asked for."""


def pct(values: list[int], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))] / 1e6 if s else float("nan")


def flood(ep: str, kind: str, count: int, per_msg: int, *extra: str) -> dict:
    f = Child("flood", ep, "--kind", kind, "--count", str(count), "--per-msg", str(per_msg), *extra)
    try:
        f.send("go")
        return json.loads(f.expect("RESULT ")[len("RESULT "):])
    finally:
        f.stop()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--role", default="main", choices=["main", "listener", "legit", "flood", "forge_ros2", "zentf_side"])
    ap.add_argument("--endpoint")
    ap.add_argument("--kind", default="nan")
    ap.add_argument("--count", type=int, default=0)
    ap.add_argument("--max-frames", default="default")
    ap.add_argument("--zenoh-config")
    ap.add_argument("--no-release", action="store_true")
    ap.add_argument("--flood", type=int, default=1_000_000, help="samples in each flood")
    ap.add_argument("--per-msg", type=int, default=1, help="samples per flood message")
    ap.add_argument("--frames", type=int, default=100_000, help="distinct frames offered in the memory case")
    ap.add_argument("--runs", type=int, default=3, help="fresh listeners per row in the memory case")
    ap.add_argument("--forged", type=int, default=40, help="forged ROS 2 TFMessages in the forged case")
    ap.add_argument("--forged-size", type=int, default=1_800_000, help="bytes of each forged TFMessage")
    ap.add_argument("--reference-tree", help="a zentf checkout (built in place) measured the same way in the forged case")
    ap.add_argument("--bomb-size", type=int, default=3 << 29, help="bytes the bomb's chunk expands to (--only bomb)")
    ap.add_argument("--only", choices=["flood", "memory", "forged", "bomb"], help="run one part")
    args = ap.parse_args()
    if args.role != "main":
        {"listener": role_listener, "legit": role_legit, "flood": role_flood, "forge_ros2": role_forge_ros2,
         "zentf_side": role_zentf_side}[args.role](args)
        return
    if args.only == "forged":
        print(f"# zentf abuse bench  (python {sys.version.split()[0]}, {os.cpu_count()} cpus; loopback router)")
        forged_table(args)
        return
    if args.only == "bomb":
        print(f"# zentf abuse bench  (python {sys.version.split()[0]}, {os.cpu_count()} cpus)")
        bomb_table(args)
        return

    print(f"# zentf abuse bench  (python {sys.version.split()[0]}, {os.cpu_count()} cpus; loopback router)")
    router, ep = start_router()
    children: list[Child] = []
    try:
        if args.only == "memory":
            raise _Skip
        lis = Child("listener", ep, stderr_counter=True)
        children.append(lis)
        children.append(Child("legit", ep))
        if not lis.ask("wait_edge")["ok"]:
            raise RuntimeError("the listener never got the legitimate edge")
        rows = []
        lis.send("start")
        lis.expect("started")
        time.sleep(3.0)
        base = lis.ask("stop")
        rows.append(("no flood (reference)", base, None, 0))
        for kind, label in (("nan", "NaN flood of the same edge"), ("frames", "valid flood of 1000 other frames")):
            lis.send("start")
            lis.expect("started")
            b0 = lis.log_bytes
            fl = flood(ep, kind, args.flood, args.per_msg)
            time.sleep(0.5)  # the tail of the flood is still being handled
            res = lis.ask("stop")
            # log bytes per second of flooding (+0.5 s of tail): the lines only appear while it lasts
            rows.append((label, res, fl, (lis.log_bytes - b0) / (fl["secs"] + 0.5)))
        print()
        print(f"| legitimate 50 Hz edge, staleness (ms) | p50 | p99 | max | flood rate (samples/s) | listener log |")
        print("|---|---|---|---|---|---|")
        for label, res, fl, lb in rows:
            s = res["stale_ns"]
            rate = f"{fl['samples'] / fl['secs']:,.0f}" if fl else ""
            print(f"| {label} | {pct(s, .5):.1f} | {pct(s, .99):.1f} (target <= 100) | {max(s) / 1e6:.1f} | "
                  f"{rate} | {lb / 1000:.2f} kB/s |")
        nan_row = rows[1]
        secs = nan_row[2]["secs"]
        line_len = 260  # one TF_NAN_INPUT line as tf2 (and zentf before issue 10) printed it
        tf2_bytes = nan_row[2]["samples"] * line_len  # tf2 refuses, and logs, every one of them
        print()
        print("| NaN flood, listener log | zentf | tf2: one line per refused sample |")
        print("|---|---|---|")
        print(f"| bytes/s | {nan_row[3]:,.0f} (target <= 10,000) | at least {tf2_bytes / (secs + 0.5):,.0f} |")
        print(f"| bytes for the whole flood | {nan_row[3] * (secs + 0.5):,.0f} | {tf2_bytes:,.0f} |")
        print("zentf's lines:")
        for line in lis.log_lines[:6]:
            print(f"    {line[:200]}")
    except _Skip:
        pass
    finally:
        for c in children:
            c.stop()
        router.terminate()
        router.wait(5)
    if args.only != "flood":
        memory_table(args)  # (a router of its own per row)
        forged_table(args)
        bomb_table(args)


def memory_run(ep: str, frames: int, *extra: str) -> dict:
    """One fresh listener, idle then flooded with distinct frames: memory above idle once all is handled."""
    config = [*extra[extra.index("--zenoh-config"):][:2]] if "--zenoh-config" in extra else []
    lis = Child("listener", ep, *extra, stderr_counter=True)
    try:
        idle = lis.ask("mark")
        flood(ep, "distinct", frames, 100, *config)
        last = -1
        while True:  # until the listener has handled everything (messages counter stable)
            m = lis.ask("mark")
            done = m["stats"]["messages"] + m["stats"]["bad_messages"] + m["stats"]["dropped"]
            if done == last:
                break
            last = done
            time.sleep(0.5)
    finally:
        lis.stop()
    a, b = idle["mem_kb"], m["mem_kb"]
    return {"after": (b["VmRSS"] - a["VmRSS"]) / 1024, "peak": (b["VmHWM"] - a["VmRSS"]) / 1024,
            "shm": (b.get("RssShmem", 0) - a.get("RssShmem", 0)) / 1024, "frames": m["frames"]}


def memory_table(args: argparse.Namespace) -> None:
    import statistics
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        zenoh_defaults = os.path.join(tmp, "zenoh-defaults.json5")
        with open(zenoh_defaults, "w") as f:  # Zenoh's own default: shared-memory transport on
            f.write("{ transport: { shared_memory: { enabled: true } } }\n")
        cases = [("zentf (default frame cap)", None, ()),
                 ("Zenoh defaults (shared memory on), no release after the burst", zenoh_defaults,
                  ("--zenoh-config", zenoh_defaults, "--no-release")),
                 ("cap off (tf2: unbounded)", None, ("--max-frames", "none"))]
        rows = []
        for label, router_config, extra in cases:
            router, ep = start_router(router_config)
            try:
                rows.append((label, [memory_run(ep, args.frames, *extra) for _ in range(args.runs)]))
            finally:
                router.terminate()
                router.wait(5)
    print()
    print(f"| listener after {args.frames:,} distinct frames offered ({args.runs} runs) | frames stored | "
          "RSS above idle (MB): median [min-max] | peak during the flood | of which Zenoh shared memory |")
    print("|---|---|---|---|---|")
    for i, (label, runs) in enumerate(rows):
        def cell(key: str) -> str:
            v = [r[key] for r in runs]
            return f"{statistics.median(v):.1f} [{min(v):.1f}-{max(v):.1f}]"
        target = " (target <= 50)" if i == 0 else ""
        print(f"| {label} | {runs[0]['frames']:,} | {cell('after')}{target} | {cell('peak')} | {cell('shm')} |")
    print()
    print("Peak: the listener's high-water mark above idle (the flood's messages waiting in Zenoh's ring and the")
    print("per-sender queues). Noisy on a shared machine; compare the rows of one run, not runs with each other.")



def rss_kb(pid: int) -> tuple[int, int]:
    """(VmRSS, VmHWM) of a process, in kB."""
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(value.split()[0])
    return out["VmRSS"], out["VmHWM"]


def forged_run(tree: str, victim: str, kind: str, count: int, size: int) -> dict:
    """One victim (run from ``tree``) under ``count`` forged (or valid) ROS 2 TFMessages: MB above idle."""
    import random

    router, ep = start_router()
    env = {**os.environ, "PYTHONPATH": tree, "ROS_DOMAIN_ID": str(random.randrange(1, 200)), "ZENTF_CONNECT": ep,
           "ZENTF_MODE": "client", "ZENTF_NO_MULTICAST": "1", "PYTHONUNBUFFERED": "1"}
    env.pop("ZENTF_NAMESPACE", None)
    procs: list[subprocess.Popen] = []

    def start(args: list[str], extra_env: dict | None = None) -> subprocess.Popen:
        p = subprocess.Popen(args, env={**env, **(extra_env or {})}, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, bufsize=1, cwd=tree)  # (-m imports from cwd first)
        procs.append(p)
        return p

    def wait_line(p: subprocess.Popen, text: str) -> None:
        assert p.stdout is not None
        for line in p.stdout:
            if text in line:
                return
        raise RuntimeError(f"{p.args}: ended before {text!r}")

    try:
        if victim == "listener":
            v = start([sys.executable, "-m", "zentf.cli", "tf", "echo", "--wire", "ros2", "world", "sentinel",
                       "-r", "20"], {"ZENTF_WIRE": "ros2"})
            wait_line(v, "Waiting for transform")
            done, done_text = v, "Translation: [7.000"
        else:
            v = start([sys.executable, "-m", "zentf.cli", "bridge", "ros2", "--ros2-connect", ep])
            wait_line(v, "bridging tf")
            done = start([sys.executable, __file__, "--role", "zentf_side", "--endpoint", ep])
            wait_line(done, "ready")
            done_text = "RESULT"
        time.sleep(2.0)
        idle = rss_kb(v.pid)[0]
        f = start([sys.executable, __file__, "--role", "forge_ros2", "--endpoint", ep, "--count", str(count),
                   "--forged-size", str(size), "--kind", kind])
        wait_line(f, "ready")
        assert f.stdin is not None
        f.stdin.write("go\n")
        f.stdin.flush()
        t0 = time.monotonic()
        wait_line(done, done_text)
        secs = time.monotonic() - t0
        if victim == "listener" and v.stdout is not None:  # (tf echo prints at 20 Hz: keep its pipe drained)
            threading.Thread(target=lambda: [None for _ in v.stdout], daemon=True).start()
        time.sleep(1.0)  # the release after a burst (the listener's tail timer, the bridge's quiet timer)
        rss, hwm = rss_kb(v.pid)
        return {"peak": (hwm - idle) / 1024, "after": (rss - idle) / 1024, "idle": idle / 1024, "secs": secs}
    finally:
        for p in procs:
            p.terminate()
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                p.kill()
        router.terminate()
        router.wait(5)


def forged_table(args: argparse.Namespace) -> None:
    trees = [("this tree", str(Path(__file__).resolve().parent.parent))]
    if args.reference_tree:
        trees.append((f"reference: {args.reference_tree}", str(Path(args.reference_tree).resolve())))
    print()
    print(f"| {args.forged} ROS 2 TFMessages of {args.forged_size / 1e6:.1f} MB, then a sentinel | tree | "
          "RSS at idle (MB) | peak above idle (MB) | above idle once the sentinel is through (MB) | s to the sentinel |")
    print("|---|---|---|---|---|---|")
    for victim, label in (("listener", "`tf echo --wire ros2`"), ("bridge", "`bridge ros2`")):
        for kind, what in (("forged", "forged (no NUL, a new shape each)"), ("nul", "valid, a new shape each")):
            for tree_label, tree in trees:
                try:
                    r = forged_run(tree, victim, kind, args.forged, args.forged_size)
                except Exception as e:  # noqa: BLE001 - a reference that cannot run this case: say so
                    print(f"| {label}, {what} | {tree_label} | failed: {str(e)[:80]} | | | |")
                    continue
                target = " (target <= 50)" if tree_label == "this tree" else ""
                print(f"| {label}, {what} | {tree_label} | {r['idle']:.0f} | {r['peak']:.0f} | "
                      f"{r['after']:.0f}{target} | {r['secs']:.1f} |")
    print()
    print("Peak: the victim's high-water mark above idle (the messages in flight and their decoding).")


# ------------------------------------------------------------------ decompression bomb


def _mcap_record(op: int, body: bytes) -> bytes:
    import struct

    return struct.pack("<BQ", op, len(body)) + body


def _mcap_str(text: str) -> bytes:
    import struct

    return struct.pack("<I", len(text)) + text.encode()


def write_mcap_bomb(path: Path, expands_to: int, declares: int | None = None) -> Path:
    """An MCAP with one /tf channel and one zstd chunk whose single message record is ``expands_to`` bytes of
    zeros (a few KB on disk for 1.5 GiB); the chunk declares ``declares`` bytes (default: the truth)."""
    import struct

    import zstandard

    mib = 1 << 20
    head = struct.pack("<BQ", 5, expands_to - 9) + struct.pack("<HIQQ", 1, 0, 10, 10)
    comp = zstandard.ZstdCompressor(level=1, write_content_size=True).compressobj(size=expands_to)
    parts = [comp.compress(head)]
    left, zeros = expands_to - len(head), bytes(mib)
    while left > 0:
        parts.append(comp.compress(zeros[:min(mib, left)]))
        left -= mib
    parts.append(comp.flush())
    data = b"".join(parts)
    chunk = struct.pack("<QQQI", 10, 10, expands_to if declares is None else declares, 0) + _mcap_str("zstd") + struct.pack("<Q", len(data)) + data
    path.write_bytes(b"\x89MCAP0\r\n" + _mcap_record(1, _mcap_str("ros2") + _mcap_str("bench"))
                     + _mcap_record(3, struct.pack("<H", 1) + _mcap_str("tf2_msgs/msg/TFMessage")
                                    + _mcap_str("ros2msg") + _mcap_str(""))
                     + _mcap_record(4, struct.pack("<HH", 1, 1) + _mcap_str("/tf") + _mcap_str("cdr")
                                    + struct.pack("<I", 0))
                     + _mcap_record(6, chunk) + _mcap_record(0x0F, struct.pack("<I", 0))
                     + _mcap_record(2, struct.pack("<QQI", 0, 0, 0)) + b"\x89MCAP0\r\n")
    return path


def bomb_run(tree: str, args: list[str]) -> dict:
    """One ``zentf ARGS`` from ``tree`` to its end: peak RSS (its VmHWM, read every 10 ms: wait4's ru_maxrss
    would count the forking parent's size, kept across exec) and the RSS last seen, in MB."""
    env = {**os.environ, "PYTHONPATH": tree, "PYTHONUNBUFFERED": "1"}
    t0 = time.monotonic()
    p = subprocess.Popen([sys.executable, "-m", "zentf.cli", *args], env=env, cwd=tree, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)
    last = peak = 0
    out: list[bytes] = []
    readers = [threading.Thread(target=lambda f=f: out.append(f.read()), daemon=True) for f in (p.stdout, p.stderr)]
    for r in readers:
        r.start()
    while True:
        try:
            last, peak = rss_kb(p.pid)
        except (OSError, KeyError):  # (gone, or a zombie without its memory lines)
            pass
        pid, status = os.waitpid(p.pid, os.WNOHANG)
        if pid:
            break
        if time.monotonic() - t0 > 600:
            p.kill()
        time.sleep(0.01)
    for r in readers:
        r.join(5)
    p.returncode = os.waitstatus_to_exitcode(status)
    text = b"".join(out).decode("utf-8", "replace").strip().splitlines()
    line = next((ln for ln in text if "warning" in ln or "error" in ln or "complete" in ln), text[-1] if text else "")
    return {"peak": peak / 1024, "last": last / 1024, "secs": time.monotonic() - t0,
            "rc": p.returncode, "line": line}


def bomb_table(args: argparse.Namespace) -> None:
    import tempfile

    trees = [("this tree", str(Path(__file__).resolve().parent.parent))]
    if args.reference_tree:
        trees.append((f"reference: {args.reference_tree}", str(Path(args.reference_tree).resolve())))
    with tempfile.TemporaryDirectory(prefix="zentf-bomb-") as tmp:
        bomb = write_mcap_bomb(Path(tmp) / "bomb.mcap", args.bomb_size)
        lying = write_mcap_bomb(Path(tmp) / "lying.mcap", args.bomb_size, declares=1 << 20)
        valid = write_mcap_bomb(Path(tmp) / "valid.mcap", 1 << 20)
        print()
        print(f"MCAP bomb: {bomb.stat().st_size / 1024:.0f} KB on disk, one zstd chunk of "
              f"{args.bomb_size / (1 << 30):.2f} GiB; lying bomb: the same chunk declaring 1 MiB; "
              "valid: the same with a 1 MiB chunk")
        print()
        print("| command | file | tree | peak RSS (MB) | RSS last seen before exit (MB) | s | exit | what it said |")
        print("|---|---|---|---|---|---|---|---|")
        for label, cmd in (("`bag info`", ["bag", "info"]), ("`tf echo --bag`", ["tf", "echo", "world", "base"])):
            for fname, path in (("valid", valid), ("bomb", bomb), ("lying bomb", lying)):
                for tree_label, tree in trees:
                    argv = [*cmd, str(path)] if cmd[0] == "bag" else [*cmd, "--bag", str(path)]
                    try:
                        r = bomb_run(tree, argv)
                    except Exception as e:  # noqa: BLE001 - a reference that cannot run this case: say so
                        print(f"| {label} | {fname} | {tree_label} | failed: {str(e)[:80]} | | | | |")
                        continue
                    said = r["line"].replace(str(path), "FILE").replace("|", "/")[:110]
                    print(f"| {label} | {fname} | {tree_label} | {r['peak']:.0f} | {r['last']:.0f} | {r['secs']:.1f} | "
                          f"{r['rc']} | {said} |")
    print()
    print("Target: this tree's peak on the bomb within +100 MB of its peak on the valid file.")


if __name__ == "__main__":
    main()
