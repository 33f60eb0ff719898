"""Bag throughput (messages/s): zentf.tools.bag against the bare libraries it sits on, measured in the same run.

Rows: MCAP write (BagWriter vs mcap.Writer), MCAP read (BagReader vs mcap StreamReader), record over
Zenoh (Recorder into a file vs a bare Zenoh subscriber that only counts), play over Zenoh (Player
at full speed vs a bare put loop). Payload: a 2-transform TFMessage (the drones demo's tf).

ROS bags (needs rosbags and mcap-ros2-support): /tf + /tf_static messages per second from the nav2
MCAP (tests/data/nav2_turtlebot.mcap) into a Buffer with ``load_buffer``, side by side with rosbags'
own read+decode loop and mcap-ros2-support's (decode only, no buffer: the references do less);
then 1M transforms (100k TFMessages of 10, a generated rosbag2 MCAP) into a Buffer against rosbags'
decode loop over the same file; then 1M transforms from a zentf MCAP recording and from a rosbag2
SQLite bag, each against its per-message Python path and the libraries' own decode loop; then ``bag
convert`` of 1M transforms from a rosbag2 MCAP and from a ROS 1 bag to a zentf MCAP, against the Python
path it replaces and rosbags' decode loop; then a
generated ROS 2 MCAP of ``--big-mb`` MB (in /tmp, deleted after) loaded into a Buffer in a child
process: time, and memory (peak RSS growth) against the raw transform bytes (stamp + 7 float64 = 64 B
per transform), and ``tf echo --bag BIG --time T`` /
``--start/--end`` and ``tf why --bag BIG --time T`` (whole process, reading only the chunks around T).

    python bench/bag.py [-n 20000] [--big-mb 1024] [--only-ros] [--only-formats] [--only-convert] [--big-ref]
"""
from __future__ import annotations

import argparse
import functools
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from zentf.demos.frames_publisher import drone_poses  # noqa: E402
from zentf.transport.wire import codec as wire  # noqa: E402
from zentf.tools.bag import BagReader, BagWriter, Player, Recorder  # noqa: E402
from zentf.core.messages import TFMessage  # noqa: E402

ENC = f"application/msgpack;{TFMessage.TYPE_NAME}"


def payload(i: int) -> bytes:
    t = 1_700_000_000 + i * 0.02
    return wire.encode_tf([{"header": {"stamp": {"sec": int(t), "nanosec": int((t % 1) * 1e9)}, "frame_id": p},
                            "child_frame_id": c,
                            "transform": {"translation": dict(zip("xyz", tr)), "rotation": dict(zip("xyzw", q))}}
                           for p, c, tr, q in drone_poses(t)])


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def sessions():
    import zenoh

    from zentf.transport.options import ZenohOptions

    ep = f"tcp/127.0.0.1:{free_port()}"
    a = ZenohOptions(listen=[ep], no_multicast=True, mode="peer").open_session()
    b = ZenohOptions(connect=[ep], no_multicast=True, mode="peer").open_session()
    return a, b, zenoh


def wait_matching(pub, timeout: float = 5.0) -> None:
    end = time.monotonic() + timeout
    while not pub.matching_status.matching and time.monotonic() < end:
        time.sleep(0.01)
    time.sleep(0.2)  # let the peer link settle (first puts of a fresh peer can be lost)


def bench_write(msgs: list[bytes], d: Path) -> tuple[float, float]:
    from mcap.writer import Writer

    t = time.perf_counter()
    with BagWriter(d / "w.mcap") as w:
        for i, p in enumerate(msgs):
            w.write("tf", p, ENC, "/bench", 1_000_000 * i)
    ours = len(msgs) / (time.perf_counter() - t)
    t = time.perf_counter()
    with open(d / "ref.mcap", "wb") as f:
        ref = Writer(f, chunk_size=64 * 1024)
        ref.start(profile="zentf", library="bench")
        sid = ref.register_schema(name=TFMessage.TYPE_NAME, encoding="msgpack", data=b"")
        cid = ref.register_channel(topic="tf", message_encoding="msgpack", schema_id=sid)
        for i, p in enumerate(msgs):
            ref.add_message(channel_id=cid, log_time=1_000_000 * i, data=p, publish_time=1_000_000 * i, sequence=i)
        ref.finish()
    return ours, len(msgs) / (time.perf_counter() - t)


