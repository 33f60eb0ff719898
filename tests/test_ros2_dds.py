"""`zentf bridge dds` against a real ROS 2: rclpy on Fast DDS from PyPI wheels (Jazzy, and Kilted), in the
test venv that tests/ros2/make_env.sh makes once under ~/.cache/zentf (.ci/run calls it). The rclpy side is
tests/ros2/rclpy_node.py, a process of that venv driven line by line; the bridge is the CLI command; the
zentf side is real Zenoh through a router of this module's own. Every DDS participant is loopback-only
and each test group has a ROS domain of its own (a lock file per domain keeps parallel runs apart).

Skipped outside CI (with the reason) when the test venv or cyclonedds is missing; failed in CI.
"""
from __future__ import annotations

import fcntl
import json
import os
import queue
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from conftest import REPO, Proc, child_env, start_router

TF = "tf2_msgs/msg/TFMessage"
ENV_SCRIPT = REPO / "tests" / "ros2" / "make_env.sh"
HELPER = REPO / "tests" / "ros2" / "rclpy_node.py"
KILTED_PROFILE = REPO / "tests" / "ros2" / "fastdds_no_type_propagation.xml"


def _missing(reason: str) -> None:
    if os.environ.get("CI"):
        pytest.fail(f"the DDS bridge's tests need this in CI: {reason}")
    pytest.skip(reason)


def ros2_python(distro: str) -> str:
    """The test venv's python for a ROS 2 distro (skip, or fail in CI, when it is not made)."""
    try:
        path = subprocess.run(["bash", str(ENV_SCRIPT), distro, "--path"], capture_output=True, text=True,
                              check=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError) as e:
        _missing(f"cannot ask {ENV_SCRIPT.name} for the ROS 2 {distro} test env: {e}")
    if not (Path(path) / ".ready").exists():
        _missing(f"no ROS 2 {distro} test env (rclpy + tf2_msgs): run `bash tests/ros2/make_env.sh {distro}`")
    return str(Path(path) / "bin" / "python")


@pytest.fixture(scope="module", autouse=True)
def _cyclonedds() -> None:
    try:
        import cyclonedds  # noqa: F401
    except ImportError:
        _missing("cyclonedds is not installed (pip install -e '.[test]')")


class DdsDomainLock:
    """A ROS domain id (1-232) no other test process on this machine holds (a lock file per id)."""

    def __init__(self) -> None:
        start = uuid.uuid4().int % 232
        for i in range(232):
            d = 1 + (start + i) % 232
            f = open(f"/tmp/zentf-test-dds-domain-{d}.lock", "w")  # noqa: SIM115 - held until release
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                f.close()
                continue
            self.id, self._f = d, f
            return
        raise RuntimeError("no free DDS domain id")

    def release(self) -> None:
        self._f.close()


class Rclpy:
    """tests/ros2/rclpy_node.py in the ROS 2 test venv: commands in, JSON lines out."""

    def __init__(self, python: str, domain: int, name: str = "zentf_test_rclpy", env: dict | None = None) -> None:
        e = dict(os.environ if env is None else env)
        for var in ("PYTHONPATH", "RMW_IMPLEMENTATION", "CYCLONEDDS_URI", "FASTRTPS_DEFAULT_PROFILES_FILE",
                    "FASTDDS_DEFAULT_PROFILES_FILE", "ROS_LOCALHOST_ONLY", "ROS_STATIC_PEERS"):
            if env is None:
                e.pop(var, None)
        e.update({"ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
                  "PYTHONUNBUFFERED": "1"})
        self.proc = Proc([python, str(HELPER), name], env=e, stdin=subprocess.PIPE)
        self.subs: dict[str, int] = {}   # subscriptions made per topic: each gets every message once
        self.proc.wait_for_line(r'"ok": "ready"', timeout=60)

    def send(self, **cmd: object) -> None:
        assert self.proc.popen.stdin is not None
        self.proc.popen.stdin.write(json.dumps(cmd) + "\n")
        self.proc.popen.stdin.flush()

    def call(self, **cmd: object) -> dict:
        """Send a command and return its {"ok": ...} answer."""
        if cmd["cmd"] == "sub":
            self.subs[str(cmd["topic"])] = self.subs.get(str(cmd["topic"]), 0) + 1
        self.send(**cmd)
        m = self.proc.wait_for_line(r'^\{"ok": "' + str(cmd["cmd"]) + '"', timeout=30)
        return json.loads(m.string)

    def wait_msg(self, topic: str, pred=lambda v: True, timeout: float = 30.0, *, from_start: bool = True) -> dict:
        """The first message received on ``topic`` (since the start) for which pred(value) holds."""
        deadline = time.monotonic() + timeout
        i = 0
        while True:
            lines = self.proc.lines
            while i < len(lines):
                line = lines[i]
                i += 1
                if line.startswith('{"msg": '):
                    got = json.loads(line)
                    if got["msg"] == topic and pred(got["value"]):
                        return got["value"]
            if time.monotonic() > deadline:
                raise AssertionError(f"rclpy got no matching message on {topic} in {timeout}s; "
                                     f"output:\n{self.proc.output()[-2000:]}")
            time.sleep(0.02)

    def received(self, topic: str) -> list[dict]:
        return [json.loads(x)["value"] for x in list(self.proc.lines)
                if x.startswith('{"msg": ') and json.loads(x)["msg"] == topic]

    def wait_nodes(self, want: tuple[str, str], timeout: float = 30.0) -> list:
        deadline = time.monotonic() + timeout
        while True:
            nodes = self.call(cmd="nodes")["nodes"]
            if list(want) in nodes:
                return nodes
            if time.monotonic() > deadline:
                raise AssertionError(f"rclpy's graph lacks {want}: {nodes}")
            time.sleep(0.2)

    def stop(self) -> None:
        try:
            self.send(cmd="quit")
            self.proc.wait(10)
        except Exception:
            pass
        self.proc.stop()


