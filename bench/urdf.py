"""Robot-model benchmark: robot_state_publisher on a 100-joint chain, and batched forward kinematics.

    python bench/urdf.py [--seconds 10] [--joints 100] [--rate 100] [--vectors 10000]

1. robot_state_publisher (its own process, `python -m nodes.robot_state_publisher`) for a chain of
   ``--joints`` revolute joints, fed JointStates of all joints at ``--rate`` Hz by this process; a
   listener process (TransformListener + Buffer) times each message from the JointState's stamp (the
   send time, CLOCK_REALTIME) to the moment its transforms were inserted in the listener's Buffer
   (lookup-able; a lookup root -> tip proves it, untimed). CPU share of one core: the rsp process's
   user+system time over the run / wall time. Reference in the same run: a bare zenoh-python relay
   process (subscribe joint_states, put as many bytes as zentf's TFMessage on tf; no decoding, no
   FK) with a bare callback as receiver: the floor of the same two hops with the same bytes. Peer to peer on loopback, no router.
   Targets (issue 12): rsp CPU <= 5 % of one core; p50 joint_states -> lookup-able <= 0.5 ms.
   Then where zentf's time goes, stage by stage, in one more run with the same three processes: the
   robot_state_publisher (RobotStatePublisher in a bench process, its subscriber callback timed at entry
   and exit) and the listener (a second, bare subscriber on tf timestamps arrival; the insert callback the
   insert); every clock is CLOCK_REALTIME on one machine.
2. Forward kinematics of ``--vectors`` joint vectors at once (``Kinematics.link_poses_batch``, numpy)
   against a Python loop over the vectors calling ``Kinematics.link_poses`` (a per-joint loop of 4x4
   products): r2d2 (urdf_tutorial 06-flexible, 8 joints, 16 links) and the chain. Target: >= 20x.
"""
from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

REPO = Path(__file__).resolve().parent.parent
R2D2 = REPO / "tests" / "data" / "urdf" / "urdf_tutorial" / "urdf" / "06-flexible.urdf"
NS = 1_000_000_000
WARMUP = 50


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def chain_urdf(n: int) -> str:
    """n revolute joints in a chain, axes cycling z, y, x, each link 0.1 m along x with a small twist."""
    parts = ['<robot name="chain">', '<link name="l0"/>']
    axes = ("0 0 1", "0 1 0", "1 0 0")
    for i in range(1, n + 1):
        parts.append(f'<link name="l{i}"/>')
        parts.append(f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
                     f'<origin xyz="0.1 0 0.01" rpy="0.01 0 0.02"/><axis xyz="{axes[i % 3]}"/>'
                     f'<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>')
    parts.append("</robot>")
    return "\n".join(parts)


def zopts(listen: str | None = None, connect: str | None = None):
    from zentf.transport.options import ZenohOptions

    return ZenohOptions(listen=[listen] if listen else [], connect=[connect] if connect else [],
                        mode="peer", no_multicast=True)


def child_env() -> dict[str, str]:
    """The bench's child processes: this checkout first, no ZENTF_* endpoints from the caller's shell."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    for var in ("ZENTF_CONNECT", "ZENTF_LISTEN", "ZENTF_NAMESPACE", "ZENTF_MODE"):
        env.pop(var, None)
    return env


def read_result(proc: subprocess.Popen, what: str) -> dict:
    """The JSON of a child's ``RESULT`` line (lines before it skipped)."""
    assert proc.stdout is not None
    line = proc.stdout.readline()
    while line and not line.startswith("RESULT "):
        line = proc.stdout.readline()
    if not line:
        raise RuntimeError(f"{what} gave no result")
    return json.loads(line[len("RESULT "):])


def joint_state_sender(ep: str, joints: int):
    """(node, send): a zentf node publishing JointStates of ``joints`` joints; ``send(i)`` publishes the
    i-th, stamped with the send time (ns, returned), its message built before the clock is read."""
    from zentf.core.messages import Header, JointState
    from zentf.core.time import Time
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions

    node = Node("bench_joint_states", options=NodeOptions(namespace="bench", zenoh=zopts(connect=ep)),
                check_unique=False)
    pub = node.create_publisher("joint_states", JointState)
    if not pub.wait_for_subscribers(20):
        node.shutdown()
        raise RuntimeError("robot_state_publisher never matched")
    names = [f"j{i}" for i in range(1, joints + 1)]

    def send(i: int) -> int:
        msg = JointState(Header(Time()), names, [0.1 + 1e-4 * i] * joints, [], [])
        t0 = time.time_ns()
        msg.header.stamp = Time(nanoseconds=t0)
        pub.publish(msg)
        return t0

    return node, send


