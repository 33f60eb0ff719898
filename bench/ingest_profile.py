"""Where a listener's per-message time goes: the tf thread against the raw ring loop it is built on, in one
process, without the network (local puts fill a ring first, then one thread drains it).

    python bench/ingest_profile.py [--n 20000] [--runs 5] [--wire zentf|ros2|both]
    python bench/ingest_profile.py --callgrind [--n 20000] [--wire ...]   (needs valgrind)
    python bench/ingest_profile.py --cold [--n 3000] [--gap-ms 1] [--wire ...]

Times: the draining thread's CPU per message (its own clock, so the load of a shared machine moves it
less than wall time), best and median of --runs, for the raw ring loop (try_recv, payload and attachment
to bytes, nothing else: bench/e2e.py's floor) and for zentf's tf thread (zentf.transport.ingest.thread.serve
into a Buffer, 1 transform a message, one sender, as bench/e2e.py floods it). ``--callgrind`` counts the
instructions of zentf's thread instead (callgrind, collecting inside ``serve`` only) and splits them into
zenoh-python's own per-message work (the ring, the sample's payload and attachment, the sample's
deallocation: what the raw ring loop does too) and zentf's (decode, insert, queues, the rest).
``--cold`` times the steps of one message's handling, in the tf thread's order, for a message that
arrives alone (another process puts one every --gap-ms over loopback: the thread wakes from the ring
for each, its caches cold, which is what bench/e2e.py's latency measures) and for the same messages
back to back (a ring filled in-process, drained: the flood's warm case). The steps are Python calls
to the same zenoh-python accessors and to the listener's compiled ``ingest(payload, authority)``
(decode, future guard, insert), each timed with perf_counter_ns: zenoh-python's part against zentf's.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

NS = 1_000_000_000


def tf_dict(child: str, stamp: int) -> dict:
    return {"header": {"stamp": {"sec": stamp // NS, "nanosec": stamp % NS}, "frame_id": "world"},
            "child_frame_id": child, "transform": {"translation": {"x": 1.0, "y": 2.0, "z": 3.0},
                                                   "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}


class Rig:
    """A Zenoh session whose local puts fill a ring of ``n`` samples (the payloads of bench/e2e.py's flood)."""

    def __init__(self, wire: str, n: int, zenoh_options: Any = None) -> None:
        import zenoh

        from zentf.transport.options import ZenohOptions
        from zentf.transport.wire.profiles import make_profile, ros2_attachment

        self.zenoh = zenoh
        self.wire, self.n = wire, n
        self.profile = make_profile(wire)
        base = time.time_ns()
        self.payloads = [self.profile.encode_tf([tf_dict(f"f{i % 100}", base + i * 1000)]) for i in range(n)]
        self.attachments = ([zenoh.ZBytes(b"/bench/bench_sender")] if wire == "zentf" else
                            [zenoh.ZBytes(ros2_attachment(i + 1, base + i, b"G" * 16)) for i in range(n)])
        self.session = (zenoh_options or ZenohOptions(mode="peer", no_multicast=True)).open_session()

    def ring(self, key: str):
        sub = self.session.declare_subscriber(key, self.zenoh.handlers.RingChannel(self.n + 16))
        pub = self.session.declare_publisher(key)
        for i, p in enumerate(self.payloads):
            pub.put(p, attachment=self.attachments[i % len(self.attachments)])
        pub.undeclare()
        return sub

    def floor(self) -> float:
        """CPU µs per message of the raw ring loop."""
        sub = self.ring("bench/floor")
        out: dict = {}

        def loop() -> None:
            recv, try_recv = sub.handler.recv, sub.handler.try_recv
            c0 = time.thread_time()
            n = 0
            sample = try_recv()
            while n < self.n:
                if sample is None:
                    sample = recv()
                sample.payload.to_bytes()
                sample.attachment.to_bytes()
                n += 1
                sample = try_recv()
            out["cpu"] = time.thread_time() - c0

        t = threading.Thread(target=loop)
        t.start()
        t.join()
        sub.undeclare()
        return out["cpu"] / self.n * 1e6

    def zentf(self) -> float:
        """CPU µs per message of zentf's tf thread (serve) into a Buffer."""
        from zentf.core.messages import TFMessage
        from zentf.transport.buffer import Buffer
        from zentf.transport.ingest.handler import IngestEvents, Senders, TfHandler
        from zentf.transport.ingest.thread import serve
        from zentf.transport.listener import _limits

        prof = self.profile
        buf = Buffer()
        sub = self.ring("bench/zentf")
        ingest = prof.tf_ingest(buf, buf, time.time_ns, 5 * NS, False)  # what a listener asks the profile for
        senders = Senders(prof.authority, prof.fixed_authority, prof.sender_of, 1024)
        handler = TfHandler(ingest, senders, IngestEvents(), "bench/zentf", prof.check_tf_encoding,
                            prof.encoding(TFMessage.TYPE_NAME))
        t = threading.Thread(target=serve, args=(sub.handler, handler, _limits()), daemon=True)
        t.start()
        while handler.messages < self.n:
            time.sleep(0.005)
        cpu = time.clock_gettime(time.pthread_getcpuclockid(t.ident))
        sub.undeclare()
        t.join(5)
        return cpu / self.n * 1e6


#: (row, substrings of callgrind functions whose inclusive counts make it), zenoh-python's rows first
CATEGORIES = [
    ("zenoh-python: the ring (try_recv, recv)", ["Handler>::__pymethod_try_recv__", "Handler>::__pymethod_recv__"]),
    ("zenoh-python: payload to bytes", ["handler_payload_of "]),
    ("zenoh-python: attachment to bytes", ["handler_attachment_of "]),
    ("zenoh-python: the sample's deallocation", ["tp_dealloc::<zenoh::sample::Sample>"]),
    ("zentf: decode", ["decoders_decode_msgpack ", "decoders_decode_cdr "]),
    ("zentf: insert (BufferCore)", ["BufferCore_ingest_one_c ", "BufferCore_ingest_begin_c ", "BufferCore_ingest_end_c "]),
]


def callgrind(wire: str, n: int) -> None:
    if shutil.which("valgrind") is None:
        sys.exit("--callgrind needs valgrind")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "cg.out")
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        "--toggle-collect=__pyx_pf_5zentf_9transport_6ingest_6thread_*serve*",
                        sys.executable, __file__, "--role", "drain", "--wire", wire, "--n", str(n)],
                       check=True, capture_output=True)
        text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", out],
                              check=True, capture_output=True, text=True).stdout
    rows = []
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+) \(\s*[\d.]+%\)\s+(.*)", line)
        if m:
            rows.append((int(m.group(1).replace(",", "")), m.group(2) + " "))
    total = next(c for c, name in rows if "PROGRAM TOTALS" in name)
    print(f"| {wire} wire: instructions per message in zentf's tf thread | Ir | share |")
    print("|---|---|---|")
    counted = zenoh = 0
    for label, keys in CATEGORIES:
        ir = 0
        for key in keys:  # a function's inclusive count once (its recursive entries carry a ')
            ir += max((c for c, name in rows if key in name and "'" not in name.split(" [")[0]), default=0)
        counted += ir
        zenoh += ir if label.startswith("zenoh") else 0
        print(f"| {label} | {ir / n:,.0f} | {ir / total:.0%} |")
    print(f"| zentf: the rest (queues, authority, counters, thread loop) | {(total - counted) / n:,.0f} | "
          f"{(total - counted) / total:.0%} |")
    print(f"| all | {total / n:,.0f} | 100% |")
    print(f"\nzenoh-python's part, which the raw ring loop does too: {zenoh / n:,.0f} Ir a message; a tf thread at "
          f"0.9x the loop's rate would have {zenoh / n / 9:,.0f} Ir a message for everything zentf does.\n")