def ts(parent: str, child: str, xyz, q=(0.0, 0.0, 0.0, 1.0), sec: int = 100, nsec: int = 5) -> dict:
    return {"header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": parent}, "child_frame_id": child,
            "transform": {"translation": dict(zip("xyz", map(float, xyz))),
                          "rotation": dict(zip("xyzw", map(float, q)))}}


class World:
    """A router, a ROS domain, a bridge (CLI) between them and an rclpy node, for one test module."""

    def __init__(self, distro: str = "jazzy", *, bridge_args: tuple[str, ...] = (), rclpy_env: dict | None = None):
        self.python = ros2_python(distro)
        self.procs: list[Proc] = []
        self.router_proc, self.router = start_router()
        self.lock = DdsDomainLock()
        self.domain = self.lock.id
        self.ns = f"t_{uuid.uuid4().hex[:10]}"
        self.env = child_env(self.router, self.ns)
        self.env.pop("ZENTF_WIRE", None)
        self.env["ROS_DOMAIN_ID"] = str(self.domain)
        self.rclpy = Rclpy(self.python, self.domain, env=rclpy_env)
        self.bridge = self.start_bridge(*bridge_args)

    def start_bridge(self, *args: str, name: str = "zentf_bridge_dds", env: dict | None = None) -> Proc:
        p = Proc([sys.executable, "-m", "zentf.cli", "bridge", "dds", "--name", name, *args],
                 env=env or self.env)
        self.procs.append(p)
        p.wait_for_line("bridging tf, tf_static", timeout=60)
        return p

    def node_options(self, **kw: object):
        from zentf.transport.options import NodeOptions, ZenohOptions

        return NodeOptions(namespace=self.ns, zenoh=ZenohOptions(connect=[self.router], no_multicast=True,
                                                                  mode="client"), **kw)

    def close(self) -> None:
        for p in self.procs:
            p.stop(timeout=5)
        self.rclpy.stop()
        self.router_proc.stop()
        self.lock.release()


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    w = World(bridge_args=("--topic", "cmd_vel:geometry_msgs/msg/Twist", "--all"))
    w.bridge.wait_for_line("dds bridge: active", timeout=30)
    try:
        yield w
    finally:
        w.close()


def _lookup(buffer, target: str, source: str, publish, timeout: float = 30.0):
    """Publish (again) until the buffer has target<-source; returns the transform."""
    from zentf import Time

    deadline = time.monotonic() + timeout
    while True:
        publish()
        if buffer.can_transform(target, source, Time(), timeout=0.3):
            return buffer.lookup_transform(target, source, Time())
        if time.monotonic() > deadline:
            raise AssertionError(f"no transform {target} <- {source} through the bridge")


def _xyz(t) -> list[float]:
    tr = t.transform.translation
    q = t.transform.rotation
    return [tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w]


