"""Two robots, one world: robot1/ and robot2/ namespaces with prefixed frames, and listeners that
watch one robot (``tf`` in the robot's namespace) or all of them (``*/tf``, ``*/tf_static``)."""
from __future__ import annotations

import pytest

from zentf.transport.buffer import Buffer
from zentf.transport.listener import TransformListener
from zentf.transport.node import Node
from zentf.core.time import Time

pytestmark = pytest.mark.timeout(90)


def _robot(spawn, zenoh_args: list[str], ns: str, robot: str, x: float) -> None:
    args = [a if a != ns else f"{ns}/{robot}" for a in zenoh_args]  # --namespace <test ns>/<robot>
    spawn.python("-m", "nodes.frames_publisher", *args, "-p", f"frame_prefix:={robot}/", "-p", "rate:=20")
    spawn.python("-m", "nodes.static_transform_publisher", *args, "--x", str(x), "--frame-id", f"{robot}/av1",
                 "--child-frame-id", f"{robot}/camera")


def test_one_robot_or_all_robots(spawn, zenoh_args, node_options, test_namespace: str) -> None:
    _robot(spawn, zenoh_args, test_namespace, "robot1", 0.1)
    _robot(spawn, zenoh_args, test_namespace, "robot2", 0.2)
    all_node = Node("watch_all", options=node_options)
    one_node = Node("watch_one", options=node_options.with_(namespace=f"{test_namespace}/robot1"))
    try:
        every = Buffer()
        TransformListener(every, all_node, tf_topic="*/tf", tf_static_topic="*/tf_static")
        one = Buffer()
        TransformListener(one, one_node)
        # all robots: both trees meet in world, statics of both arrive through */tf_static
        cross = every.lookup_transform("robot1/camera", "robot2/camera", Time(), timeout=30)
        assert cross.header.frame_id == "robot1/camera"
        frames = {i["frame"] for i in every.frame_info()}
        assert {"robot1/av1", "robot1/av2", "robot1/camera", "robot2/av1", "robot2/av2", "robot2/camera"} <= frames
        assert every.lookup_transform("robot2/av1", "robot2/camera", Time()).transform.translation.x == \
            pytest.approx(0.2)
        # one robot: robot1's tree only, although robot2 has been publishing all along
        assert one.lookup_transform("world", "robot1/camera", Time(), timeout=10)
        since = one.lookup_transform("world", "robot1/av1", Time()).header.stamp.nanoseconds
        # robot2 kept publishing while `one` listened (a new robot2 sample 0.2 s later reached `every`)
        assert every.wait_for(lambda: every.lookup_transform("world", "robot2/av1", Time()).header.stamp
                              .nanoseconds > since + 200_000_000, 10)
        mine = {i["frame"] for i in one.frame_info()}
        assert mine == {"robot1/av1", "robot1/av2", "robot1/camera"}, mine
    finally:
        one_node.shutdown()
        all_node.shutdown()


def test_wildcard_must_be_a_whole_part(node_options) -> None:
    node = Node("bad_wild", options=node_options)
    try:
        with pytest.raises(ValueError, match="whole part"):
            TransformListener(Buffer(), node, tf_topic="robot*/tf")
    finally:
        node.shutdown()


def test_frame_listener_node_watches_all_robots(spawn, zenoh_args, test_namespace: str) -> None:
    """nodes.frame_listener with tf_topic:=*/tf looks across robots; both fly the same av1 path,
    so robot2's camera (0.2 m ahead on its av1) is 0.1 m ahead of robot1's (0.1 m ahead on its av1)."""
    _robot(spawn, zenoh_args, test_namespace, "robot1", 0.1)
    _robot(spawn, zenoh_args, test_namespace, "robot2", 0.2)
    watcher = spawn.python("-m", "nodes.frame_listener", *zenoh_args, "-p", "tf_topic:=*/tf",
                           "-p", "tf_static_topic:=*/tf_static", "-p", "target_frame:=robot1/camera",
                           "-p", "source_frame:=robot2/camera", "-p", "period:=0.2")
    for _ in range(3):
        m = watcher.wait_for_line(r"robot2/camera in robot1/camera: translation \((\S+), (\S+), (\S+)\)", 30)
        assert [float(v) for v in m.groups()] == pytest.approx([0.1, 0.0, 0.0], abs=0.02)