#: (step, what it runs) for --cold, in the order the tf thread runs them
COLD_STEPS = ["zenoh-python: attachment to bytes", "zenoh-python: key compared with the subscriber's",
              "zenoh-python: payload to bytes", "zentf: decode + insert (ingest)", "zenoh-python: the sample's deallocation"]


def _steps(sample, concrete, ingest, authority, out: list) -> None:
    """One message's handling, step by step, each step's ns appended to out (see COLD_STEPS)."""
    pc = time.perf_counter_ns
    t0 = pc()
    sample.attachment.to_bytes()
    t1 = pc()
    if not sample.key_expr == concrete:
        raise RuntimeError("a sample on another key")
    t2 = pc()
    payload = sample.payload.to_bytes()
    t3 = pc()
    ingest(payload, authority)
    t4 = pc()
    del sample
    t5 = pc()
    out.append((t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4))


def _cold_sender(wire: str, endpoint: str, n: int, gap_ms: float) -> None:
    """(child) Put n of the rig's messages on bench/cold, one every gap_ms, to a subscriber at endpoint."""
    import zenoh

    from zentf.transport.options import ZenohOptions

    rig = Rig(wire, n, ZenohOptions(mode="peer", no_multicast=True, connect=[endpoint]))
    pub = rig.session.declare_publisher("bench/cold", congestion_control=zenoh.CongestionControl.BLOCK)
    while not pub.matching_status.matching:
        time.sleep(0.005)
    time.sleep(0.3)
    for i, p in enumerate(rig.payloads):
        pub.put(p, attachment=rig.attachments[i % len(rig.attachments)])
        time.sleep(gap_ms / 1000)
    rig.session.close()


