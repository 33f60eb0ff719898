"""`zentf bridge ros2` with both graphs running at once: a zentf graph (zentf wire, a namespace) and a
ROS 2 graph (a zenoh-ros2-sdk node, rmw_zenoh wire, a domain) on one router. Each side sees the other's
frames, statics stay latched on both sides (late joiners get them after the publishers are gone), and
no sample circulates once the publishers stop (no echo loop)."""
from __future__ import annotations

import json
import sys
import time
import uuid

import pytest

from conftest import Proc, child_env
from test_ros2_live import BROADCASTER, LISTENER, SDK_NODE

pytest.importorskip("zenoh_ros2_sdk")


@pytest.fixture
def graphs(isolated_router: str, test_namespace: str):
    zentf_env = child_env(isolated_router, test_namespace)
    zentf_env.pop("ZENTF_WIRE", None)
    domain = 1 + uuid.uuid4().int % 200
    ros2_env = child_env(isolated_router, "")
    ros2_env.pop("ZENTF_NAMESPACE", None)
    ros2_env.update({"ZENTF_WIRE": "ros2", "ROS_DOMAIN_ID": str(domain)})
    procs: list[Proc] = []

    def start(args: list[str], env: dict[str, str]) -> Proc:
        p = Proc(args, env=env)
        procs.append(p)
        return p

    yield isolated_router, zentf_env, ros2_env, domain, start
    for p in procs:
        p.stop(timeout=5)


def test_bridge_relays_both_ways_latched_and_loop_free(graphs) -> None:
    router, zentf_env, ros2_env, domain, start = graphs
    host_port = router.split("/", 1)[1]
    bridge = start([sys.executable, "-m", "zentf.cli", "bridge", "ros2", "--ros2-connect", router,
                    "--ros2-mode", "client", "--domain", str(domain)], zentf_env)
    bridge.wait_for_line("bridging tf, tf_static, /clock", timeout=40)
    zpub = start([sys.executable, "-c", BROADCASTER], zentf_env)           # zentf wire: world -> robot -> gripper
    zpub.wait_for_line("static sent", timeout=40)
    rpub = start([*SDK_NODE, "pub", host_port, "--node", "sdk_tf_node"], ros2_env)  # ROS 2: map -> odom -> base_link
    rpub.wait_for_line("publishing", timeout=60)

    # zentf side sees the ROS 2 node's frames (through the bridge)
    zlis = start([sys.executable, "-c", LISTENER], zentf_env)
    m = zlis.wait_for_line(r"map->base_link (\S+) (\S+) (\S+)", timeout=40)
    assert [float(x) for x in m.groups()] == [1.5, 2.0, 3.0]
    # ROS 2 side sees zentf's frames (through the bridge)
    rsub = start([*SDK_NODE, "sub", host_port, "--node", "sdk_listener"], ros2_env)
    got = json.loads(rsub.wait_for_line(r'"topic": "/tf_static".*"child": "robot"', timeout=40).string)
    assert (got["parent"], got["t"], got["q"]) == ("world", [4.0, -5.0, 6.5], [0.0, 0.0, 0.6, 0.8])
    got = json.loads(rsub.wait_for_line(r'"topic": "/tf".*"child": "gripper"', timeout=40, from_start=True).string)
    assert got["t"] == [0.25, 0.5, 0.75]

    # publishers gone: nothing may keep circulating between the two graphs
    zpub.stop()
    rpub.stop()
    from zentf.transport.options import ZenohOptions
    from zentf.transport.wire.profiles import Ros2Profile

    session = ZenohOptions(connect=[router], mode="client", no_multicast=True).open_session()
    try:
        ns = zentf_env["ZENTF_NAMESPACE"]
        ros2 = Ros2Profile(domain)
        keys = [f"{ns}/tf", f"{ns}/tf_static", ros2.data_key("/tf", "tf2_msgs/msg/TFMessage"),
                ros2.data_key("/tf_static", "tf2_msgs/msg/TFMessage")]
        time.sleep(1.0)  # let in-flight samples of the stopped publishers drain
        seen: list[str] = []
        subs = [session.declare_subscriber(k, lambda s: seen.append(str(s.key_expr))) for k in keys]
        time.sleep(2.0)
        for s in subs:
            s.undeclare()
        assert seen == [], f"samples still circulating after the publishers stopped: {seen[:5]} ({len(seen)})"
    finally:
        session.close()

    # statics stay latched on both sides: late joiners get them from the bridge's caches
    late = start([sys.executable, "-c", LISTENER.replace('"map", "base_link"', '"map", "odom"')
                  .replace("zentf_listener", "late_zentf")], zentf_env)
    m = late.wait_for_line(r"map->base_link (\S+) (\S+) (\S+)", timeout=40)  # (the script's label)
    assert [float(x) for x in m.groups()] == [1.0, 2.0, 3.0]
    late_ros2 = start([*SDK_NODE, "sub", host_port, "--node", "late_sdk"], ros2_env)
    got = json.loads(late_ros2.wait_for_line(r'"topic": "/tf_static".*"child": "robot"', timeout=40,
                                             from_start=True).string)
    assert got["t"] == [4.0, -5.0, 6.5]

    bridge.signal(2)
    assert bridge.wait(20) == 0
    summary = bridge.wait_for_line(r"relayed to ROS 2: (\d+), to zentf: (\d+), echoes dropped: (\d+)", timeout=5)
    to_ros2, to_zentf, echoes = (int(x) for x in summary.groups())
    assert to_ros2 > 0 and to_zentf > 0 and echoes > 0