def test_rclpy_tf_and_statics_reach_zentf_listeners(world: World) -> None:
    """rclpy /tf and /tf_static -> bridge -> zentf: lookups equal what rclpy published; a zentf listener
    started after the robot's one static publish gets the statics."""
    from zentf import Buffer, Node, TransformListener

    world.rclpy.call(cmd="pub", topic="/tf_static", type=TF, latched=True,
                     msg={"transforms": [ts("base", "laser", (0.5, -0.25, 0.2), (0.0, 0.0, 0.6, 0.8))]})
    with Node("early_listener", options=world.node_options()) as node:
        buf = Buffer()
        TransformListener(buf, node)
        pub_tf = lambda: world.rclpy.call(cmd="pub", topic="/tf", type=TF,  # noqa: E731
                                          msg={"transforms": [ts("odom", "base", (1.5, 2.0, 3.0), sec=200, nsec=7)]})
        t = _lookup(buf, "odom", "base", pub_tf)
        assert _xyz(t) == [1.5, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]
        assert (t.header.stamp.sec, t.header.stamp.nanosec) == (200, 7)
        t = _lookup(buf, "base", "laser", lambda: None)
        assert _xyz(t) == [0.5, -0.25, 0.2, 0.0, 0.0, 0.6, 0.8]
    with Node("late_listener", options=world.node_options()) as node:  # the robot published its static once
        buf = Buffer()
        TransformListener(buf, node)
        t = _lookup(buf, "base", "laser", lambda: None)
        assert _xyz(t) == [0.5, -0.25, 0.2, 0.0, 0.0, 0.6, 0.8]


def test_zentf_broadcasters_reach_rclpy_subscribers(world: World) -> None:
    """zentf TransformBroadcaster and StaticTransformBroadcaster -> bridge -> rclpy: the TFMessage fields
    equal what was sent; an rclpy subscriber started late gets /tf_static."""
    from zentf import Node, StaticTransformBroadcaster, TransformBroadcaster
    from zentf.core.messages import TransformStamped

    world.rclpy.call(cmd="sub", topic="/tf", type=TF)
    world.rclpy.call(cmd="sub", topic="/tf_static", type=TF, latched=True)
    with Node("zentf_tf_pub", options=world.node_options()) as node:
        StaticTransformBroadcaster(node).send_transform(
            TransformStamped.from_dict(ts("world", "cam", (4.0, -5.0, 6.5), (0.0, 0.0, 0.6, 0.8), sec=3, nsec=4)))
        tb = TransformBroadcaster(node)
        dyn = TransformStamped.from_dict(ts("world", "arm", (0.25, 0.5, 0.75), sec=10, nsec=11))
        deadline = time.monotonic() + 30
        while not any(t["child_frame_id"] == "arm" for m in world.rclpy.received("/tf") for t in m["transforms"]):
            assert time.monotonic() < deadline, "rclpy got nothing on /tf"
            tb.send_transform(dyn)
            time.sleep(0.1)
        got = world.rclpy.wait_msg("/tf", lambda v: v["transforms"][0]["child_frame_id"] == "arm")
        assert got["transforms"][0] == ts("world", "arm", (0.25, 0.5, 0.75), sec=10, nsec=11)
        got = world.rclpy.wait_msg("/tf_static", lambda v: any(t["child_frame_id"] == "cam" for t in v["transforms"]))
        assert [t for t in got["transforms"] if t["child_frame_id"] == "cam"] == [
            ts("world", "cam", (4.0, -5.0, 6.5), (0.0, 0.0, 0.6, 0.8), sec=3, nsec=4)]
    # the zentf node is gone; a new rclpy subscriber still gets the static (the bridge's latched writer)
    late = Rclpy(world.python, world.domain, name="late_rclpy")
    try:
        late.call(cmd="sub", topic="/tf_static", type=TF, latched=True)
        got = late.wait_msg("/tf_static", lambda v: any(t["child_frame_id"] == "cam" for t in v["transforms"]))
        assert [t["transform"]["translation"] for t in got["transforms"] if t["child_frame_id"] == "cam"] == [
            {"x": 4.0, "y": -5.0, "z": 6.5}]
    finally:
        late.stop()