def cold(wire: str, n: int, gap_ms: float) -> None:
    """Print the per-step medians of a message handled alone (cold) and back to back (warm)."""
    import zenoh

    from zentf.transport.buffer import Buffer
    from zentf.transport.options import ZenohOptions

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from e2e import free_port

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    rig = Rig(wire, n, ZenohOptions(mode="peer", no_multicast=True, listen=[endpoint]))
    prof = rig.profile
    authority = prof.fixed_authority or "/bench/bench_sender"
    results: dict[str, list] = {}
    for case in ("cold", "warm"):
        buf = Buffer()
        ingest = prof.tf_ingest(buf, buf, time.time_ns, 5 * NS, False)
        out: list = []
        if case == "cold":
            sub = rig.session.declare_subscriber("bench/cold", zenoh.handlers.RingChannel(n + 16))
            child = subprocess.Popen([sys.executable, __file__, "--role", "cold-send", "--wire", wire,
                                      "--endpoint", endpoint, "--n", str(n), "--gap-ms", str(gap_ms)])
            concrete = zenoh.KeyExpr("bench/cold")
            try:
                for _ in range(n):
                    sample = sub.handler.recv()
                    _steps(sample, concrete, ingest, authority, out)
                    del sample
            finally:
                child.wait(60)
        else:
            sub = rig.ring("bench/zentf")
            concrete = zenoh.KeyExpr("bench/zentf")
            while (sample := sub.handler.try_recv()) is not None:
                _steps(sample, concrete, ingest, authority, out)
                del sample
        sub.undeclare()
        results[case] = out[100:]  # the first ones warm the caches and the buffer up
    rig.session.close()
    print(f"| {wire} wire: one message's steps, median ns | alone, every {gap_ms:g} ms (cold) | back to back (warm) |")
    print("|---|---|---|")
    totals = {}
    for case in results:
        totals[case] = [sum(r) for r in results[case]]
    zsum = {c: 0.0 for c in results}
    for i, label in enumerate(COLD_STEPS):
        med = {c: statistics.median(r[i] for r in results[c]) for c in results}
        for c in results:
            zsum[c] += med[c] if label.startswith("zenoh") else 0
        print(f"| {label} | {med['cold']:,.0f} | {med['warm']:,.0f} |")
    print(f"| all (median of the sums) | {statistics.median(totals['cold']):,.0f} | "
          f"{statistics.median(totals['warm']):,.0f} |")
    print(f"| zenoh-python's share (sum of its medians) | {zsum['cold']:,.0f} | {zsum['warm']:,.0f} |\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--role", default="main", choices=["main", "drain", "cold-send"])
    ap.add_argument("--wire", default="both", choices=["zentf", "ros2", "both"])
    ap.add_argument("--n", type=int, default=20000, help="messages in the ring")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--callgrind", action="store_true", help="count instructions instead (valgrind)")
    ap.add_argument("--cold", action="store_true", help="time one message's steps alone and back to back")
    ap.add_argument("--gap-ms", type=float, default=1.0, help="--cold: ms between the messages sent alone")
    ap.add_argument("--endpoint", help=argparse.SUPPRESS)
    args = ap.parse_args()
    wires = ["zentf", "ros2"] if args.wire == "both" else [args.wire]
    if args.role == "drain":  # (under callgrind: zentf's thread only)
        Rig(wires[0], args.n).zentf()
        return
    if args.role == "cold-send":
        _cold_sender(wires[0], args.endpoint, args.n, args.gap_ms)
        return
    print(f"# zentf ingest profile  (python {sys.version.split()[0]}, {os.cpu_count()} cpus, "
          f"load {os.getloadavg()[0]:.1f}; {args.n} messages of 1 transform, in-process)\n")
    if args.callgrind:
        for wire in wires:
            callgrind(wire, args.n)
        return
    if args.cold:
        for wire in wires:
            cold(wire, min(args.n, 5000), args.gap_ms)
        return
    print("| wire | raw ring loop, CPU µs/message best [median] | zentf's tf thread | loop / zentf (rate ratio) |")
    print("|---|---|---|---|")
    for wire in wires:
        rig = Rig(wire, args.n)
        floor, zt = [], []
        for _ in range(args.runs):  # alternated
            floor.append(rig.floor())
            zt.append(rig.zentf())
        print(f"| {wire} | {min(floor):.2f} [{statistics.median(floor):.2f}] | {min(zt):.2f} "
              f"[{statistics.median(zt):.2f}] | {statistics.median(floor) / statistics.median(zt):.2f} |")
        rig.session.close()


if __name__ == "__main__":
    main()