def test_bridge_relays_clock_and_named_topics_in_process(isolated_router: str, test_namespace: str) -> None:
    """Ros2Bridge itself (no CLI): /clock from ROS 2 to zentf, a named topic from zentf to ROS 2."""
    import threading

    from zentf.core.messages import Clock, Header, Point, PointStamped
    from zentf.core.time import Time
    from zentf.transport.graph import GraphWatcher
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions, ZenohOptions
    from zentf.tools.bridge import Ros2Bridge

    z = ZenohOptions(connect=[isolated_router], mode="client", no_multicast=True)
    domain = 1 + uuid.uuid4().int % 200
    znode = Node("zentf_side", options=NodeOptions(namespace=test_namespace, zenoh=z))
    rnode = Node("ros2_side", options=NodeOptions(wire="ros2", domain_id=domain, zenoh=z))
    bz = Node("bridge", options=NodeOptions(namespace=test_namespace, zenoh=z))
    br = Node("bridge", options=NodeOptions(wire="ros2", domain_id=domain, zenoh=z))
    bridge = Ros2Bridge(bz, br, ("points",))
    try:
        clocks: list = []
        points: list = []
        got_clock, got_points = threading.Event(), threading.Event()
        znode.create_subscription("/clock", Clock, lambda m: (clocks.append(m), got_clock.set()))
        rnode.create_subscription("/points", PointStamped, lambda m: (points.append(m), got_points.set()))
        watcher = GraphWatcher(br.session, profile=br.wire)
        assert watcher.wait_for(lambda es: any(e.kind == "sub" and e.topic == "/points" for e in es), 10)
        watcher.close()
        clock_pub = rnode.create_publisher("/clock", Clock)
        pts_pub = znode.create_publisher("points", PointStamped)
        deadline = time.monotonic() + 20
        while not (got_clock.is_set() and got_points.is_set()) and time.monotonic() < deadline:
            clock_pub.publish(Clock(Time(sec=42, nanosec=7)))
            pts_pub.publish(PointStamped(Header(Time(sec=3), "base"), Point(1.0, 2.0, 3.0)))
            time.sleep(0.05)
        assert clocks and clocks[0].clock == Time(sec=42, nanosec=7)
        assert points and points[0].point == Point(1.0, 2.0, 3.0) and points[0].header.frame_id == "base"
        assert bridge.stats.to_zentf["/clock"] > 0 and bridge.stats.to_ros2[f"/{test_namespace}/points"] > 0
    finally:
        bridge.close()
        for n in (znode, rnode, bz, br):
            n.shutdown()