def test_clock_drives_sim_time_and_robot_state_publisher_feeds_rclpy(world: World) -> None:
    """/clock from rclpy drives a zentf node's sim time and rclpy's joint_states reach it; a zentf
    robot_state_publisher's tf_static and robot_description reach rclpy subscribers."""
    from zentf import Node

    with Node("sim_node", params={"use_sim_time": True}, options=world.node_options()) as node:
        deadline = time.monotonic() + 30
        while node.get_clock().now().nanoseconds != 1234 * 10**9 + 5:
            assert time.monotonic() < deadline, f"sim time stayed {node.get_clock().now()}"
            world.rclpy.call(cmd="pub", topic="/clock", type="rosgraph_msgs/msg/Clock", best_effort=True,
                             msg={"clock": {"sec": 1234, "nanosec": 5}})
            time.sleep(0.05)
        from zentf.core.messages import JointState

        states: "queue.Queue" = queue.Queue()
        node.create_subscription("joint_states", JointState, states.put)
        js = {"header": {"stamp": {"sec": 9, "nanosec": 10}, "frame_id": ""}, "name": ["wheel_l", "wheel_r"],
              "position": [0.5, -1.25], "velocity": [1.0, 2.0], "effort": []}
        deadline = time.monotonic() + 30
        while states.empty():
            assert time.monotonic() < deadline, "rclpy's joint_states never reached zentf"
            world.rclpy.call(cmd="pub", topic="/joint_states", type="sensor_msgs/msg/JointState", depth=10, msg=js)
            time.sleep(0.1)
        assert states.get().to_dict() == js
    urdf = REPO / "tests" / "data" / "urdf" / "urdf_tutorial" / "urdf" / "03-origins.urdf"
    world.rclpy.call(cmd="sub", topic="/robot_description", type="std_msgs/msg/String", latched=True)
    world.rclpy.call(cmd="sub", topic="/tf_static", type=TF, latched=True)
    rsp = Proc([sys.executable, "-m", "nodes.robot_state_publisher", str(urdf)], env=world.env)
    try:
        got = world.rclpy.wait_msg("/tf_static", lambda v: any(t["child_frame_id"] == "right_leg"
                                                                for t in v["transforms"]))
        leg = next(t for t in got["transforms"] if t["child_frame_id"] == "right_leg")
        assert leg["header"]["frame_id"] == "base_link"
        assert leg["transform"]["translation"] == {"x": 0.0, "y": -0.22, "z": 0.25}
        desc = world.rclpy.wait_msg("/robot_description", lambda v: "base_to_right_leg" in v["data"])
        assert desc["data"] == urdf.read_text()
    finally:
        rsp.stop()


def test_graphs_list_each_other(world: World) -> None:
    """rclpy's graph API lists the bridge's node and attributes its writers to it; zentf's graph lists the
    rclpy node and its topics."""
    from zentf.transport import graph

    world.rclpy.call(cmd="pub", topic="/tf_static", type=TF, latched=True,
                     msg={"transforms": [ts("base", "laser", (0.5, -0.25, 0.2), (0.0, 0.0, 0.6, 0.8))]})
    world.rclpy.wait_nodes(["/", "zentf_bridge_dds"])
    deadline = time.monotonic() + 30
    while ["/", "zentf_bridge_dds"] not in world.rclpy.call(cmd="info", topic="/tf")["publishers"]:
        assert time.monotonic() < deadline, f"rclpy does not attribute the bridge's /tf writer to its node: " \
                                            f"{world.rclpy.call(cmd='info', topic='/tf')}"
        time.sleep(0.2)
    from zentf.transport.options import ZenohOptions

    session = ZenohOptions(connect=[world.router], no_multicast=True, mode="client").open_session()
    try:
        deadline = time.monotonic() + 30
        while True:
            nodes = [n.fq_name for n in graph.list_nodes(session, timeout=1.0)]
            topics = {t.name: t for t in graph.list_topics(session, timeout=1.0)}
            static = topics.get(f"/{world.ns}/tf_static")
            if f"/{world.ns}/zentf_test_rclpy" in nodes and static and f"/{world.ns}/zentf_test_rclpy" in static.publishers:
                break
            assert time.monotonic() < deadline, f"zentf's graph lacks the rclpy node: {nodes} {list(topics)}"
        assert static.types == [TF]
    finally:
        session.close()


