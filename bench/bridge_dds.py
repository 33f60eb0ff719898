"""`zentf bridge dds` benchmark: DDS -> zentf throughput and the latency the bridge adds, beside rclpy -> rclpy
measured in the same run (real ROS 2: the test venv of tests/ros2/make_env.sh; loopback only).

    python bench/bridge_dds.py [--seconds 5] [--n-lat 500] [--wire zentf|ros2]

Throughput (10 transforms per /tf message): a DDS writer offers pre-serialized TFMessages at --rate
(25k/s by default; 0: as fast as it can) for --seconds;
the rate is messages per second arriving on the zentf side (a bare Zenoh subscriber on the bridge's key),
against the same writer -> an rclpy subscriber (rclpy's own receive path), and rclpy's publisher -> both.
Each receiver is measured alone (the rclpy subscriber before the bridge starts, the bridge after the
subscriber is gone): on 2 cores a second busy receiver takes the CPU the first one needs. The flooding writer is Cyclone DDS (raw CDR; rclpy's Python publisher
cannot offer 20k messages/s itself, its own rate is printed too).
Latency: rclpy publishes one /tf message every 10 ms (rclpy's subscriber keeps up), its stamp = the send
time (CLOCK_REALTIME); a Cyclone DDS reader process (the DDS hop alone: raw CDR, no conversion), an rclpy
subscriber (rclpy -> rclpy, its Python message conversion included) and the zentf side (DDS hop + bridge +
Zenoh hop) take receive time - stamp of the same messages. The added latency is p50(zentf) - p50(DDS hop).
The bridge process's CPU time per relayed message is printed too: on a shared 2-core machine the received
rate says as much about the other processes as about the bridge.
Targets: DDS -> zentf >= 20k messages/s sustained; added latency p50 <= 1 ms.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
import uuid
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))

N_TF = 10

RCLPY = r'''
import json, os, sys, threading, time
import rclpy
from rclpy.node import Node
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile
from tf2_msgs.msg import TFMessage
from geometry_msgs.msg import TransformStamped
mode = sys.argv[1]
rclpy.init()
node = Node("bench_rclpy_" + mode)
def msg(stamp_ns):
    m = TFMessage()
    for i in range(%(n)d):
        t = TransformStamped()
        t.header.frame_id = "odom"; t.child_frame_id = "link%%d" %% i
        t.header.stamp.sec = stamp_ns // 10**9; t.header.stamp.nanosec = stamp_ns %% 10**9
        t.transform.translation.x = float(i); t.transform.rotation.w = 1.0
        m.transforms.append(t)
    return m
if mode == "sub":
    count = [0]; lat = []
    def cb(m):
        count[0] += 1
        if m.transforms[0].header.frame_id == "odom" and m.transforms[0].child_frame_id == "link0" and lat_on[0]:
            s = m.transforms[0].header.stamp
            lat.append(time.time_ns() - (s.sec * 10**9 + s.nanosec))
    lat_on = [False]
    subs = [node.create_subscription(TFMessage, "/tf", cb, QoSProfile(depth=100))]
    ex = SingleThreadedExecutor(); ex.add_node(node)
    threading.Thread(target=ex.spin, daemon=True).start()
    print("ready", flush=True)
    for line in sys.stdin:
        cmd = line.split()
        if cmd[0] == "count":
            print("count", count[0], flush=True)
        elif cmd[0] == "unsub":
            node.destroy_subscription(subs.pop()); print("done", flush=True)
        elif cmd[0] == "sub":
            subs.append(node.create_subscription(TFMessage, "/tf", cb, QoSProfile(depth=100))); print("done", flush=True)
        elif cmd[0] == "lat":
            lat_on[0] = cmd[1] == "on"
            if cmd[1] == "off":
                print("lat", json.dumps(lat), flush=True); lat.clear()
        elif cmd[0] == "quit":
            break
else:
    pub = node.create_publisher(TFMessage, "/tf", QoSProfile(depth=100))
    print("ready", flush=True)
    for line in sys.stdin:
        cmd = line.split()
        if cmd[0] == "flood":
            end = time.monotonic() + float(cmd[1]); n = 0; m = msg(1)
            while time.monotonic() < end:
                pub.publish(m); n += 1
            print("sent", n, flush=True)
        elif cmd[0] == "lat":
            for i in range(int(cmd[1])):
                pub.publish(msg(time.time_ns()))
                time.sleep(0.01)
            print("sent", cmd[1], flush=True)
        elif cmd[0] == "quit":
            break
rclpy.shutdown()
os._exit(0)
''' % {"n": N_TF}

CYCLONE_FLOOD = r'''
import sys, time
from zentf.tools.dds.cyclone import DdsDomain, TopicQos
from zentf.ros import encode_tf
d = DdsDomain(int(sys.argv[1]), mark=False)  # a robot's writer, not a bridge's
w = d.writer("rt/tf", "tf2_msgs/msg/TFMessage", TopicQos(depth=100), mark=False)
cdr = encode_tf([{"header": {"stamp": {"sec": 1, "nanosec": 0}, "frame_id": "odom"}, "child_frame_id": f"link{i}",
                  "transform": {"translation": {"x": float(i), "y": 0.0, "z": 0.0},
                                "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}} for i in range(%(n)d)])
print("ready", flush=True)
for line in sys.stdin:
    cmd = line.split()
    if cmd[0] == "flood":  # flood SECONDS RATE: RATE messages/s (0: as fast as it can), in bursts of 50
        secs, rate = float(cmd[1]), float(cmd[2])
        t0 = time.monotonic(); end = t0 + secs; n = 0
        while time.monotonic() < end:
            for _ in range(50):
                w.write(cdr)
            n += 50
            if rate > 0:
                ahead = t0 + n / rate - time.monotonic()
                if ahead > 0:
                    time.sleep(ahead)
        print("sent", n, flush=True)
    elif cmd[0] == "quit":
        break
d.close()
''' % {"n": N_TF}


CYCLONE_READ = r'''
import json, sys, threading, time
from zentf.tools.dds.cyclone import DdsDomain, TopicQos
from zentf.ros import tf_samples
d = DdsDomain(int(sys.argv[1]), mark=False)
r = d.reader("rt/tf", "tf2_msgs/msg/TFMessage", TopicQos(depth=100), 0)
lat = []; on = [False]; count = [0]
def loop():
    while True:
        d.wait(0.5)
        for cdr, _info in r.take():
            now = time.time_ns()
            count[0] += 1
            if on[0]:
                lat.append(now - tf_samples(cdr)[0][0][2])
threading.Thread(target=loop, daemon=True).start()
print("ready", flush=True)
for line in sys.stdin:
    cmd = line.split()
    if cmd[0] == "count":
        print("count", count[0], flush=True)
    elif cmd[0] == "lat":
        on[0] = cmd[1] == "on"
        if cmd[1] == "off":
            print("lat", json.dumps(lat), flush=True); lat.clear()
    elif cmd[0] == "quit":
        break
'''


class Child:
    def __init__(self, args: list[str], env: dict) -> None:
        self.p = subprocess.Popen(args, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)
        self.expect("ready")

    def send(self, line: str) -> None:
        self.p.stdin.write(line + "\n")
        self.p.stdin.flush()

    def expect(self, word: str) -> list[str]:
        while True:
            line = self.p.stdout.readline()
            if not line:
                raise RuntimeError(f"{word!r}: the child exited ({self.p.poll()})")
            parts = line.split(maxsplit=1)
            if parts and parts[0] == word:
                return parts

    def close(self) -> None:
        try:
            self.send("quit")
            self.p.wait(10)
        except Exception:
            self.p.kill()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--rate", type=float, default=25_000.0,
                    help="messages/s the Cyclone DDS writer offers (0: as fast as it can)")
    ap.add_argument("--n-lat", type=int, default=500)
    ap.add_argument("--wire", choices=["zentf", "ros2"], default="zentf")
    args = ap.parse_args()

    from conftest import child_env, start_router
    from test_ros2_dds import DdsDomainLock, ros2_python

    import pytest

    try:
        py = ros2_python("jazzy")
    except pytest.skip.Exception as e:
        print(f"bench/bridge_dds.py: {e}", file=sys.stderr)
        return 2
    lock = DdsDomainLock()
    domain = lock.id
    router_proc, router = start_router()
    ns = f"bench_{uuid.uuid4().hex[:6]}"
    env = child_env(router, ns)
    env["ROS_DOMAIN_ID"] = str(domain)
    renv = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "RMW_IMPLEMENTATION")}
    renv.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1")
    kids: list = []
    bridge = None
    try:
        import zenoh

        from zentf.ros import tf_samples
        from zentf.transport.options import ZenohOptions
        from zentf.transport.wire import codec as zwire
        from zentf.transport.wire.profiles import make_profile

        if args.wire == "ros2":
            env.pop("ZENTF_NAMESPACE", None)
        session = ZenohOptions(connect=[router], mode="client", no_multicast=True).open_session()
        prof = make_profile(args.wire, domain)
        key = prof.data_key("/tf" if args.wire == "ros2" else f"/{ns}/tf", "tf2_msgs/msg/TFMessage")
        count = [0]
        lat: list[int] = []
        lat_on = [False]

        def on_sample(s: zenoh.Sample) -> None:
            count[0] += 1
            if lat_on[0]:
                now = time.time_ns()
                raw = s.payload.to_bytes()
                if args.wire == "ros2":
                    stamp = tf_samples(raw)[0][0][2]
                else:
                    st = zwire.unpack(raw)["transforms"][0]["header"]["stamp"]
                    stamp = st["sec"] * 10**9 + st["nanosec"]
                lat.append(now - stamp)

        sub = session.declare_subscriber(key, on_sample)
        rsub = Child([py, "-c", RCLPY, "sub"], renv)
        kids.append(rsub)
        rpub = Child([py, "-c", RCLPY, "pub"], renv)
        kids.append(rpub)
        flood = Child([sys.executable, "-c", CYCLONE_FLOOD, str(domain)], {**env, "PYTHONPATH": str(REPO)})
        kids.append(flood)

        def warm(ok) -> None:
            deadline = time.monotonic() + 30
            while not ok():
                rpub.send("flood 0.1")
                rpub.expect("sent")
                if time.monotonic() > deadline:
                    raise RuntimeError("no message arrived")
            time.sleep(1.0)  # the warm-up's backlog drains

        def rate(source: Child, received) -> tuple[float, float]:
            r0 = received()
            t0 = time.monotonic()
            source.send(f"flood {args.seconds} {args.rate}" if source is flood else f"flood {args.seconds}")
            sent = int(source.expect("sent")[1])
            time.sleep(0.5)  # what is still in flight
            return sent / args.seconds, (received() - r0) / (time.monotonic() - t0)

        # each consumer measured alone (on 2 cores a second one takes the CPU the first one needs)
        rcount = lambda: int(_count(rsub))  # noqa: E731
        warm(lambda: rcount() > 0)
        c_sent_r, c_rclpy = rate(flood, rcount)
        r_sent_r, r_rclpy = rate(rpub, rcount)
        rsub.send("unsub")
        rsub.expect("done")
        bargs = [sys.executable, "-m", "zentf.cli", "bridge", "dds", "--wire", args.wire]
        bridge = subprocess.Popen(bargs, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        while "dds bridge: active" not in (bridge.stderr.readline() or "dds bridge: active"):
            pass
        zcount = lambda: count[0]  # noqa: E731
        warm(lambda: count[0] > 0)
        cpu0 = _cpu(bridge.pid)
        z0 = count[0]
        c_sent, c_zentf = rate(flood, zcount)
        cpu_us = (_cpu(bridge.pid) - cpu0) / max(1, count[0] - z0) * 1e6
        r_sent, r_zentf = rate(rpub, zcount)
        # latency: all three receivers of the same messages, at a rate each keeps up with
        rsub.send("sub")
        rsub.expect("done")
        csub = Child([sys.executable, "-c", CYCLONE_READ, str(domain)], {**env, "PYTHONPATH": str(REPO)})
        kids.append(csub)
        r0, z0 = rcount(), count[0]
        warm(lambda: int(_count(csub)) > 0 and rcount() > r0 and count[0] > z0)
        lat_on[0] = True
        rsub.send("lat on")
        csub.send("lat on")
        rpub.send(f"lat {args.n_lat}")
        rpub.expect("sent")
        time.sleep(0.5)
        lat_on[0] = False
        rsub.send("lat off")
        rlat = json.loads(rsub.expect("lat")[1])
        csub.send("lat off")
        clat = json.loads(csub.expect("lat")[1])
        cl = statistics.median(clat) / 1e3 if clat else float("nan")
        c90 = statistics.quantiles(clat, n=10)[-1] / 1e3 if len(clat) > 10 else float("nan")
        zl = statistics.median(lat) / 1e3 if lat else float("nan")
        rl = statistics.median(rlat) / 1e3 if rlat else float("nan")
        z90 = statistics.quantiles(lat, n=10)[-1] / 1e3 if len(lat) > 10 else float("nan")
        r90 = statistics.quantiles(rlat, n=10)[-1] / 1e3 if len(rlat) > 10 else float("nan")
        sub.undeclare()
        session.close()
        load = os.getloadavg()
        print(f"# zentf bridge dds (--wire {args.wire}), {N_TF} transforms per /tf message, loopback; "
              f"load {load[0]:.2f} {load[1]:.2f}")
        print()
        print("| throughput (messages/s), each receiver alone | offered | DDS -> bridge -> zentf | offered | "
              "DDS -> rclpy subscriber |")
        print("|---|---|---|---|---|")
        print(f"| Cyclone DDS writer (raw CDR) flood | {c_sent:,.0f} | {c_zentf:,.0f} | {c_sent_r:,.0f} | {c_rclpy:,.0f} |")
        print(f"| rclpy publisher flood | {r_sent:,.0f} | {r_zentf:,.0f} | {r_sent_r:,.0f} | {r_rclpy:,.0f} "
              "(rclpy -> rclpy) |")
        print()
        print(f"bridge process CPU per relayed message (Cyclone writer run): {cpu_us:.1f} us "
              f"(= {1e6 / cpu_us:,.0f} messages/s on one free core)")
        print()
        print(f"| one-way latency from an rclpy publisher (us), {len(lat)} messages | p50 | p90 |")
        print("|---|---|---|")
        print(f"| -> Cyclone DDS reader (the DDS hop alone, raw CDR) | {cl:.0f} | {c90:.0f} |")
        print(f"| -> rclpy subscriber (rclpy -> rclpy) | {rl:.0f} | {r90:.0f} |")
        print(f"| -> bridge -> zentf subscriber | {zl:.0f} | {z90:.0f} |")
        print(f"| added by the bridge (p50 difference to the DDS hop alone) | {zl - cl:.0f} | |")
        print()
        ok_rate = c_zentf >= 20_000
        ok_lat = (zl - cl) <= 1000
        print(f"target DDS -> zentf >= 20,000 messages/s: {'met' if ok_rate else 'NOT met'} ({c_zentf:,.0f}); "
              f"added latency p50 <= 1 ms: {'met' if ok_lat else 'NOT met'} ({(zl - cl) / 1e3:.2f} ms)")
    finally:
        for k in kids:
            k.close()
        if bridge is not None:
            bridge.terminate()
            try:
                bridge.wait(10)
            except subprocess.TimeoutExpired:
                bridge.kill()
        router_proc.stop()
        lock.release()
    return 0


def _cpu(pid: int) -> float:
    """CPU seconds (user + system, all threads) of a process so far."""
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _count(child: Child) -> str:
    child.send("count")
    return child.expect("count")[1]


if __name__ == "__main__":
    sys.exit(main())
