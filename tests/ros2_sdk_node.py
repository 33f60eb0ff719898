"""A ROS 2 node made with zenoh-ros2-sdk (an independent ROS 2-over-Zenoh implementation), for the live tests.

    python tests/ros2_sdk_node.py pub ROUTER_HOST:PORT [--node NAME]   # /tf and /tf_static as a ROS 2 node
    python tests/ros2_sdk_node.py sub ROUTER_HOST:PORT                 # prints what arrives on /tf, /tf_static
    python tests/ros2_sdk_node.py joints ROUTER_HOST:PORT --joint head_swivel=0.5 ...   # /joint_states

``pub`` publishes, every 0.1 s until stopped: /tf_static map -> odom (1, 2, 3) (transient local, depth 1)
and /tf odom -> base_link with x = 0.5 and the current time; it prints ``publishing`` once the first
pair is out. ``joints`` publishes sensor_msgs/JointState on /joint_states every 0.1 s (the given joints
and positions, stamped now) and prints ``publishing`` after the first. ``sub`` prints one JSON line per received transform: topic, parent, child, stamp (ns),
translation, rotation. ROS_DOMAIN_ID picks the domain. The SDK reads its .msg definitions from
tests/data/ros2_msgs (its own git download cannot work offline).
"""
from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from pathlib import Path

MSGS = Path(__file__).resolve().parent / "data" / "ros2_msgs"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=("pub", "sub", "joints"))
    ap.add_argument("router")
    ap.add_argument("--node", default="sdk_tf_node")
    ap.add_argument("--joint", action="append", default=[], metavar="NAME=POSITION")
    args = ap.parse_args()
    host, _, port = args.router.rpartition(":")

    from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber, get_message_class, get_registry
    from zenoh_ros2_sdk.qos import QosDurability, QosProfile
    from zenoh_ros2_sdk.session import ZenohSession

    ZenohSession.get_instance(host, int(port))  # first: the SDK's shared session, on our router
    get_registry(str(MSGS))  # the first call fixes the registry's folder
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *a: stop.set())
    signal.signal(signal.SIGINT, lambda *a: stop.set())
    latched = QosProfile(durability=QosDurability.TRANSIENT_LOCAL, history_depth=1)
    tf_qos = QosProfile(history_depth=100)
    ts_cls = get_message_class("geometry_msgs/msg/TransformStamped")
    hdr_cls = get_message_class("std_msgs/msg/Header")
    time_cls = get_message_class("builtin_interfaces/msg/Time")
    tr_cls = get_message_class("geometry_msgs/msg/Transform")
    v_cls = get_message_class("geometry_msgs/msg/Vector3")
    q_cls = get_message_class("geometry_msgs/msg/Quaternion")

    def stamped(parent: str, child: str, ns: int, xyz: tuple) -> object:
        return ts_cls(header=hdr_cls(stamp=time_cls(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=parent),
                      child_frame_id=child,
                      transform=tr_cls(translation=v_cls(x=xyz[0], y=xyz[1], z=xyz[2]),
                                       rotation=q_cls(x=0.0, y=0.0, z=0.0, w=1.0)))

    if args.mode == "joints":
        import numpy as np  # the SDK's serializer (rosbags) takes float64[] fields as numpy arrays

        names = [j.split("=")[0] for j in args.joint]
        positions = np.array([float(j.split("=")[1]) for j in args.joint], dtype=np.float64)
        none = np.zeros(0, dtype=np.float64)
        js = ROS2Publisher("/joint_states", "sensor_msgs/msg/JointState", node_name=args.node, router_ip=host,
                           router_port=int(port), qos=QosProfile(history_depth=10))
        first = True
        while not stop.is_set():
            ns = time.time_ns()
            js.publish(header=hdr_cls(stamp=time_cls(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""),
                       name=names, position=positions, velocity=none, effort=none)
            if first:
                print("publishing", flush=True)
                first = False
            stop.wait(0.1)
        js.close()
        return 0

    if args.mode == "pub":
        static = ROS2Publisher("/tf_static", "tf2_msgs/msg/TFMessage", node_name=args.node, router_ip=host,
                               router_port=int(port), qos=latched)
        tf = ROS2Publisher("/tf", "tf2_msgs/msg/TFMessage", node_name=args.node, router_ip=host,
                           router_port=int(port), qos=tf_qos)
        first = True
        while not stop.is_set():
            static.publish(transforms=[stamped("map", "odom", 1_000_000_000, (1.0, 2.0, 3.0))])
            tf.publish(transforms=[stamped("odom", "base_link", time.time_ns(), (0.5, 0.0, 0.0))])
            if first:
                print("publishing", flush=True)
                first = False
            stop.wait(0.1)
        static.close()
        tf.close()
        return 0

    out_lock = threading.Lock()

    def printer(topic: str):
        def on_msg(msg: object) -> None:
            for t in msg.transforms:
                tr, q = t.transform.translation, t.transform.rotation
                line = json.dumps({"topic": topic, "parent": t.header.frame_id, "child": t.child_frame_id,
                                   "stamp": t.header.stamp.sec * 10**9 + t.header.stamp.nanosec,
                                   "t": [tr.x, tr.y, tr.z], "q": [q.x, q.y, q.z, q.w]})
                with out_lock:  # two subscriptions call back from their own threads: one whole line each
                    sys.stdout.write(line + "\n")
                    sys.stdout.flush()
        return on_msg

    subs = [ROS2Subscriber("/tf_static", "tf2_msgs/msg/TFMessage", printer("/tf_static"), node_name=args.node,
                           router_ip=host, router_port=int(port), qos=latched),
            ROS2Subscriber("/tf", "tf2_msgs/msg/TFMessage", printer("/tf"), node_name=args.node,
                           router_ip=host, router_port=int(port), qos=tf_qos)]
    print("subscribed", flush=True)
    stop.wait()
    for s in subs:
        s.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
