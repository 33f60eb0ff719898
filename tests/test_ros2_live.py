"""Live interop with an independent ROS 2-over-Zenoh implementation (zenoh-ros2-sdk, test-only).

A ROS 2 node made with the SDK publishes /tf and /tf_static; a zentf listener process, `zentf tf echo`,
`zentf topic list`, `zentf node list` and a listener started late all see them with ``--wire ros2``.
The reverse: zentf's broadcasters (``ZENTF_WIRE=ros2``) publish and the SDK's subscriber decodes the right
values, including a latched /tf_static it only asks for after it was sent (rmw_zenoh's transient local).
Each test has its own router and ROS domain.
"""
from __future__ import annotations

import json
import math
import sys

import pytest

from cli_helpers import zentf, zentf_together
from conftest import REPO, router_address

pytest.importorskip("zenoh_ros2_sdk")

SDK_NODE = [sys.executable, str(REPO / "tests" / "ros2_sdk_node.py")]

LISTENER = """
import sys, time
from zentf.transport.buffer import Buffer
from zentf.core.time import Time
from zentf.transport.listener import TransformListener
from zentf.transport.node import Node
node = Node("zentf_listener")
buf = Buffer()
TransformListener(buf, node)
deadline = time.monotonic() + 30
while time.monotonic() < deadline:
    try:
        t = buf.lookup_transform("map", "base_link", Time())
    except Exception:
        time.sleep(0.05)
        continue
    tr = t.transform.translation
    print(f"map->base_link {tr.x:.3f} {tr.y:.3f} {tr.z:.3f}", flush=True)
    break
node.shutdown()
"""

BROADCASTER = """
import time
from zentf.transport.broadcaster import StaticTransformBroadcaster, TransformBroadcaster
from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
from zentf.core.time import Time
from zentf.transport.node import Node
node = Node("zentf_broadcaster")
static = StaticTransformBroadcaster(node)
static.send_transform(TransformStamped(Header(Time(sec=7, nanosec=5), "world"), "robot",
                                       Transform(Vector3(4.0, -5.0, 6.5), Quaternion(0.0, 0.0, 0.6, 0.8))))
print("static sent", flush=True)
tf = TransformBroadcaster(node)
i = 0
while node.ok():
    i += 1
    tf.send_transform(TransformStamped(Header(Time(sec=100 + i), "robot"), "gripper",
                                       Transform(Vector3(0.25, 0.5, 0.75))))
    time.sleep(0.05)
"""


def test_zentf_sees_a_ros2_node(ros2_env, spawn, tmp_path) -> None:
    sdk = spawn([*SDK_NODE, "pub", router_address(ros2_env), "--node", "sdk_tf_node"], ros2_env)
    sdk.wait_for_line("publishing", timeout=60)
    listener = spawn([sys.executable, "-c", LISTENER], ros2_env)
    m = listener.wait_for_line(r"map->base_link (\S+) (\S+) (\S+)", timeout=40)
    assert [float(x) for x in m.groups()] == [1.5, 2.0, 3.0]   # map->odom (1,2,3) + odom->base_link (0.5,0,0)

    # independent observers of the one SDK node, a few at a time (their waits overlap instead of adding up)
    echo, topics, nodes, info, static = zentf_together([
        ["tf", "echo", "map", "base_link", "--count", "1", "--timeout", "30"],
        ["topic", "list", "-t", "--wait", "3"],
        ["node", "list", "--wait", "3"],
        ["node", "info", "/sdk_tf_node", "--wait", "3"],
        ["topic", "echo", "/tf_static", "--once", "--json", "--timeout", "30"]], ros2_env)
    assert echo.returncode == 0, echo.stderr
    assert "Translation: [1.500, 2.000, 3.000]" in echo.stdout

    assert topics.returncode == 0, topics.stderr
    assert "/tf [tf2_msgs/msg/TFMessage]" in topics.stdout
    assert "/tf_static [tf2_msgs/msg/TFMessage]" in topics.stdout
    assert "/sdk_tf_node" in nodes.stdout.split(), nodes.stdout
    assert "/tf: tf2_msgs/msg/TFMessage" in info.stdout, info.stdout

    assert static.returncode == 0, static.stderr
    msg = json.loads(static.stdout.splitlines()[0])
    t = msg["transforms"][0]
    assert (t["header"]["frame_id"], t["child_frame_id"]) == ("map", "odom")
    assert t["transform"]["translation"] == {"x": 1.0, "y": 2.0, "z": 3.0}

    monitor, frames, hz, graph = zentf_together([
        ["tf", "monitor", "--duration", "2"],
        ["tf", "frames", "--wait", "1", "--print", "-o", str(tmp_path / "frames")],
        ["topic", "hz", "/tf", "--duration", "2"],
        ["graph", "--wait", "2"]], ros2_env)
    assert monitor.returncode == 0, monitor.stderr
    # ROS 2's tf2_monitor says "Authority undetectable"; zentf names the sender by the GID in its attachment
    # (resolved to a node where it is rmw_zenoh's hash of the token key; zenoh-ros2-sdk draws random GIDs)
    assert "base_link" in monitor.stdout and "publisher gid " in monitor.stdout, monitor.stdout
    assert frames.returncode == 0, frames.stderr
    assert "odom" in frames.stdout and "base_link" in frames.stdout and (tmp_path / "frames.gv").exists()
    assert hz.returncode == 0 and "average rate: " in hz.stdout, hz.stdout + hz.stderr
    rate = float(hz.stdout.split("average rate: ")[-1].split()[0])
    assert 5 < rate < 15                                                   # the SDK node publishes at 10 Hz
    assert "/sdk_tf_node" in graph.stdout and "-> /tf [tf2_msgs/msg/TFMessage]" in graph.stdout

    # a listener that starts late, after the SDK node has been publishing for a while
    late = spawn([sys.executable, "-c", LISTENER.replace("zentf_listener", "late_listener")], ros2_env)
    m = late.wait_for_line(r"map->base_link (\S+) (\S+) (\S+)", timeout=40)
    assert [float(x) for x in m.groups()] == [1.5, 2.0, 3.0]

    # the same graph without the profile is not a zentf graph: nothing of it shows
    plain_env = {k: v for k, v in ros2_env.items() if k not in ("ZENTF_WIRE",)}
    plain = zentf(["topic", "list", "--wait", "1"], plain_env)
    assert "/tf" not in plain.stdout.split()


