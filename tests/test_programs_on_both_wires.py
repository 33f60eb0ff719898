"""Every program `zentf run` lists works on both wires: started together on one router (zentf's wire in a
namespace of its own, ROS 2's in a ROS domain of its own), each one's output is seen on the graph by a node
on the same wire (transforms in a listener's buffer, messages on its subscriptions, a buffer server's
answers), or, for the programs that only print, in the line they print from what they heard. The DDS
bridge's other side is a Cyclone DDS participant in the test (its domain is the test's ROS_DOMAIN_ID): a
transform written there reaches the observer's buffer, and the graph's tf_static reaches a DDS reader."""
from __future__ import annotations

import sys
import threading
import time
import uuid
from collections.abc import Callable

import pytest

from conftest import REPO, Proc, child_env
from test_nodes_teleop_key import UP, PtyProc
from zentf.core.messages import JointState, MarkerArray, PointStamped, TurtlePose, Twist
from zentf.core.time import Time
from zentf.tools.programs import PROGRAMS, module_of
from zentf.transport.buffer import Buffer
from zentf.transport.buffer_server import BufferClient
from zentf.transport.listener import TransformListener
from zentf.transport.node import Node
from zentf.transport.options import NodeOptions, ZenohOptions

URDF = str(REPO / "configs" / "robots" / "my_robot.urdf")
#: program -> its arguments (static_transform_publisher's laser is what the point and buffer demos use)
ARGS: dict[str, list[str]] = {
    "static_transform_publisher": ["0.4", "0", "0.2", "0", "0", "0", "base_link", "laser"],
    "robot_state_publisher": [URDF, "--frame-prefix", "r/"],
    "joint_state_publisher": [URDF],
    "turtle_teleop_key": ["-p", "turtlename:=turtle3"],
}
#: programs started only to feed others: a camera for frame_listener, turtle2's frame for the follower
HELPERS = [["zentf.tools.static_transform_publisher", "0", "0.1", "0.3", "0", "0", "0", "base_link", "camera"],
           ["zentf.demos.turtle_tf_broadcaster", "--name", "turtle2_tf", "-p", "turtlename:=turtle2"]]
WAIT = 120.0  # 16 programs start at once on a loaded 2-core machine