def test_named_and_discovered_topics(world: World) -> None:
    """--topic cmd_vel:geometry_msgs/msg/Twist carries a zentf publisher's Twist to rclpy; --all finds
    rclpy PointStamped topics the bridge was not told of (reliable, and best effort) and carries them to
    zentf subscribers."""
    from zentf import Node
    from zentf.core.messages import PointStamped, Twist

    world.rclpy.call(cmd="sub", topic="/cmd_vel", type="geometry_msgs/msg/Twist")
    got: "queue.Queue" = queue.Queue()
    with Node("zentf_topics", options=world.node_options()) as node:
        node.create_subscription("probe_point", PointStamped, got.put)
        pub = node.create_publisher("cmd_vel", Twist)
        twist = Twist.from_dict({"linear": {"x": 0.5, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": -1.5}})
        deadline = time.monotonic() + 30
        while not world.rclpy.received("/cmd_vel"):
            assert time.monotonic() < deadline, "rclpy got no /cmd_vel"
            pub.publish(twist)
            time.sleep(0.1)
        assert world.rclpy.received("/cmd_vel")[0] == twist.to_dict()
        point = {"header": {"stamp": {"sec": 7, "nanosec": 8}, "frame_id": "map"}, "point": {"x": 1.0, "y": 2.0, "z": 3.0}}
        deadline = time.monotonic() + 30
        while got.empty():
            assert time.monotonic() < deadline, "the discovered /probe_point never reached zentf"
            world.rclpy.call(cmd="pub", topic="/probe_point", type="geometry_msgs/msg/PointStamped", msg=point)
            time.sleep(0.1)
        assert got.get().to_dict() == point
        # a best-effort publisher (sensor data QoS) is matched too: the route takes the QoS it finds
        node.create_subscription("probe_best_effort", PointStamped, got.put)
        deadline = time.monotonic() + 30
        while got.empty():
            assert time.monotonic() < deadline, "the best-effort /probe_best_effort never reached zentf"
            world.rclpy.call(cmd="pub", topic="/probe_best_effort", type="geometry_msgs/msg/PointStamped",
                             best_effort=True, depth=5, msg=point)
            time.sleep(0.1)
        assert got.get().to_dict() == point


def _router_knows(world: World, session, key: str) -> None:
    """Wait until the router routes to the subscriptions ``session`` declared so far (the first messages a
    sender puts right after a declaration can otherwise miss it): a subscription on a probe key, declared
    after them on the same link, hears a put from another session."""
    import threading

    from zentf.transport.options import ZenohOptions

    heard = threading.Event()
    probe_key = f"zentf_test_probe/{os.getpid()}_{time.monotonic_ns()}"  # no program's key
    probe = session.declare_subscriber(probe_key, lambda _s: heard.set())
    other = ZenohOptions(connect=[world.router], no_multicast=True, mode="client").open_session()
    try:
        deadline = time.monotonic() + 30
        while not heard.wait(0.05):
            assert time.monotonic() < deadline, "the router never routed to a new subscription"
            other.put(probe_key, b"probe")
    finally:
        other.close()
        probe.undeclare()


def _count_zentf(world: World, key: str, n: int, send, what: str, marker: bytes = b"\xa3dup") -> list:
    """Samples (holding ``marker``) on a zentf key while ``send()`` publishes n distinct messages, after a
    quiet spell."""
    from zentf.transport.options import ZenohOptions

    session = ZenohOptions(connect=[world.router], no_multicast=True, mode="client").open_session()
    seen: list = []
    try:
        sub = session.declare_subscriber(key, lambda s: seen.append(s.payload.to_bytes())
                                         if marker in s.payload.to_bytes() else None)
        _router_knows(world, session, key)
        send()
        deadline = time.monotonic() + 30
        while len(seen) < n:
            assert time.monotonic() < deadline, f"{what}: {len(seen)} of {n} arrived"
            time.sleep(0.05)
        time.sleep(1.0)  # a duplicate would arrive within this
        sub.undeclare()
    finally:
        session.close()
    return seen


def test_two_bridges_one_relays_no_duplicates(world: World) -> None:
    """A second bridge between the same DDS domain and zentf graph: one of them stands by; every message
    arrives once on each side; when the relaying one stops, the other takes over."""
    second = world.start_bridge("--all", "--topic", "cmd_vel:geometry_msgs/msg/Twist", name="second_bridge")
    procs = {"first": world.bridge, "second": second}
    deadline = time.monotonic() + 30
    standby = None
    while standby is None:
        standby = next((k for k, p in procs.items() if any("dds bridge: standby" in x for x in p.lines)), None)
        assert time.monotonic() < deadline, "neither bridge stood by"
        time.sleep(0.05)
    n = 20
    from zentf import Buffer, Node, TransformListener

    with Node("warm_listener", options=world.node_options()) as node:  # rclpy's /tf writer matched first
        buf = Buffer()
        TransformListener(buf, node)
        _lookup(buf, "warm", "up", lambda: world.rclpy.call(cmd="pub", topic="/tf", type=TF,
                                                             msg={"transforms": [ts("warm", "up", (0, 0, 0))]}))
    seen = _count_zentf(world, f"{world.ns}/tf", n, lambda: [
        world.rclpy.call(cmd="pub", topic="/tf", type=TF, msg={"transforms": [ts("dup", f"c{i}", (i, 0, 0))]})
        for i in range(n)], "rclpy -> zentf")
    assert len(seen) == n, f"{len(seen)} samples for {n} messages"

    from zentf import TransformBroadcaster
    from zentf.core.messages import TransformStamped

    world.rclpy.call(cmd="sub", topic="/tf", type=TF)
    before = len([m for m in world.rclpy.received("/tf") if m["transforms"][0]["header"]["frame_id"] == "z2r"])
    with Node("zentf_dup_pub", options=world.node_options()) as node:
        tb = TransformBroadcaster(node)
        warm = TransformStamped.from_dict(ts("warm2", "up", (0, 0, 0)))
        deadline = time.monotonic() + 30
        while not any(m["transforms"][0]["header"]["frame_id"] == "warm2" for m in world.rclpy.received("/tf")):
            assert time.monotonic() < deadline, "rclpy got nothing from zentf"
            tb.send_transform(warm)
            time.sleep(0.1)

        def send() -> None:
            for i in range(n):
                tb.send_transform(TransformStamped.from_dict(ts("z2r", f"c{i}", (i, 0, 0))))

        # on the zentf side only the broadcaster's n: no bridge brings them back
        seen = _count_zentf(world, f"{world.ns}/tf", n, send, "zentf broadcaster", marker=b"\xa3z2r")
        assert len(seen) == n, f"{len(seen)} samples on the zentf side for {n} sent"
        got = lambda: [m for m in world.rclpy.received("/tf") if m["transforms"][0]["header"]["frame_id"] == "z2r"]  # noqa: E731
        deadline = time.monotonic() + 30
        while len(got()) - before < n * world.rclpy.subs["/tf"]:
            assert time.monotonic() < deadline, f"zentf -> rclpy: {len(got()) - before} of {n}"
            time.sleep(0.05)
        time.sleep(1.0)
    # each message once per rclpy subscription (the helper has /tf subscriptions from earlier tests too)
    counts = {}
    for m in got()[before:]:
        counts[m["transforms"][0]["child_frame_id"]] = counts.get(m["transforms"][0]["child_frame_id"], 0) + 1
    assert counts == {f"c{i}": world.rclpy.subs["/tf"] for i in range(n)}  # once per rclpy subscription

    relaying = "second" if standby == "first" else "first"
    procs[relaying].stop()
    procs[standby].wait_for_line("dds bridge: active", timeout=30)
    if relaying == "first":
        world.bridge = second
    # the takeover is seen by its first relayed message; each message sent after it arrives once
    from zentf.transport.options import ZenohOptions

    session = ZenohOptions(connect=[world.router], no_multicast=True, mode="client").open_session()
    seen: list = []
    try:
        session.declare_subscriber(f"{world.ns}/tf", lambda s: seen.append(s.payload.to_bytes())
                                   if b"\xa3dup" in s.payload.to_bytes() else None)
        deadline, k = time.monotonic() + 30, 0
        while not seen:
            assert time.monotonic() < deadline, f"after takeover: none of {k} messages arrived"
            world.rclpy.call(cmd="pub", topic="/tf", type=TF, msg={"transforms": [ts("dup", f"after{k}", (1, 0, 0))]})
            k += 1
            time.sleep(0.5)
        time.sleep(1.0)  # a duplicate would arrive within this
    finally:
        session.close()
    assert len(seen) == len(set(seen)), "a message relayed twice after the takeover"  # each payload is unique


def test_ros2_wire_bridge_beside_a_zentf_wire_one(world: World) -> None:
    """--wire ros2 (rmw_zenoh's format on the zentf side) beside the zentf-wire bridge on the same DDS
    domain: rclpy's /tf reaches a ros2-wire zentf listener, a ros2-wire broadcaster reaches rclpy once
    (neither bridge relays what the other wrote to DDS)."""
    from zentf import Buffer, Node, TransformBroadcaster, TransformListener
    from zentf.core.messages import TransformStamped
    from zentf.transport.options import NodeOptions, ZenohOptions

    env = dict(world.env)
    env.pop("ZENTF_NAMESPACE", None)
    world.start_bridge("--wire", "ros2", "--domain", str(world.domain), name="ros2_wire_bridge", env=env)
    opts = NodeOptions(wire="ros2", domain_id=world.domain,
                       zenoh=ZenohOptions(connect=[world.router], no_multicast=True, mode="client"))
    world.rclpy.call(cmd="sub", topic="/tf", type=TF)
    with Node("ros2_wire_node", options=opts) as node:
        buf = Buffer()
        TransformListener(buf, node)
        t = _lookup(buf, "rw_odom", "rw_base", lambda: world.rclpy.call(
            cmd="pub", topic="/tf", type=TF, msg={"transforms": [ts("rw_odom", "rw_base", (7.0, 8.0, 9.0))]}))
        assert _xyz(t) == [7.0, 8.0, 9.0, 0.0, 0.0, 0.0, 1.0]
        tb = TransformBroadcaster(node)
        deadline = time.monotonic() + 30
        mine = lambda: [m for m in world.rclpy.received("/tf") if m["transforms"][0]["header"]["frame_id"] == "rw_z"]  # noqa: E731
        while not mine():
            assert time.monotonic() < deadline, "rclpy got nothing from the ros2-wire node"
            tb.send_transform(TransformStamped.from_dict(ts("rw_z", "warm", (0, 0, 0))))
            time.sleep(0.1)
        before = len(mine())
        crossed: list = []  # the zentf-wire bridge must not read the ros2-wire one's DDS writes into zentf
        spy = node.session.declare_subscriber(f"{world.ns}/tf", lambda s: crossed.append(1)
                                              if b"rw_z" in s.payload.to_bytes() else None)
        tb.send_transform(TransformStamped.from_dict(ts("rw_z", "once", (1, 2, 3))))
        deadline = time.monotonic() + 30
        while not any(m["transforms"][0]["child_frame_id"] == "once" for m in mine()):
            assert time.monotonic() < deadline, "rclpy did not get the ros2-wire transform"
            time.sleep(0.05)
        time.sleep(1.0)  # a copy through the zentf-wire bridge would arrive within this
        spy.undeclare()
        assert crossed == []
        once = [m for m in mine()[before:] if m["transforms"][0]["child_frame_id"] == "once"]
        assert len(once) == world.rclpy.subs["/tf"]  # once per rclpy subscription
        assert once[0]["transforms"][0]["transform"]["translation"] == {"x": 1.0, "y": 2.0, "z": 3.0}


def test_kilted_with_the_robot_setting() -> None:
    """Kilted (Fast DDS 3) with the documented robot setting (type propagation off): /tf both ways."""
    profile_env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "RMW_IMPLEMENTATION")}
    profile_env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(KILTED_PROFILE)
    w = World("kilted", rclpy_env=profile_env)
    try:
        from zentf import Buffer, Node, TransformBroadcaster, TransformListener
        from zentf.core.messages import TransformStamped

        w.rclpy.call(cmd="sub", topic="/tf", type=TF)
        with Node("kilted_listener", options=w.node_options()) as node:
            buf = Buffer()
            TransformListener(buf, node)
            t = _lookup(buf, "k_odom", "k_base", lambda: w.rclpy.call(
                cmd="pub", topic="/tf", type=TF, msg={"transforms": [ts("k_odom", "k_base", (1.0, 2.0, 3.0))]}))
            assert _xyz(t) == [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]
            tb = TransformBroadcaster(node)
            deadline = time.monotonic() + 30
            while not w.rclpy.received("/tf") or not any(
                    m["transforms"][0]["header"]["frame_id"] == "k_z" for m in w.rclpy.received("/tf")):
                assert time.monotonic() < deadline, "Kilted rclpy got nothing from zentf"
                tb.send_transform(TransformStamped.from_dict(ts("k_z", "k_c", (4.0, 5.0, 6.0))))
                time.sleep(0.1)
        got = w.rclpy.wait_msg("/tf", lambda v: v["transforms"][0]["header"]["frame_id"] == "k_z")
        assert got["transforms"][0] == ts("k_z", "k_c", (4.0, 5.0, 6.0))
        w.rclpy.wait_nodes(["/", "zentf_bridge_dds"])
    finally:
        w.close()


def test_launch_demo_with_dds() -> None:
    """`zentf launch laser dds:=true`: the demo's bridge program puts its frames on DDS for rclpy."""
    python = ros2_python("jazzy")
    router_proc, router = start_router()
    lock = DdsDomainLock()
    env = child_env(router, f"t_{uuid.uuid4().hex[:10]}")
    env.pop("ZENTF_WIRE", None)
    env["ROS_DOMAIN_ID"] = str(lock.id)
    launch = rclpy = None
    try:
        launch = Proc([sys.executable, "-m", "zentf.cli", "launch", "laser", "dds:=true"], env=env)
        launch.wait_for_line("dds bridge: active", timeout=120)  # a whole demo starts first
        rclpy = Rclpy(python, lock.id)
        rclpy.call(cmd="sub", topic="/tf_static", type=TF, latched=True)
        got = rclpy.wait_msg("/tf_static", lambda v: {"laser", "camera"} <= {t["child_frame_id"] for t in v["transforms"]})
        laser = next(t for t in got["transforms"] if t["child_frame_id"] == "laser")
        assert laser["header"]["frame_id"] == "base_link"
        assert laser["transform"]["translation"] == {"x": 0.4, "y": 0.0, "z": 0.2}
        rclpy.wait_nodes(["/", "dds_bridge"])
        launch.signal(2)
        assert launch.wait(30) == 0
    finally:
        if rclpy is not None:
            rclpy.stop()
        if launch is not None:
            launch.stop()
        router_proc.stop()
        lock.release()


def test_bad_input_is_dropped_with_one_line(world: World) -> None:
    """Malformed CDR from DDS and a wrong payload from zentf are dropped (counted, one rate-limited line);
    the bridge keeps relaying; bad command lines are one line and exit 2."""
    from zentf import Buffer, Node, TransformListener
    from zentf.transport.options import ZenohOptions
    from zentf.tools.dds.cyclone import DdsDomain, TopicQos

    forger = DdsDomain(world.domain, mark=False)
    try:
        w = forger.writer("rt/tf", TF, TopicQos(depth=100), mark=False)
        from zentf.ros import encode_tf
        from zentf.tools.dds.cyclone import DdsError

        for garbage in (b"\x00\x01\x00\x00\xff\xff\xff\x7f" + b"\x00" * 64, b"\x01\x00"):
            with pytest.raises(DdsError):  # Cyclone checks the CDR against the type: it never leaves a writer
                w.write(garbage)
        # well-formed CDR with bad content: a name that is not UTF-8, a negative stamp, NaN
        not_utf8 = encode_tf([ts("ab", "cd", (1, 2, 3))]).replace(b"ab\x00", b"\xff\xfe\x00")
        bad = [not_utf8, encode_tf([ts("n_odom", "n_base", (1, 2, 3), sec=-5)]),
               encode_tf([ts("n_odom", "n_base", (float("nan"), 2, 3))])]
        session = ZenohOptions(connect=[world.router], no_multicast=True, mode="client").open_session()
        with Node("after_garbage", options=world.node_options()) as node:
            buf = Buffer()
            TransformListener(buf, node)
            for payload in bad:
                w.write(payload)
            session.put(f"{world.ns}/tf", b"\xc1 not msgpack")             # zentf side: garbage on the tf key
            t = _lookup(buf, "g_odom", "g_base", lambda: w.write(encode_tf([ts("g_odom", "g_base", (1, 2, 3))])))
            assert _xyz(t) == [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]
            assert not buf.can_transform("n_odom", "n_base", __import__("zentf").Time())
        session.close()
    finally:
        forger.close()
    assert world.bridge.returncode is None
    world.bridge.wait_for_line(r"not relayed to DDS from '/t_\w+/tf': not valid msgpack", timeout=10, from_start=True)
    for args, text in ((["--topic", "x:nope/msg/Nothing"], "no ROS 2 message type 'nope/msg/Nothing'"),
                       (["--topic", "bad name:std_msgs/msg/String"], "bad topic name"),
                       (["--domain", "300"], "300"),
                       (["--dds-peer", "192.0.2.7"], "add --lan")):
        r = subprocess.run([sys.executable, "-m", "zentf.cli", "bridge", "dds", *args], env=world.env,
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 2, (args, r.stderr)
        assert text in r.stderr and "Traceback" not in r.stderr
