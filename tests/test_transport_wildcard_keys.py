"""A put on a key expression with wildcards (``**``, ``t$*``, ``<ns>/*``) reaches every subscriber it
intersects and arrives there under that wildcard: receivers drop it. Real sessions on a router of the
test's own (a put on ``**`` reaches every subscriber of the router)."""
from __future__ import annotations

import threading

import pytest

from zentf.core.messages import Clock, Header, Quaternion, Transform, TransformStamped, Vector3
from zentf.core.time import Time
from zentf.transport.buffer import Buffer
from zentf.transport.listener import TransformListener
from zentf.transport.node import Node
from zentf.transport.options import NodeOptions, ZenohOptions

pytestmark = pytest.mark.timeout(60)


def _ts(parent: str, child: str, x: float) -> TransformStamped:
    return TransformStamped(Header(Time(), parent), child, Transform(Vector3(x, 0.0, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0)))


@pytest.mark.parametrize("wire", ["zentf", "ros2"])
def test_listeners_drop_samples_put_on_wildcard_keys(isolated_router, test_namespace, wire) -> None:
    zopts = ZenohOptions(connect=[isolated_router], no_multicast=True, mode="client")
    opts = NodeOptions(namespace=test_namespace, zenoh=zopts, wire=wire)
    sim_opts = NodeOptions(namespace=test_namespace, zenoh=zopts, wire=wire, params={"use_sim_time": True})
    with Node("sim", options=sim_opts) as sim, Node("listener", options=opts) as node, \
            Node("forger", options=opts) as forger:
        jumps: list[int] = []  # sim time going back (1000 -> 666) runs the jump callbacks
        sim.get_clock().add_jump_callback(lambda old, new: jumps.append(new.nanoseconds))
        buf = Buffer(node=node)
        TransformListener(buf, node)
        seven = threading.Event()
        times: list[int] = []

        def on_clock(msg: Clock) -> None:
            times.append(msg.clock.sec)
            if msg.clock.sec == 7:
                seven.set()

        node.create_subscription("/clock", Clock, on_clock)
        session = forger.session
        profile = forger.wire
        tf_key = profile.data_key(forger.resolve_topic_name("tf"), "tf2_msgs/msg/TFMessage")
        clock_key = profile.data_key("/clock", Clock.TYPE_NAME)
        enc = profile.encoding("tf2_msgs/msg/TFMessage")
        evil = profile.encode_tf([_ts("base", f"evil{i}", 666.0) for i in range(1)])
        wild = ["**", f"{test_namespace}/**", f"{test_namespace}/*", f"{test_namespace}/t$*",
                "**/tf", tf_key.replace("/tf", "/t$*", 1)]
        clock_wild = ["**", "clo$*", "*"] if wire == "zentf" else ["**", "0/clo$*/**", "0/clock/*/*"]
        clock_payload = profile.encode(Clock.from_dict({"clock": {"sec": 666, "nanosec": 0}}), Clock.TYPE_NAME)
        pub = session.declare_publisher(tf_key, encoding=enc)
        matched = threading.Event()
        watch = pub.declare_matching_listener(lambda status: status.matching and matched.set())
        assert matched.is_set() or pub.matching_status.matching or matched.wait(30), "no listener matched"
        watch.undeclare()
        pub.put(profile.encode_tf([_ts("base", "good", 1.0)]))
        buf.lookup_transform("base", "good", Time(), timeout=10)  # the listener takes concrete puts
        clock_enc = profile.encoding(Clock.TYPE_NAME)
        session.put(clock_key, profile.encode(Clock.from_dict({"clock": {"sec": 1000, "nanosec": 0}}), Clock.TYPE_NAME),
                    encoding=clock_enc)
        assert sim.get_clock().sleep_until(Time(1000, 0), timeout=10)  # ...and the sim clock concrete ones
        for key in wild:
            session.put(key, evil, encoding=enc)
        for key in clock_wild:
            session.put(key, clock_payload, encoding=profile.encoding(Clock.TYPE_NAME))
        last = profile.encode_tf([_ts("base", "last", 1.0)])
        session.put(clock_key, profile.encode(Clock.from_dict({"clock": {"sec": 7, "nanosec": 0}}), Clock.TYPE_NAME),
                    encoding=clock_enc)
        session.put(clock_key, profile.encode(Clock.from_dict({"clock": {"sec": 1001, "nanosec": 0}}), Clock.TYPE_NAME),
                    encoding=clock_enc)
        pub.put(last)
        buf.lookup_transform("base", "last", Time(), timeout=10)  # sent after every wildcard put
        assert seven.wait(10) and sim.get_clock().sleep_until(Time(1001, 0), timeout=10)
        assert 666 not in times, times
        assert jumps == [7 * 10**9], jumps  # only the concrete step back, 1000 -> 7
        frames = buf.all_frames_as_string()
        assert "evil" not in frames, frames