def test_a_ros2_node_sees_zentf_broadcasters(ros2_env, spawn) -> None:
    bc = spawn([sys.executable, "-c", BROADCASTER], ros2_env)
    bc.wait_for_line("static sent", timeout=40)
    # the SDK subscriber starts after the static transform went out: it must come from the latched cache
    sub = spawn([*SDK_NODE, "sub", router_address(ros2_env), "--node", "sdk_listener"], ros2_env)
    sub.wait_for_line("subscribed", timeout=60)
    # (the SDK queries the cache while it builds the subscriber: the line may come before "subscribed")
    line = sub.wait_for_line(r'"topic": "/tf_static"', timeout=40, from_start=True).string
    got = json.loads(line)
    assert (got["parent"], got["child"], got["stamp"]) == ("world", "robot", 7_000_000_005)
    assert got["t"] == [4.0, -5.0, 6.5] and got["q"] == [0.0, 0.0, 0.6, 0.8]
    line = sub.wait_for_line(r'"topic": "/tf"', timeout=40).string
    got = json.loads(line)
    assert (got["parent"], got["child"]) == ("robot", "gripper")
    assert got["t"] == [0.25, 0.5, 0.75] and got["stamp"] % 1_000_000_000 == 0 and got["stamp"] > 100e9
    assert math.isclose(sum(q * q for q in got["q"]), 1.0)


def test_bag_record_of_a_ros2_graph_is_a_rosbag2_mcap(ros2_env, spawn, tmp_path) -> None:
    mcap_reader = pytest.importorskip("mcap.reader")
    decoder = pytest.importorskip("mcap_ros2.decoder")
    sdk = spawn([*SDK_NODE, "pub", router_address(ros2_env), "--node", "sdk_tf_node"], ros2_env)
    sdk.wait_for_line("publishing", timeout=60)
    out = tmp_path / "robot.mcap"
    rec = zentf(["bag", "record", "/tf", "/tf_static", "-o", str(out), "--duration", "2"], ros2_env)
    assert rec.returncode == 0, rec.stderr
    with out.open("rb") as f:   # read back by mcap-ros2-support (independent of zentf)
        reader = mcap_reader.make_reader(f, decoder_factories=[decoder.DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        seen: dict[str, list] = {"/tf": [], "/tf_static": []}
        for schema, channel, _, msg in reader.iter_decoded_messages():
            assert schema.name == "tf2_msgs/msg/TFMessage" and schema.encoding == "ros2msg"
            assert channel.message_encoding == "cdr"
            assert channel.metadata["topic_type_hash"].startswith("RIHS01_e369d0f0")
            t = msg.transforms[0]
            seen[channel.topic].append((t.header.frame_id, t.child_frame_id, t.transform.translation.x))
    assert len(seen["/tf"]) >= 5 and set(seen["/tf"]) == {("odom", "base_link", 0.5)}
    assert seen["/tf_static"] and set(seen["/tf_static"]) == {("map", "odom", 1.0)}