class Inbox:
    """The first messages each subscribed topic delivers to the observer node."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.got: dict[str, list] = {}
        self.cond = threading.Condition()

    def subscribe(self, topic: str, msg_type: type) -> None:
        self.got[topic] = []

        def on(msg: object) -> None:
            with self.cond:
                if len(self.got[topic]) < 1000:
                    self.got[topic].append(msg)
                self.cond.notify_all()

        self.node.create_subscription(topic, msg_type, on)

    def first(self, topic: str, ok: Callable[[object], bool] = lambda m: True, timeout: float = WAIT) -> object:
        with self.cond:
            assert self.cond.wait_for(lambda: any(ok(m) for m in self.got[topic]), timeout), \
                f"nothing fitting on {topic} within {timeout:g} s ({len(self.got[topic])} messages)"
            return next(m for m in self.got[topic] if ok(m))


def _translation(buffer: Buffer, target: str, source: str) -> tuple[float, float, float]:
    t = buffer.lookup_transform(target, source, Time(), timeout=WAIT).transform.translation
    return t.x, t.y, t.z


def _dds_both_ways(domain: int, buffer: Buffer) -> bool:
    """A TFMessage written on DDS's rt/tf comes out of the bridge into ``buffer``; the graph's tf_static
    (static_transform_publisher's laser) comes out of the bridge on DDS's rt/tf_static."""
    from zentf.ros import encode_tf
    from zentf.tools.dds.convert import cdr_to_message
    from zentf.tools.dds.cyclone import DdsDomain, TopicQos

    d = DdsDomain(domain, mark=False)  # an ordinary DDS node, not a bridge
    try:
        writer = d.writer("rt/tf", "tf2_msgs/msg/TFMessage", TopicQos(depth=100), mark=False)
        reader = d.reader("rt/tf_static", "tf2_msgs/msg/TFMessage", TopicQos(transient_local=True, depth=1), 1)
        statics: set[str] = set()
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline and not (
                "laser" in statics and buffer.can_transform("dds_parent", "dds_child", Time())):
            now = time.time()
            writer.write(encode_tf([{"header": {"stamp": {"sec": int(now), "nanosec": 0}, "frame_id": "dds_parent"},
                                     "child_frame_id": "dds_child",
                                     "transform": {"translation": {"x": 7.0, "y": 0.0, "z": 0.0},
                                                   "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}]))
            d.wait(0.2)
            statics.update(t.child_frame_id for cdr, _ in reader.take()
                           for t in cdr_to_message(cdr, "tf2_msgs/msg/TFMessage").transforms)
        assert "laser" in statics, f"no laser on DDS's rt/tf_static (got {sorted(statics)})"
        return _translation(buffer, "dds_parent", "dds_child") == (7.0, 0.0, 0.0)
    finally:
        d.close()


@pytest.mark.parametrize("wire", ["zentf", "ros2"])
def test_every_program_works_on_both_wires(wire: str, zenoh_router: str) -> None:
    ns = f"t_{uuid.uuid4().hex[:10]}"
    domain = 1 + uuid.uuid4().int % 200
    env = {**child_env(zenoh_router, ns), "ZENTF_WIRE": wire, "ROS_DOMAIN_ID": str(domain)}
    opts = NodeOptions(namespace=ns, wire=wire, domain_id=domain,
                       zenoh=ZenohOptions(connect=[zenoh_router], no_multicast=True, mode="client"))
    procs: dict[str, Proc] = {}
    with Node("observer", options=opts) as obs:
        buffer = Buffer()
        TransformListener(buffer, obs)
        inbox = Inbox(obs)
        for topic, msg_type in (("joint_states", JointState), ("turtle1/pose", TurtlePose),
                                ("turtle2/cmd_vel", Twist), ("turtle3/cmd_vel", Twist),
                                ("visual_markers", MarkerArray), ("laser_point", PointStamped)):
            inbox.subscribe(topic, msg_type)
        try:
            for name in PROGRAMS:
                argv = [sys.executable, "-m", module_of(name), *ARGS.get(name, [])]
                procs[name] = PtyProc(argv, env) if name == "turtle_teleop_key" else Proc(argv, env)
            for i, argv in enumerate(HELPERS):
                procs[f"helper{i}"] = Proc([sys.executable, "-m", *argv], env)

            def press_up(_: object = None) -> Twist:
                key = procs["turtle_teleop_key"]
                key.wait_for_line(r"Use arrow keys", WAIT)
                deadline = time.monotonic() + WAIT
                while time.monotonic() < deadline:  # the first presses may beat the route to the observer
                    key.keys(UP)
                    try:
                        return inbox.first("turtle3/cmd_vel", timeout=1.0)
                    except AssertionError:
                        continue
                raise AssertionError("no turtle3/cmd_vel after pressing up")

            checks: dict[str, Callable[[], None]] = {
                "static_transform_publisher": lambda: _check(
                    _translation(buffer, "base_link", "laser") == (0.4, 0.0, 0.2)),
                "robot_state_publisher": lambda: _check(  # a fixed joint (tf_static), a movable one (tf)
                    _translation(buffer, "r/base_link", "r/right_leg") == pytest.approx((0.0, -0.22, 0.25))
                    and _translation(buffer, "r/base_link", "r/head") == pytest.approx((0.0, 0.0, 0.3))),
                "joint_state_publisher": lambda: _check(
                    "head_swivel" in inbox.first("joint_states").name),
                "buffer_server": lambda: _check(_server_lookup(obs) == pytest.approx((0.4, 0.0, 0.2))),
                "turtlesim": lambda: _check(inbox.first("turtle1/pose").x > 0),
                "turtle_tf_broadcaster": lambda: _check(_translation(buffer, "world", "turtle1")[0] > 0),
                "turtle_teleop": lambda: _check(inbox.first("turtle1/pose", lambda p: p.linear_velocity > 0)),
                "turtle_follower": lambda: _check(inbox.first("turtle2/cmd_vel")),
                "turtle_teleop_key": lambda: _check(press_up().linear.x == 2.0),
                "frames_publisher": lambda: _check(_translation(buffer, "world", "av1") is not None),
                "plots_publisher": lambda: _check(inbox.first("visual_markers").markers),
                "point_publisher": lambda: _check(inbox.first("laser_point").header.frame_id == "laser"),
                "point_listener": lambda: _check(procs["point_listener"].wait_for_line(
                    r"obstacle in base_link: ", WAIT)),
                "frame_listener": lambda: _check(procs["frame_listener"].wait_for_line(r"laser in camera: ", WAIT)),
                "dds_bridge": lambda: _check(_dds_both_ways(domain, buffer)),
            }
            assert set(checks) == set(PROGRAMS), "a program without its check"
            failed = {}
            for name, check in checks.items():
                try:
                    check()
                except Exception as e:  # noqa: BLE001 - every program's result in one report
                    failed[name] = f"{type(e).__name__}: {str(e)[:300]}\n{procs[name].output()[-600:]}"
            assert not failed, f"on the {wire} wire:\n" + "\n\n".join(f"{k}: {v}" for k, v in failed.items())
        finally:
            for p in procs.values():
                p.stop(timeout=3)
                if isinstance(p, PtyProc):
                    p.close()


def _check(ok: object) -> None:
    assert ok


def _server_lookup(node: Node) -> tuple[float, float, float]:
    client = BufferClient(node)
    try:
        assert client.wait_for_server(WAIT)
        t = client.lookup_transform("base_link", "laser", Time(), timeout=WAIT).transform.translation
        return t.x, t.y, t.z
    finally:
        client.destroy()
