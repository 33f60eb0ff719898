"""A real ROS 2 node (rclpy on Fast DDS, the test venv of tests/ros2/make_env.sh) driven by the tests.

Runs under the test venv's python, not zentf's: it imports nothing of zentf. Commands arrive one JSON
object a line on stdin; results go to stdout one JSON object a line ({"ok": ...} after each command, and
{"msg": ...} for every message a subscription receives), so one process serves several checks.

    {"cmd": "pub", "topic": "/tf", "type": "tf2_msgs/msg/TFMessage", "msg": {...}, "latched": false}
    {"cmd": "sub", "topic": "/tf_static", "type": "tf2_msgs/msg/TFMessage", "latched": true}
    {"cmd": "nodes"}                      -> {"ok": "nodes", "nodes": [[namespace, name], ...]}
    {"cmd": "topics"}                     -> {"ok": "topics", "topics": [[name, [types]], ...]}
    {"cmd": "count", "topic": "/tf"}      -> {"ok": "count", "publishers": n, "subscribers": n}
    {"cmd": "info", "topic": "/tf"}       -> {"ok": "info", "publishers": [[ns, node], ...], "subscribers": [...]}
    {"cmd": "quit"}
"""
from __future__ import annotations

import importlib
import json
import os
import sys
import threading

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

_out = threading.Lock()


def say(obj: dict) -> None:
    with _out:
        sys.stdout.write(json.dumps(obj) + "\n")
        sys.stdout.flush()


def msg_class(type_name: str):
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


def _element_class(spec: str):
    """'sequence<geometry_msgs/TransformStamped, 5>' -> the message class, None for primitives."""
    inner = spec.split("<", 1)[1].rsplit(">", 1)[0] if "<" in spec else spec
    inner = inner.split(",")[0].strip()
    if "[" in inner:
        inner = inner.split("[")[0]
    if "/" not in inner:
        return None
    pkg, name = inner.split("/")[0], inner.split("/")[-1]
    return msg_class(f"{pkg}/msg/{name}")


def to_plain(msg):
    """A ROS message as plain data (rosidl_runtime_py has no wheel)."""
    if hasattr(msg, "get_fields_and_field_types"):
        return {f: to_plain(getattr(msg, f)) for f in msg.get_fields_and_field_types()}
    if isinstance(msg, (bytes, bytearray)):
        return list(msg)
    if hasattr(msg, "tolist"):
        return msg.tolist()
    if isinstance(msg, (list, tuple)):
        return [to_plain(x) for x in msg]
    return msg


def fill(msg, plain: dict):
    """Set a ROS message's fields from plain data."""
    types = msg.get_fields_and_field_types()
    for key, value in plain.items():
        current = getattr(msg, key)
        if hasattr(current, "get_fields_and_field_types"):
            fill(current, value)
        elif isinstance(value, list) and _element_class(types[key]) is not None:
            cls = _element_class(types[key])
            setattr(msg, key, [fill(cls(), v) for v in value])
        elif types[key] in ("double", "float") and isinstance(value, int):
            setattr(msg, key, float(value))  # rclpy does not check by default and would write garbage
        else:
            setattr(msg, key, value)
    return msg


def qos(cmd: dict) -> QoSProfile:
    if cmd.get("latched"):
        return QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE,
                          history=HistoryPolicy.KEEP_LAST)
    if cmd.get("best_effort"):
        return QoSProfile(depth=int(cmd.get("depth", 1)), reliability=ReliabilityPolicy.BEST_EFFORT)
    return QoSProfile(depth=int(cmd.get("depth", 100)))


def main() -> int:
    rclpy.init()
    node = Node(sys.argv[1] if len(sys.argv) > 1 else "zentf_test_rclpy")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    pubs: dict = {}
    subs: list = []
    say({"ok": "ready"})
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        cmd = json.loads(line)
        what = cmd["cmd"]
        if what == "quit":
            break
        if what == "pub":
            key = (cmd["topic"], cmd["type"], bool(cmd.get("latched")), bool(cmd.get("best_effort")))
            pub = pubs.get(key)
            if pub is None:
                pub = pubs[key] = node.create_publisher(msg_class(cmd["type"]), cmd["topic"], qos(cmd))
            for _ in range(int(cmd.get("repeat", 1))):
                pub.publish(fill(msg_class(cmd["type"])(), cmd["msg"]))
            say({"ok": "pub"})
        elif what == "sub":
            topic = cmd["topic"]

            def on_msg(msg, topic=topic) -> None:
                say({"msg": topic, "value": to_plain(msg)})

            subs.append(node.create_subscription(msg_class(cmd["type"]), topic, on_msg, qos(cmd)))
            say({"ok": "sub"})
        elif what == "nodes":
            say({"ok": "nodes", "nodes": [[ns, n] for n, ns in node.get_node_names_and_namespaces()]})
        elif what == "topics":
            say({"ok": "topics", "topics": [[n, t] for n, t in node.get_topic_names_and_types()]})
        elif what == "info":
            say({"ok": "info", "publishers": [[i.node_namespace, i.node_name] for i in
                                              node.get_publishers_info_by_topic(cmd["topic"])],
                 "subscribers": [[i.node_namespace, i.node_name] for i in
                                 node.get_subscriptions_info_by_topic(cmd["topic"])]})
        elif what == "count":
            say({"ok": "count", "publishers": node.count_publishers(cmd["topic"]),
                 "subscribers": node.count_subscribers(cmd["topic"])})
        else:
            say({"error": f"unknown command {what}"})
    rclpy.shutdown()  # ends the executor's spin
    spinner.join(timeout=5)
    sys.stdout.flush()
    os._exit(0)  # no interpreter teardown under rclpy's threads


if __name__ == "__main__":
    main()