def bench_read(n: int, d: Path) -> tuple[float, float]:
    from mcap.stream_reader import StreamReader
    from mcap.records import Message

    t = time.perf_counter()
    got = sum(1 for _ in BagReader(d / "w.mcap"))
    ours = got / (time.perf_counter() - t)
    t = time.perf_counter()
    with open(d / "ref.mcap", "rb") as f:
        ref_n = sum(1 for r in StreamReader(f).records if isinstance(r, Message))
    assert got == ref_n == n, (got, ref_n, n)
    return ours, ref_n / (time.perf_counter() - t)


def pump(session, key: str, msgs: list[bytes], zenoh) -> None:
    pub = session.declare_publisher(key, encoding=zenoh.Encoding(ENC), congestion_control=zenoh.CongestionControl.BLOCK)
    wait_matching(pub)
    for p in msgs:
        pub.put(p, attachment=b"/bench")
    pub.undeclare()


def wait_count(get, n: int, timeout: float = 60.0) -> float:
    end = time.monotonic() + timeout
    while get() < n and time.monotonic() < end:
        time.sleep(0.002)
    return time.perf_counter()


def pump_process(endpoint: str, key: str, n: int) -> subprocess.Popen:
    """A separate publisher process (the recorder gets its own GIL, as in real use)."""
    return subprocess.Popen([sys.executable, __file__, "--pump", endpoint, key, "-n", str(n)],
                            stdout=subprocess.PIPE, text=True)


def _pump_main(endpoint: str, key: str, n: int) -> None:
    import zenoh

    from zentf.transport.options import ZenohOptions

    s = ZenohOptions(connect=[endpoint], no_multicast=True, mode="peer").open_session()
    msgs = [payload(i) for i in range(n)]
    pub = s.declare_publisher(key, encoding=zenoh.Encoding(ENC), congestion_control=zenoh.CongestionControl.BLOCK)
    wait_matching(pub)
    print("go", flush=True)
    for p in msgs:
        pub.put(p, attachment=b"/bench")
    time.sleep(1.0)
    s.close()


def _node(session, name: str):
    """A hidden zentf node on an open session (the recorder and player work through a node's wire)."""
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions

    return Node(name, options=NodeOptions(), session=session, check_unique=False)


def bench_record(msgs: list[bytes], d: Path) -> tuple[float, float]:
    from zentf.transport.options import ZenohOptions

    ep = f"tcp/127.0.0.1:{free_port()}"
    b = ZenohOptions(listen=[ep], no_multicast=True, mode="peer").open_session()
    n = len(msgs)
    try:
        w = BagWriter(d / "rec.mcap")
        node = _node(b, "_bench_recorder")
        rec = Recorder(node, w, ["/bench/rec"])
        child = pump_process(ep, "bench/rec", n)
        child.stdout.readline()
        t = time.perf_counter()
        elapsed = wait_count(lambda: w.messages, n) - t
        ours = w.messages / elapsed
        child.wait(30)
        rec.close()
        node.shutdown()
        w.close()
        count = [0]

        def on(_s) -> None:
            count[0] += 1

        sub = b.declare_subscriber("bench/raw", on)
        child = pump_process(ep, "bench/raw", n)
        child.stdout.readline()
        t = time.perf_counter()
        elapsed = wait_count(lambda: count[0], n) - t
        ref = count[0] / elapsed
        child.wait(30)
        sub.undeclare()
        return ours, ref
    finally:
        b.close()


def bench_play(msgs: list[bytes], d: Path) -> tuple[float, float, int]:
    a, b, zenoh = sessions()
    try:
        n = len(msgs)
        count = [0]

        def on(_s) -> None:
            count[0] += 1

        sub = b.declare_subscriber("tf", on)
        # The player declares its publisher on the first message: warm the route with a probe bag.
        node = _node(a, "_bench_player")
        player = Player(node, d / "w.mcap", rate=1e9)
        probe = a.declare_publisher("tf")
        wait_matching(probe)
        probe.undeclare()
        t = time.perf_counter()
        stats = player.play()
        wait_count(lambda: count[0], n, 10)
        ours = stats.messages / (time.perf_counter() - t)
        got = count[0]
        player.close()
        node.shutdown()
        sub.undeclare()
        count[0] = 0
        sub = b.declare_subscriber("bench/raw", on)
        pub = a.declare_publisher("bench/raw", encoding=zenoh.Encoding(ENC),
                                  congestion_control=zenoh.CongestionControl.BLOCK)
        wait_matching(pub)
        t = time.perf_counter()
        for p in BagReader(d / "ref.mcap"):
            pub.put(p.payload)
        wait_count(lambda: count[0], n, 10)
        ref = count[0] / (time.perf_counter() - t)
        return ours, ref, got
    finally:
        a.close()
        b.close()