def paced(count: int, rate: float, send) -> None:
    """send(0 .. count-1) at ``rate`` per second."""
    next_t = time.monotonic()
    for i in range(count):
        send(i)
        next_t += 1.0 / rate
        time.sleep(max(0.0, next_t - time.monotonic()))


def stop(procs: list[subprocess.Popen]) -> None:
    """Terminate the bench's child processes (killed after 5 s)."""
    for p in procs:
        p.terminate()
        try:
            p.wait(5)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def cpu_seconds(pid: int) -> float:
    """user + system CPU seconds of a process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


# ------------------------------------------------------------------ child roles

def role_listen(args: argparse.Namespace) -> None:
    """zentf listener: time from the JointState stamp to the insert of its transforms."""
    from zentf.transport.buffer import Buffer
    from zentf.core.time import Time
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions

    node = Node("bench_listener", options=NodeOptions(namespace="bench", zenoh=zopts(connect=args.endpoint)),
                check_unique=False)
    buf = Buffer(node=node)
    lat: list[int] = []
    done = threading.Event()
    tip = f"l{args.joints}"

    def on_insert() -> None:
        now = time.time_ns()
        try:
            t = buf.lookup_transform("l0", tip, Time())  # proves it (not timed)
        except Exception:  # the static part may not be there yet
            return
        lat.append(now - t.header.stamp.nanoseconds)
        if len(lat) >= args.count + WARMUP:
            done.set()

    buf.add_insert_callback(on_insert)
    TransformListener(buf, node)
    print("ready", flush=True)
    done.wait(args.count / 50 + 60)
    print("RESULT " + json.dumps({"lat_ns": lat[WARMUP:]}), flush=True)
    node.shutdown()


def role_rsp_timed(args: argparse.Namespace) -> None:
    """robot_state_publisher in this process, its joint_states callback timed (entry, exit) per message."""
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions
    from zentf.tools.robot_state_publisher import RobotStatePublisher
    from zentf.urdf import parse_urdf

    times: list[tuple[int, int]] = []

    class Timed(RobotStatePublisher):
        def _on_sample(self, sample) -> None:
            t0 = time.time_ns()
            super()._on_sample(sample)
            times.append((t0, time.time_ns()))

    node = Node("robot_state_publisher", options=NodeOptions(namespace="bench", zenoh=zopts(listen=args.endpoint)),
                check_unique=False)
    Timed(node, parse_urdf(chain_urdf(args.joints)), publish_frequency=10000)
    print("publishing robot (timed)", flush=True)
    sys.stdin.readline()
    print("RESULT " + json.dumps({"rsp": times}), flush=True)
    node.shutdown()


def role_listen_timed(args: argparse.Namespace) -> None:
    """zentf listener with a bare subscriber beside it: arrival on tf and insert time per message."""
    from zentf.transport.buffer import Buffer
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions

    node = Node("bench_listener", options=NodeOptions(namespace="bench", zenoh=zopts(connect=args.endpoint)),
                check_unique=False)
    buf = Buffer(node=node)
    rx: list[int] = []
    inserted: list[int] = []
    buf.add_insert_callback(lambda: inserted.append(time.time_ns()))
    node.session.declare_subscriber("bench/tf", lambda sample: rx.append(time.time_ns()))
    TransformListener(buf, node)
    print("ready", flush=True)
    sys.stdin.readline()
    print("RESULT " + json.dumps({"rx": rx, "inserted": inserted}), flush=True)
    node.shutdown()


def run_stages(joints: int, rate: float, seconds: float) -> dict[str, list[float]]:
    """One more zentf run, timed stage by stage (us per message, sorted): see the module doc."""
    ep = f"tcp/127.0.0.1:{free_port()}"
    count = int(seconds * rate)
    procs = []
    node = None
    try:
        for role, ready in (("rsp_timed", "publishing robot"), ("listen_timed", "ready")):
            p = subprocess.Popen([sys.executable, __file__, "--role", role, "--endpoint", ep, "--joints", str(joints)],
                                 env=child_env(), cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
            procs.append(p)
            assert p.stdout is not None
            if ready not in p.stdout.readline():
                raise RuntimeError(f"{role} failed to start")
        node, send = joint_state_sender(ep, joints)
        time.sleep(0.5)
        sent: list[tuple[int, int]] = []
        paced(count, rate, lambda i: sent.append((send(i), time.time_ns())))
        time.sleep(0.5)  # the last message's way through (nothing to wait on across three processes)
        out = {}
        for p in procs:
            p.stdin.write("\n")
            p.stdin.flush()
            out.update(read_result(p, p.args[3]))
    finally:
        if node is not None:
            node.shutdown()
        stop(procs)
    rsp, rx, ins = out["rsp"][-count:], out["rx"][-count:], out["inserted"][-count:]
    if not len(rsp) == len(rx) == len(ins) == count:
        raise RuntimeError(f"stages: {count} sent, {len(rsp)} through the publisher, {len(rx)} received, "
                           f"{len(ins)} inserted")
    rows = {"sender: publish() (encode + put)": [b - a for a, b in sent],
            "hop 1: stamp -> publisher callback": [r[0] - s[0] for s, r in zip(sent, rsp)],
            "publisher callback (decode, FK, bytes, put)": [r[1] - r[0] for r in rsp],
            "hop 2: callback end -> listener arrival": [x - r[1] for r, x in zip(rsp, rx)],
            "listener: arrival -> inserted": [i - x for x, i in zip(rx, ins)],
            "total: stamp -> inserted": [i - s[0] for s, i in zip(sent, ins)]}
    return {k: sorted(v / 1000 for v in vals[WARMUP:]) for k, vals in rows.items()}


def role_raw_relay(args: argparse.Namespace) -> None:
    """Reference publisher process: for each joint_states sample, a tf sample as large as zentf's
    TFMessage (its first 8 bytes, the send time, copied from the input; no decoding, no kinematics)."""
    import zenoh

    session = zopts(listen=args.endpoint).open_session()
    pub = session.declare_publisher("bench/tf", congestion_control=zenoh.CongestionControl.BLOCK)
    pad = b"x" * max(0, args.out_size - 8)
    session.declare_subscriber("bench/joint_states", lambda s: pub.put(s.payload.to_bytes()[:8] + pad))
    print("publishing robot (raw relay)", flush=True)
    threading.Event().wait(args.count / 50 + 120)


def role_raw_listen(args: argparse.Namespace) -> None:
    session = zopts(connect=args.endpoint).open_session()
    lat: list[int] = []
    done = threading.Event()

    def on_sample(sample) -> None:
        now = time.time_ns()
        lat.append(now - int.from_bytes(sample.payload.to_bytes()[:8], "little"))
        if len(lat) >= args.count + WARMUP:
            done.set()

    session.declare_subscriber("bench/tf", on_sample)
    print("ready", flush=True)
    done.wait(args.count / 50 + 60)
    print("RESULT " + json.dumps({"lat_ns": lat[WARMUP:]}), flush=True)
    session.close()


# ------------------------------------------------------------------ one run

def run_publisher_case(impl: str, urdf: Path, joints: int, rate: float, seconds: float, out_size: int) -> dict:
    ep = f"tcp/127.0.0.1:{free_port()}"
    count = int(seconds * rate)
    env = child_env()
    if impl == "zentf":
        pub_cmd = [sys.executable, "-m", "nodes.robot_state_publisher", str(urdf), "--listen", ep, "--mode", "peer",
                   "--no-multicast", "--namespace", "bench", "-p", "publish_frequency:=10000"]
    else:
        pub_cmd = [sys.executable, __file__, "--role", "raw_relay", "--endpoint", ep, "--count", str(count),
                   "--out-size", str(out_size)]
    rsp = subprocess.Popen(pub_cmd, env=env, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    listener = None
    node = session = None
    try:
        assert rsp.stdout is not None
        line = rsp.stdout.readline()
        if "publishing robot" not in line:
            raise RuntimeError(f"{impl} publisher failed to start: {line!r}{rsp.stdout.read()[:2000]}")
        threading.Thread(target=rsp.stdout.read, daemon=True).start()  # keep draining its output
        listener = subprocess.Popen([sys.executable, __file__, "--role", "listen" if impl == "zentf" else "raw_listen",
                                     "--endpoint", ep, "--count", str(count - 2 * WARMUP), "--joints", str(joints)],
                                    env=env, cwd=REPO, stdout=subprocess.PIPE, text=True)
        assert listener.stdout is not None
        if not listener.stdout.readline().startswith("ready"):
            raise RuntimeError("listener failed to start")
        if impl == "zentf":
            node, send = joint_state_sender(ep, joints)
        else:
            import zenoh

            from zentf.transport.wire import codec as wire
            from zentf.core.messages import Header, JointState

            session = zopts(connect=ep).open_session()
            raw = session.declare_publisher("bench/joint_states", congestion_control=zenoh.CongestionControl.BLOCK)
            while not raw.matching_status.matching:
                time.sleep(0.005)
            pad = wire.encode(JointState(Header(), [f"j{i}" for i in range(1, joints + 1)], [0.1] * joints, [],
                                         []))[8:]

            def send(i: int) -> None:
                raw.put(time.time_ns().to_bytes(8, "little") + pad)
        time.sleep(0.5)
        cpu0, wall0 = cpu_seconds(rsp.pid), time.monotonic()
        paced(count, rate, send)
        cpu = cpu_seconds(rsp.pid) - cpu0
        wall = time.monotonic() - wall0
        lat = read_result(listener, f"{impl}: the listener")["lat_ns"]
        return {"cpu": cpu / wall, "lat_us": sorted(v / 1000 for v in lat), "n": len(lat)}
    finally:
        if node is not None:
            node.shutdown()
        if session is not None:
            session.close()
        stop([p for p in (listener, rsp) if p is not None])


def in_process_costs(joints: int, rate: float, n: int = 2000, n_paced: int = 200) -> dict:
    """Per message, no network, in us: robot_state_publisher decode + kinematics + encoding, and the listener
    inserting the result; back to back (warm caches) and paced at ``rate`` (a sleep of 1/rate before each, as
    in the run: the caches are cold again, which makes each stage several times slower). Also the size of
    the TFMessage."""
    from zentf.transport.wire import codec as wire
    from zentf.transport.buffer import Buffer
    from zentf.core.messages import Header, JointState
    from zentf.core.time import Time
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions
    from zentf.tools.robot_state_publisher import RobotStatePublisher
    from zentf.urdf import parse_urdf

    node = Node("bench_inproc", options=NodeOptions(namespace="bench_inproc", zenoh=zopts()), check_unique=False)
    try:
        rsp = RobotStatePublisher(node, parse_urdf(chain_urdf(joints)), ignore_timestamp=True)
        out: list[bytes] = []
        rsp._tf.publish_bytes = out.append  # keep the payloads here instead of sending them
        names = [f"j{i}" for i in range(1, joints + 1)]
        payloads = [wire.encode(JointState(Header(Time(sec=1, nanosec=i + 1)), names, [0.1 + 1e-4 * i] * joints, [],
                                           [])) for i in range(n + n_paced)]  # distinct stamps

        t0 = time.perf_counter()
        for p in payloads[:n]:
            rsp.on_payload(p)  # the subscriber's own path (the names read in C after the first)
        t_rsp = (time.perf_counter() - t0) / n
        from zentf.transport.ingest.handler import TfIngest  # the listener's own path: compiled decode, insert from C

        def ingester(buf: Buffer):
            return TfIngest(False, lambda p, t, a, s: wire.ingest_tf(p, t, a, s), buf, buf, None, 0, False)

        buf = Buffer()
        ingest = ingester(buf)
        t0 = time.perf_counter()
        for p in out:
            ingest(p, "/bench")
        t_ingest = (time.perf_counter() - t0) / len(out)
        paced_rsp, paced_ingest = [], []
        for p in payloads[n:]:
            time.sleep(1 / rate)
            t0 = time.perf_counter()
            rsp.on_payload(p)
            paced_rsp.append(time.perf_counter() - t0)
        buf = Buffer()
        ingest = ingester(buf)
        for p in out[:n_paced]:
            time.sleep(1 / rate)
            t0 = time.perf_counter()
            ingest(p, "/bench")
            paced_ingest.append(time.perf_counter() - t0)
    finally:
        node.shutdown()
    return {"rsp": 1e6 * t_rsp, "ingest": 1e6 * t_ingest, "rsp_paced": 1e6 * statistics.median(paced_rsp),
            "ingest_paced": 1e6 * statistics.median(paced_ingest), "size": len(out[-1])}


def pct(sorted_values: list[float], q: float) -> float:
    return sorted_values[min(len(sorted_values) - 1, int(q * len(sorted_values)))] if sorted_values else float("nan")


def fk_case(name: str, kin, n_batch: int, n_loop: int) -> tuple[float, float]:
    """(batch seconds for n_batch vectors, loop seconds scaled to n_batch)."""
    import numpy as np

    rng = np.random.default_rng(1)
    q = rng.uniform(-1, 1, size=(n_batch, len(kin.joint_names)))
    tb = float("inf")
    for _ in range(3):  # best of 3 (the loop below runs long enough to average itself)
        t0 = time.perf_counter()
        batch = kin.link_poses_batch(q)
        tb = min(tb, time.perf_counter() - t0)
    t0 = time.perf_counter()
    for row in q[:n_loop]:
        kin.link_poses(row)
    tl = (time.perf_counter() - t0) * n_batch / n_loop
    last = kin.link_poses(q[n_loop - 1])
    assert all(np.abs(batch[n_loop - 1, k] - last[ln]).max() < 1e-9 for k, ln in enumerate(kin.link_names))
    return tb, tl


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--role", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--endpoint", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--out-size", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--joints", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--vectors", type=int, default=10_000)
    args = parser.parse_args()
    if args.role:
        {"listen": role_listen, "raw_relay": role_raw_relay, "raw_listen": role_raw_listen,
         "rsp_timed": role_rsp_timed, "listen_timed": role_listen_timed}[args.role](args)
        return

    from zentf.urdf import Kinematics, load_urdf, parse_urdf

    print(f"# zentf urdf bench  (python {sys.version.split()[0]}, {os.cpu_count()} cpus, "
          f"load {os.getloadavg()[0]:.2f}; loopback, peer to peer)")
    costs = in_process_costs(args.joints, args.rate)
    out_size = costs["size"]
    with tempfile.TemporaryDirectory() as tmp:
        urdf = Path(tmp) / "chain.urdf"
        urdf.write_text(chain_urdf(args.joints))
        rows = {impl: run_publisher_case(impl, urdf, args.joints, args.rate, args.seconds, out_size)
                for impl in ("raw", "zentf")}
    stages = run_stages(args.joints, args.rate, args.seconds)
    print(f"\n## robot_state_publisher: {args.joints}-joint chain, joint_states at {args.rate:g} Hz for "
          f"{args.seconds:g} s")
    print(f"{'':28}{'zentf rsp':>12}{'raw relay':>12}{'ratio':>8}")
    z, r = rows["zentf"], rows["raw"]
    print(f"{'CPU, % of one core':28}{100 * z['cpu']:>12.2f}{100 * r['cpu']:>12.2f}{z['cpu'] / max(r['cpu'], 1e-9):>8.1f}"
          f"   target <= 5 %")
    for label, q in (("p50", 0.5), ("p90", 0.9), ("p99", 0.99)):
        zv, rv = pct(z["lat_us"], q), pct(r["lat_us"], q)
        print(f"{'latency ' + label + ', us':28}{zv:>12.0f}{rv:>12.0f}{zv / rv:>8.2f}"
              + ("   target p50 <= 500 us" if q == 0.5 else ""))
    print(f"{'samples':28}{z['n']:>12}{r['n']:>12}")
    print(f"TFMessage of {args.joints} transforms: {out_size} bytes (the relay sends as many)")
    print(f"where the time goes, per message, in process (no network), back to back | paced at {args.rate:g} Hz as in"
          f" the run (cold caches, median): robot_state_publisher decode + kinematics + encoding {costs['rsp']:.0f} |"
          f" {costs['rsp_paced']:.0f} us; the listener inserting its {args.joints} transforms {costs['ingest']:.0f} |"
          f" {costs['ingest_paced']:.0f} us")
    print("\nwhere zentf's time goes, in a third run of the same three processes (us; stages overlap: the")
    print("sender's put wakes Zenoh's I/O thread before it returns, the publisher's put is inside its callback)")
    print(f"{'':46}{'p50':>8}{'p90':>8}")
    for label, vals in stages.items():
        print(f"{label:46}{pct(vals, 0.5):>8.0f}{pct(vals, 0.9):>8.0f}")

    print(f"\n## forward kinematics of {args.vectors} joint vectors")
    print(f"{'model':28}{'batch, ms':>12}{'loop, ms':>12}{'speed-up':>10}")
    chain = Kinematics(parse_urdf(chain_urdf(args.joints)))
    for name, kin, n_loop in (("r2d2 (8 joints, 16 links)", Kinematics(load_urdf(R2D2)), args.vectors),
                              (f"chain ({args.joints} joints)", chain, max(100, args.vectors // 10))):
        tb, tl = fk_case(name, kin, args.vectors, n_loop)
        note = "" if n_loop == args.vectors else f"   (loop timed on {n_loop}, scaled)"
        print(f"{name:28}{1000 * tb:>12.1f}{1000 * tl:>12.1f}{tl / tb:>9.0f}x{note}   target >= 20x")


if __name__ == "__main__":
    main()
