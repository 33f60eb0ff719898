"""Bag throughput (messages/s): zentf.tools.bag against the bare libraries it sits on, measured in the same run.

Rows: MCAP write (BagWriter vs mcap.Writer), MCAP read (BagReader vs mcap StreamReader), record over
Zenoh (Recorder into a file vs a bare Zenoh subscriber that only counts), play over Zenoh (Player
at full speed vs a bare put loop). Payload: a 2-transform TFMessage (the drones demo's tf).

    python bench/bag.py [-n 20000]
"""
from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from nodes.frames_publisher import drone_poses  # noqa: E402
from zentf import wire  # noqa: E402
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

    from zentf.options import ZenohOptions

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

    from zentf.options import ZenohOptions

    s = ZenohOptions(connect=[endpoint], no_multicast=True, mode="peer").open_session()
    msgs = [payload(i) for i in range(n)]
    pub = s.declare_publisher(key, encoding=zenoh.Encoding(ENC), congestion_control=zenoh.CongestionControl.BLOCK)
    wait_matching(pub)
    print("go", flush=True)
    for p in msgs:
        pub.put(p, attachment=b"/bench")
    time.sleep(1.0)
    s.close()


def bench_record(msgs: list[bytes], d: Path) -> tuple[float, float]:
    from zentf.options import ZenohOptions

    ep = f"tcp/127.0.0.1:{free_port()}"
    b = ZenohOptions(listen=[ep], no_multicast=True, mode="peer").open_session()
    n = len(msgs)
    try:
        w = BagWriter(d / "rec.mcap")
        rec = Recorder(b, w, ["bench/rec"])
        child = pump_process(ep, "bench/rec", n)
        child.stdout.readline()
        t = time.perf_counter()
        elapsed = wait_count(lambda: w.messages, n) - t
        ours = w.messages / elapsed
        child.wait(30)
        rec.close()
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
        player = Player(a, d / "w.mcap", rate=1e9)
        probe = a.declare_publisher("tf")
        wait_matching(probe)
        probe.undeclare()
        t = time.perf_counter()
        stats = player.play()
        wait_count(lambda: count[0], n, 10)
        ours = stats.messages / (time.perf_counter() - t)
        got = count[0]
        player.close()
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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-n", type=int, default=20000, help="messages per run")
    ap.add_argument("--pump", nargs=2, metavar=("ENDPOINT", "KEY"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.pump:
        _pump_main(args.pump[0], args.pump[1], args.n)
        return 0
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