# ---------------------------------------------------------------- ROS bags

NAV2 = Path(__file__).resolve().parent.parent / "tests" / "data" / "nav2_turtlebot.mcap"
TF_TOPICS = ("/tf", "/tf_static")


def _rosbags_transforms(path: Path) -> int:
    """The reference: rosbags reads and decodes every message of a tf-only bag; the transforms in it."""
    from rosbags.highlevel import AnyReader

    n = 0
    with AnyReader([path]) as r:
        for c, _, raw in r.messages():
            n += len(r.deserialize(raw, c.msgtype).transforms)
    return n


def _interleaved(cases: dict, repeat: int, n_tf: int) -> dict:
    """Each case's seconds over ``repeat`` rounds of all cases in turn (a load spike hits them alike); each
    must return n_tf, the transforms it read."""
    times: dict = {k: [] for k in cases}
    for _ in range(repeat):
        for k, fn in cases.items():
            t = time.perf_counter()
            got = fn()
            times[k].append(time.perf_counter() - t)
            assert got == n_tf, (k, got, n_tf)
    return times


def _best(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def bench_nav2(repeat: int = 5) -> list[tuple[str, float]]:
    """(name, tf msgs/s) for zentf load_buffer and the two references, best of ``repeat`` (interleaved)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    from zentf.tools.bag import load_buffer
    from zentf.tools.bag.tfdecode import cdr_tf_decoder

    def rosbags_loop() -> int:
        n = 0
        with AnyReader([NAV2]) as r:
            conns = [c for c in r.connections if c.topic in TF_TOPICS]
            for c, _, raw in r.messages(connections=conns):
                r.deserialize(raw, c.msgtype)
                n += 1
        return n

    def mcap_ros2_loop() -> int:
        n = 0
        with open(NAV2, "rb") as f:
            for _ in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(topics=list(TF_TOPICS)):
                n += 1
        return n

    n = rosbags_loop()
    assert mcap_ros2_loop() == n
    buf = load_buffer(NAV2)
    assert buf.lookup_transform("map", "oakd_rgb_camera_optical_frame", 0)
    times = {"zentf": [], "rosbags": [], "mcap-ros2-support": []}
    for _ in range(repeat):  # interleaved: a load spike hits all three alike
        times["zentf"].append(_best(lambda: load_buffer(NAV2), 1))
        times["rosbags"].append(_best(rosbags_loop, 1))
        times["mcap-ros2-support"].append(_best(mcap_ros2_loop, 1))
    print(f"nav2 MCAP: {n} /tf + /tf_static messages; zentf decodes /tf with {cdr_tf_decoder()[0]}")
    return [(k, n / min(v)) for k, v in times.items()]


def _marker_offsets(template: bytes, marker: int, per_msg: int) -> list[int]:
    """Where a template message's per_msg stamps (sec = marker, little-endian) are, to stamp copies of it."""
    packed = struct.pack("<I", marker)
    offsets = []
    i = template.find(packed)
    while i >= 0:
        offsets.append(i)
        i = template.find(packed, i + 4)
    assert len(offsets) == per_msg, offsets
    return offsets


def _cdr_template(per_msg: int) -> tuple[bytes, list[int], str]:
    """A CDR TFMessage of ``per_msg`` transforms (a chain of links), the offsets of its stamps, the type's
    definition."""

    from rosbags.typesys import Stores, get_typestore

    from zentf.ros.tf import encode_tf

    frames = ["base_link"] + [f"link_{i}" for i in range(per_msg)]
    marker = 0x5A5A5A5A
    items = [{"header": {"stamp": {"sec": marker, "nanosec": 0}, "frame_id": frames[i]},
              "child_frame_id": frames[i + 1],
              "transform": {"translation": {"x": 0.1 * i, "y": 0.0, "z": 0.05},
                            "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}} for i in range(per_msg)]
    template = encode_tf(items)
    offsets = _marker_offsets(template, marker, per_msg)
    store = get_typestore(Stores.ROS2_HUMBLE)
    msgdef, _ = store.generate_msgdef("tf2_msgs/msg/TFMessage", ros_version=2)
    return template, offsets, msgdef


def _stamped(template: bytes, offsets: list[int], n: int):
    """(stamp ns, payload) of n messages at 100 Hz from 1000 s, the template's stamps patched."""

    pack = struct.Struct("<iI").pack_into
    buf = bytearray(template)
    t0 = 1_000_000_000_000
    for k in range(n):
        stamp = t0 + k * 10_000_000
        sec, nsec = divmod(stamp, 1_000_000_000)
        for off in offsets:
            pack(buf, off, sec, nsec)
        yield stamp, bytes(buf)


def generate_big(path: Path, target_mb: int, per_msg: int = 10, messages: int | None = None) -> tuple[int, int]:
    """A ROS 2 MCAP of ~target_mb MB: TFMessages of ``per_msg`` transforms (a chain of links at 100 Hz,
    stamps patched into one encoded template). Returns (messages, transforms)."""
    from mcap.writer import CompressionType, Writer

    template, offsets, msgdef = _cdr_template(per_msg)
    n = messages or max(1, target_mb * 1024 * 1024 // (len(template) + 31))
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=1024 * 1024, compression=CompressionType.NONE)
        w.start(profile="ros2", library="zentf bench")
        sid = w.register_schema(name="tf2_msgs/msg/TFMessage", encoding="ros2msg", data=msgdef.encode())
        cid = w.register_channel(topic="/tf", message_encoding="cdr", schema_id=sid)
        for k, (stamp, data) in enumerate(_stamped(template, offsets, n)):
            w.add_message(channel_id=cid, log_time=stamp, publish_time=stamp, data=data, sequence=k)
        w.finish()
    return n, n * per_msg


def generate_sqlite(folder: Path, messages: int, per_msg: int = 10) -> int:
    """A rosbag2 SQLite bag (written by rosbags) of the generator's TFMessages; returns the transforms."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    template, offsets, _ = _cdr_template(per_msg)
    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(folder, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        conn = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store)
        for stamp, data in _stamped(template, offsets, messages):
            w.write(conn, stamp, data)
    return messages * per_msg


def generate_zentf(path: Path, messages: int, per_msg: int = 10) -> int:
    """A zentf MCAP recording (BagWriter, msgpack TFMessages from wire.encode_tf, as ``zentf bag record``
    writes them) of the generator's chain at 100 Hz; returns the transforms."""
    frames = ["base_link"] + [f"link_{i}" for i in range(per_msg)]
    t0 = 1_000_000_000_000
    with BagWriter(path) as w:
        for k in range(messages):
            stamp = t0 + k * 10_000_000
            st = {"sec": stamp // 1_000_000_000, "nanosec": stamp % 1_000_000_000}
            items = [{"header": {"stamp": st, "frame_id": frames[i]}, "child_frame_id": frames[i + 1],
                      "transform": {"translation": {"x": 0.1 * i, "y": 0.0, "z": 0.05},
                                    "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}} for i in range(per_msg)]
            w.write("tf", wire.encode_tf(items), ENC, "/bench", stamp)
    return messages * per_msg


def _rss_kb() -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def _load_child(path: str) -> None:
    """Child: load a bag into a Buffer; print one JSON line of seconds and memory."""
    import json
    import resource

    from zentf.tools.bag import load_buffer

    base = _rss_kb()
    t = time.perf_counter()
    buf = load_buffer(path)
    seconds = time.perf_counter() - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    samples = sum(f["samples"] for f in buf.frame_info())
    print(json.dumps({"seconds": seconds, "rss_growth": (_rss_kb() - base) * 1024,
                      "peak_growth": (peak - base) * 1024, "held": buf.memory_bytes(), "samples": samples}))


def bench_big(target_mb: int, big_ref: bool = False) -> None:
    import json

    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        path = Path(tmp) / "big_tf.mcap"
        t = time.perf_counter()
        n_msgs, n_tf = generate_big(path, target_mb)
        size = os.path.getsize(path)
        print(f"\ngenerated {path.name}: {size / 2**20:,.0f} MiB, {n_msgs:,} TFMessages, {n_tf:,} transforms "
              f"in {time.perf_counter() - t:.0f} s")
        out = subprocess.run([sys.executable, __file__, "--load-child", str(path)], capture_output=True, text=True,
                             check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        assert r["samples"] == n_tf, (r, n_tf)
        raw = n_tf * 64
        print(f"{'load into a Buffer':<28} {r['seconds']:8.1f} s  {n_msgs / r['seconds']:10,.0f} msg/s "
              f"{n_tf / r['seconds']:12,.0f} transforms/s")
        print(f"{'raw transform bytes':<28} {raw / 2**20:8.0f} MiB (64 B x {n_tf:,})")
        print(f"{'buffer storage (arrays)':<28} {r['held'] / 2**20:8.0f} MiB  = {r['held'] / raw:.2f}x raw")
        print(f"{'process peak RSS growth':<28} {r['peak_growth'] / 2**20:8.0f} MiB  = {r['peak_growth'] / raw:.2f}x raw "
              f"(target <= 1.2x), {r['peak_growth'] / max(1, r['held']):.2f}x the buffer's storage")
        print(f"{'load: target <= 15 s':<28} {'met' if r['seconds'] <= 15 else 'NOT met'}")
        at = 1_000 + n_msgs * 0.01 / 2  # the generator's stamps: 1000 s + 10 ms a message
        for label, cmd, extra in (
                ("tf echo --bag --time T", "echo", ["--time", f"{at:.3f}"]),
                ("tf echo --bag --start/--end", "echo", ["--start", f"{at - 1:.3f}", "--end", f"{at + 1:.3f}"]),
                ("tf why --bag --time T", "why", ["--time", f"{at:.3f}"])):
            walls = []
            for _ in range(3):
                t = time.perf_counter()
                out = subprocess.run([sys.executable, "-m", "zentf.cli", "tf", cmd, "base_link", "link_9", "--bag",
                                      str(path), *extra], capture_output=True, text=True, timeout=300)
                walls.append(time.perf_counter() - t)
                assert out.stdout.startswith("At time") if cmd == "echo" else \
                    (out.returncode == 0 and "link_9" in out.stdout), out.stdout + out.stderr
            print(f"{label:<28} {min(walls):8.2f} s  (runs {', '.join(f'{w:.2f}' for w in walls)}; whole process, "
                  f"target <= 1 s; the full load above: {r['seconds']:.1f} s)")
        if not big_ref:
            return
        from rosbags.highlevel import AnyReader

        t = time.perf_counter()
        with AnyReader([path]) as reader:  # the reference: rosbags' decode alone, no buffer
            n = sum(1 for c, _, raw_msg in reader.messages() if reader.deserialize(raw_msg, c.msgtype) is not None)
        ref = time.perf_counter() - t
        assert n == n_msgs
        print(f"{'rosbags read + decode only':<28} {ref:8.1f} s  {n / ref:10,.0f} msg/s  "
              f"(zentf loads {ref / r['seconds']:.2f}x as fast)")


def bench_million(repeat: int = 3) -> None:
    """1M transforms (100k TFMessages of 10) from a rosbag2 MCAP into a Buffer, against rosbags' own decode
    loop over the same file (no buffer: the reference does less), interleaved runs."""

    from zentf.tools.bag import load_buffer

    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        path = Path(tmp) / "million.mcap"
        n_msgs, n_tf = generate_big(path, 0, messages=100_000)

        rosbags_loop = functools.partial(_rosbags_transforms, path)

        ours, ref = [], []
        for _ in range(repeat):
            t = time.perf_counter()
            buf = load_buffer(path)
            ours.append(time.perf_counter() - t)
            t = time.perf_counter()
            assert rosbags_loop() == n_tf
            ref.append(time.perf_counter() - t)
        assert sum(f["samples"] for f in buf.frame_info()) == n_tf
    print(f"\n1M transforms from a rosbag2 MCAP ({n_msgs:,} TFMessages of 10), {repeat} interleaved runs")
    print(f"{'':<34} {'best s':>8} {'transforms/s':>14}  runs (s)")
    for name, runs in (("zentf load_buffer (into a Buffer)", ours), ("rosbags read + decode loop", ref)):
        print(f"{name:<34} {min(runs):8.3f} {n_tf / min(runs):14,.0f}  {', '.join(f'{x:.3f}' for x in runs)}")
    print(f"zentf / rosbags: {min(ref) / min(ours):.1f}x (target >= 10x); zentf {n_tf / min(ours) / 1e6:.2f}M "
          "transforms/s (target >= 1M/s)")


class _PythonPath:
    """Today's per-message Python path of the loader, for a before/after row: zentf recordings through
    the Python msgpack decoder, .db3 rows through Python's sqlite3."""

    def __enter__(self):
        from zentf.tools.bag import bulk, sqliteapi
        from zentf.tools.bag.tfload import KIND_OTHER

        self.saved = bulk.KIND_MSGPACK, sqliteapi.unavailable
        bulk.KIND_MSGPACK = KIND_OTHER
        sqliteapi.unavailable = lambda: "bench: the Python path"
        return self

    def __exit__(self, *exc):
        from zentf.tools.bag import bulk, sqliteapi

        bulk.KIND_MSGPACK, sqliteapi.unavailable = self.saved


def bench_formats(repeat: int = 3, messages: int = 100_000) -> None:
    """1M transforms (100k TFMessages of 10) into a Buffer from a zentf MCAP recording and from a rosbag2
    SQLite bag: zentf's compiled load, its per-message Python path (before), and the independent libraries'
    own read + decode loop over the same file (no buffer: the references do less), interleaved runs."""
    import msgpack
    from mcap.reader import make_reader

    from zentf.tools.bag import load_buffer

    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        zpath, sqpath = Path(tmp) / "million_zentf.mcap", Path(tmp) / "million_db3"
        t = time.perf_counter()
        n_tf = generate_zentf(zpath, messages)
        assert generate_sqlite(sqpath, messages) == n_tf
        print(f"\ngenerated a zentf MCAP ({zpath.stat().st_size / 2**20:.0f} MiB) and a rosbag2 SQLite bag "
              f"({sum(f.stat().st_size for f in sqpath.iterdir()) / 2**20:.0f} MiB) of {n_tf:,} transforms "
              f"({messages:,} TFMessages of 10) in {time.perf_counter() - t:.0f} s")

        def mcap_msgpack_loop() -> int:
            n = 0
            with open(zpath, "rb") as f:
                for _, _, m in make_reader(f).iter_messages():
                    n += len(msgpack.unpackb(m.data)["transforms"])
            return n

        rosbags_loop = functools.partial(_rosbags_transforms, sqpath)

        def load(path: Path, python: bool) -> int:
            if python:
                with _PythonPath():
                    buf = load_buffer(path)
            else:
                buf = load_buffer(path)
            return sum(f["samples"] for f in buf.frame_info())

        cases = {("zentf MCAP", "zentf"): lambda: load(zpath, False),
                 ("zentf MCAP", "before"): lambda: load(zpath, True),
                 ("zentf MCAP", "ref"): mcap_msgpack_loop,
                 ("rosbag2 SQLite", "zentf"): lambda: load(sqpath, False),
                 ("rosbag2 SQLite", "before"): lambda: load(sqpath, True),
                 ("rosbag2 SQLite", "ref"): rosbags_loop}
        times = _interleaved(cases, repeat, n_tf)
        at = 1_000 + messages * 0.01 / 2
        echo = {}
        for fmt, path in (("zentf MCAP", zpath), ("rosbag2 SQLite", sqpath)):
            walls = []
            for _ in range(3):
                t = time.perf_counter()
                out = subprocess.run([sys.executable, "-m", "zentf.cli", "tf", "echo", "base_link", "link_9", "--bag",
                                      str(path), "--time", f"{at:.3f}"], capture_output=True, text=True, timeout=300)
                walls.append(time.perf_counter() - t)
                assert out.stdout.startswith("At time"), out.stderr
            echo[fmt] = walls
    refs = {"zentf MCAP": "mcap reader + msgpack.unpackb", "rosbag2 SQLite": "rosbags read + decode"}
    print(f"1M transforms into a Buffer, best of {repeat} interleaved runs (transforms/s; load "
          f"{os.getloadavg()[0]:.1f})")
    print(f"{'format':<16} {'zentf':>12} {'before (Python/msg)':>20} {'reference':<30} {'ref':>12} {'zentf/ref':>9}")
    for fmt, ref in refs.items():
        z, b, r = (n_tf / min(times[(fmt, k)]) for k in ("zentf", "before", "ref"))
        print(f"{fmt:<16} {z:12,.0f} {b:20,.0f} {ref:<30} {r:12,.0f} {z / r:8.1f}x")
        print(f"{'':<16} runs (s): zentf {', '.join(f'{x:.2f}' for x in times[(fmt, 'zentf')])}; before "
              f"{', '.join(f'{x:.2f}' for x in times[(fmt, 'before')])}; reference "
              f"{', '.join(f'{x:.2f}' for x in times[(fmt, 'ref')])}")
    for fmt, walls in echo.items():
        print(f"tf echo --bag ({fmt}) --time T: {min(walls):.2f} s (runs {', '.join(f'{w:.2f}' for w in walls)}; "
              f"whole process, the chunks/rows around T)")


def _ros1_template(per_msg: int) -> tuple[bytes, list[int], object]:
    """A ROS 1 TFMessage of ``per_msg`` transforms (the chain of _cdr_template), its stamps' offsets, and a
    rosbags typestore holding tf2_msgs/TFMessage as ROS 1 defines it."""

    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)  # has geometry_msgs and std_msgs; tf2_msgs/TFMessage added
    store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    T = store.types
    frames = ["base_link"] + [f"link_{i}" for i in range(per_msg)]
    marker = 0x5A5A5A5A
    items = [T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=marker, nanosec=0),
                                        frame_id=frames[i]),
        child_frame_id=frames[i + 1],
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=0.1 * i, y=0.0, z=0.05),
            rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))) for i in range(per_msg)]
    template = bytes(store.serialize_ros1(T["tf2_msgs/msg/TFMessage"](transforms=items), "tf2_msgs/msg/TFMessage"))
    offsets = _marker_offsets(template, marker, per_msg)
    return template, offsets, store


def generate_ros1(path: Path, messages: int, per_msg: int = 10) -> int:
    """A ROS 1 bag (written by rosbags, lz4 chunks) of the generator's chain at 100 Hz; returns the transforms."""
    from rosbags.rosbag1 import Writer

    template, offsets, store = _ros1_template(per_msg)
    w = Writer(path)
    w.set_compression(Writer.CompressionFormat.LZ4)
    with w:
        conn = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store, callerid="/bench")
        for stamp, data in _stamped(template, offsets, messages):
            w.write(conn, stamp, data)
    return messages * per_msg


def bench_convert(repeat: int = 3, messages: int = 100_000) -> None:
    """``bag convert`` of 1M transforms (100k TFMessages of 10) from a rosbag2 MCAP and from a ROS 1 bag to a
    zentf MCAP: the compiled TFMessage writers, the Python path they replace (rosbags' decoder, to_plain,
    msgpack: before), and rosbags' own read + decode loop over the same file (no writing: the reference does
    less), interleaved runs."""

    from zentf.tools.bag import source
    from zentf.tools.bag.convert import convert

    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        r2, r1 = Path(tmp) / "million.mcap", Path(tmp) / "million.bag"
        t = time.perf_counter()
        _, n_tf = generate_big(r2, 0, messages=messages)
        assert generate_ros1(r1, messages) == n_tf
        print(f"\ngenerated a rosbag2 MCAP ({r2.stat().st_size / 2**20:.0f} MiB) and a ROS 1 bag "
              f"({r1.stat().st_size / 2**20:.0f} MiB) of {n_tf:,} transforms ({messages:,} TFMessages of 10) in "
              f"{time.perf_counter() - t:.0f} s")
        out = Path(tmp) / "out.mcap"

        def run(path: Path, compiled: bool) -> int:
            source.COMPILED_TF = compiled
            try:
                r = convert(path, out, to="zentf")
            finally:
                source.COMPILED_TF = True
            out.unlink()
            return r["messages"] * 10

        cases = {}
        for fmt, path in (("rosbag2 MCAP", r2), ("ROS 1 bag", r1)):
            cases[(fmt, "zentf")] = lambda path=path: run(path, True)
            cases[(fmt, "before")] = lambda path=path: run(path, False)
            cases[(fmt, "ref")] = functools.partial(_rosbags_transforms, path)
        times = _interleaved(cases, repeat, n_tf)
    print(f"bag convert to a zentf MCAP, 1M transforms, best of {repeat} interleaved runs (transforms/s; load "
          f"{os.getloadavg()[0]:.1f})")
    print(f"{'format':<14} {'zentf':>12} {'before (Python/msg)':>20} {'rosbags read + decode':>22} "
          f"{'zentf/before':>12} {'zentf/ref':>9}")
    for fmt in ("rosbag2 MCAP", "ROS 1 bag"):
        z, b, r = (n_tf / min(times[(fmt, k)]) for k in ("zentf", "before", "ref"))
        print(f"{fmt:<14} {z:12,.0f} {b:20,.0f} {r:22,.0f} {z / b:11.1f}x {z / r:8.1f}x")
        print(f"{'':<14} runs (s): zentf {', '.join(f'{x:.2f}' for x in times[(fmt, 'zentf')])}; before "
              f"{', '.join(f'{x:.2f}' for x in times[(fmt, 'before')])}; reference "
              f"{', '.join(f'{x:.2f}' for x in times[(fmt, 'ref')])}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-n", type=int, default=20000, help="messages per run")
    ap.add_argument("--big-mb", type=int, default=1024, help="size of the generated ROS 2 bag (0: skip)")
    ap.add_argument("--only-ros", action="store_true", help="only the ROS bag rows")
    ap.add_argument("--big-ref", action="store_true", help="also time rosbags' decode of the big bag (~2 min a GB)")
    ap.add_argument("--pump", nargs=2, metavar=("ENDPOINT", "KEY"), help=argparse.SUPPRESS)
    ap.add_argument("--load-child", metavar="PATH", help=argparse.SUPPRESS)
    ap.add_argument("--only-formats", action="store_true", help="only the zentf MCAP / SQLite million rows")
    ap.add_argument("--only-convert", action="store_true", help="only the bag convert million rows")
    args = ap.parse_args()
    if args.pump:
        _pump_main(args.pump[0], args.pump[1], args.n)
        return 0
    if args.load_child:
        _load_child(args.load_child)
        return 0
    if args.only_formats:
        bench_formats()
        return 0
    if args.only_convert:
        bench_convert()
        return 0
    if not args.only_ros:
        zenoh_rows(args)
    rows = bench_nav2()
    zentf_rate = rows[0][1]
    faster = max(r for _, r in rows[1:])
    print(f"{'ROS 2 /tf into a Buffer':<40} {'msg/s':>12} {'vs zentf':>9}")
    for name, rate in rows:
        print(f"{name:<40} {rate:12,.0f} {zentf_rate / rate:8.2f}x")
    print(f"zentf / the faster reference: {zentf_rate / faster:.2f}x (target >= 2)")
    bench_million()
    bench_formats()
    bench_convert()
    if args.big_mb:
        bench_big(args.big_mb, args.big_ref)
    return 0


def zenoh_rows(args: argparse.Namespace) -> None:
    msgs = [payload(i) for i in range(args.n)]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        rows = [("MCAP write", "mcap.Writer", *bench_write(msgs, d))]
        rows.append(("MCAP read", "mcap StreamReader", *bench_read(args.n, d)))
        rows.append(("record over Zenoh (pub in a 2nd process)", "bare subscriber (count only)", *bench_record(msgs, d)))
        ours, ref, got = bench_play(msgs, d)
        rows.append(("play over Zenoh (full speed)", "bare put loop", ours, ref))
        size = os.path.getsize(d / "w.mcap")
    print(f"bag throughput, {args.n} TFMessages of {len(msgs[0])} B (file {size / 1024:.0f} KiB), "
          f"{os.cpu_count()} CPUs")
    print(f"{'stage':<40} {'zentf msg/s':>12} {'reference':<30} {'ref msg/s':>12} {'ratio':>6}")
    for name, refname, o, r in rows:
        print(f"{name:<40} {o:12,.0f} {refname:<30} {r:12,.0f} {o / r:6.2f}")
    print(f"(play: subscriber received {got}/{args.n})")


if __name__ == "__main__":
    sys.exit(main())
