"""Buffer, TransformListener and broadcasters across real processes on loopback."""
from __future__ import annotations

import math
import threading
import time
import textwrap

import pytest

from zentf.transport.buffer import Buffer
from zentf.transport.broadcaster import StaticTransformBroadcaster, TransformBroadcaster
from zentf.core.exceptions import LookupException
from zentf.transport.listener import TransformListener
from zentf.core.messages import Header, PointStamped, Point, Transform, TransformStamped, Vector3, Quaternion
from zentf.transport.node import Node
from zentf.core.time import Time

BROADCASTER = textwrap.dedent("""
    import math, sys, time
    from zentf.transport.node import Node, init_logging
    from zentf.transport.broadcaster import StaticTransformBroadcaster, TransformBroadcaster
    from zentf.core.messages import TransformStamped, Header, Transform, Vector3, Quaternion
    from zentf.core.time import Time
    init_logging()
    def ts(parent, child, x, y=0.0, z=0.0, stamp=None):
        return TransformStamped(Header(stamp or Time(), parent), child,
                                Transform(Vector3(x, y, z), Quaternion(0.0, 0.0, 0.0, 1.0)))
    node = Node(sys.argv[1])
    static = StaticTransformBroadcaster(node)
    static.send_transform(ts("base_link", "laser", 0.1, 0.0, 0.2))
    static.send_transform([ts("base_link", "camera", 1.0, 0.0, 0.0), ts("base_link", "laser", 0.1, 0.0, 0.3)])
    dyn = TransformBroadcaster(node)
    x0 = float(sys.argv[2])
    def tick():
        dyn.send_transform(ts("world", "base_link", x0, stamp=node.get_clock().now()))
    node.create_timer(0.02, tick)
    print("ready", flush=True)
    node.spin()
""")


def _ts(parent: str, child: str, x: float, stamp: Time | None = None) -> TransformStamped:
    return TransformStamped(Header(stamp or Time(), parent), child,
                            Transform(Vector3(x, 0.0, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0)))


def test_transforms_from_another_process(spawn, node_options) -> None:
    p = spawn.python("-c", BROADCASTER, "bcast", "5.0")
    with Node("listener", options=node_options) as node:
        buf = Buffer(node=node)
        tl = TransformListener(buf, node)
        t = buf.lookup_transform("world", "laser", Time(), timeout=20)
        assert t.transform.translation.x == pytest.approx(5.1)
        assert t.transform.translation.z == pytest.approx(0.3)   # re-sent child replaced
        cam = buf.lookup_transform("laser", "camera", Time(), timeout=5)
        assert cam.transform.translation.x == pytest.approx(0.9)
        assert cam.transform.translation.z == pytest.approx(-0.3)
        # authority = the sending node's fully qualified name
        assert f"/{node_options.namespace}/bcast" in buf.all_frames_as_yaml()
        pt = buf.transform(PointStamped(Header(Time(), "laser"), Point(1.0, 0.0, 0.0)), "base_link", timeout=2)
        assert (pt.point.x, pt.point.z) == pytest.approx((1.1, 0.3))
        assert tl.stats()["bad_messages"] == 0 and tl.stats()["transforms"] > 0
        tl.unregister()
    p.stop()


def test_late_joining_listener_gets_statics(spawn, node_options) -> None:
    p = spawn.python("-c", BROADCASTER, "early", "0.0")
    p.wait_for_line("ready", timeout=20)
    time.sleep(0.3)  # let the statics go out with nobody listening (nothing to await: no subscriber yet)
    with Node("late", options=node_options) as node:
        buf = Buffer(node=node)
        TransformListener(buf, node, static_only=True)
        assert buf.can_transform("laser", "camera", Time(), timeout=10), p.output()
        t = buf.lookup_transform("camera", "laser", Time())
        assert (t.transform.translation.x, t.transform.translation.z) == pytest.approx((-0.9, 0.3))
        assert not buf.can_transform("world", "base_link", Time())  # static_only: no dynamic data


def test_static_publisher_started_after_listener(spawn, node_options) -> None:
    with Node("first", options=node_options) as node:
        buf = Buffer(node=node)
        TransformListener(buf, node)
        p = spawn.python("-c", BROADCASTER, "later", "0.0")
        assert buf.can_transform("laser", "camera", Time(), timeout=20), p.output()


def test_blocking_lookup_wakes_on_arrival(node_options) -> None:
    buf = Buffer()
    threading.Timer(0.3, lambda: buf.set_transform(_ts("a", "b", 1.0), "test")).start()
    t0 = time.monotonic()
    t = buf.lookup_transform("a", "b", Time(), timeout=10)
    elapsed = time.monotonic() - t0
    assert t.transform.translation.x == 1.0
    assert 0.25 < elapsed < 2.0
    t0 = time.monotonic()
    with pytest.raises(LookupException):
        buf.lookup_transform("a", "nowhere", Time(), timeout=0.3)
    assert 0.28 < time.monotonic() - t0 < 2.0
    ok, msg = buf.can_transform("a", "nowhere", Time(), timeout=0.1, return_debug_tuple=True)
    assert not ok and "canTransform returned after" in msg


def test_tf2_py_core_spellings_on_a_buffer_answer_at_once() -> None:
    """A Buffer inherits tf2_py's *_core methods: (bool, reason) without waiting, as on a BufferCore."""
    buf = Buffer()
    buf.set_transform(_ts("map", "odom", 1.0, stamp=Time(10)), "test")
    assert buf.can_transform_core("map", "odom", Time(10)) == (True, "")
    ok, why = buf.can_transform_core("map", "nowhere", Time(10))
    assert not ok and "nowhere" in why
    assert buf.can_transform_full_core("map", Time(10), "odom", Time(10), "map") == (True, "")
    ok, why = buf.can_transform_full_core("map", Time(10), "nowhere", Time(10), "map")
    assert not ok and "nowhere" in why
    assert buf.lookup_transform_core("map", "odom", Time(10)).transform.translation.x == 1.0


def test_blocking_lookup_across_processes_and_publisher_restart(spawn, node_options) -> None:
    with Node("waiter", options=node_options) as node:
        buf = Buffer(node=node)
        TransformListener(buf, node)
        result: list = []
        waiter = threading.Thread(target=lambda: result.append(buf.lookup_transform("world", "base_link", Time(),
                                                                                     timeout=20)))
        waiter.start()
        p = spawn.python("-c", BROADCASTER, "pub1", "1.0")
        waiter.join(25)
        assert result and result[0].transform.translation.x == 1.0, p.output()
        p.kill()                                              # publisher dies without a goodbye
        p2 = spawn.python("-c", BROADCASTER, "pub1", "2.0")    # and comes back with the same name
        assert buf.wait_for(lambda: buf.lookup_transform("world", "base_link", Time()).transform.translation.x
                            == 2.0, 20), p2.output()
        assert buf.lookup_transform("world", "base_link", Time()).transform.translation.x == 2.0, p2.output()


def test_static_broadcaster_replaces_and_accumulates(node_options) -> None:
    with Node("sb", options=node_options) as a, Node("sl", options=node_options) as b:
        sb = StaticTransformBroadcaster(a)
        sb.send_transform(_ts("p", "c1", 1.0))
        sb.send_transform(_ts("p", "c2", 2.0))
        sb.send_transform(_ts("q", "c1", 3.0))  # re-parented and replaced
        assert [(t.header.frame_id, t.child_frame_id) for t in sb.transforms] == [("q", "c1"), ("p", "c2")]
        buf = Buffer(node=b)
        TransformListener(buf, b)
        assert buf.can_transform("q", "c1", Time(), timeout=10)
        assert buf.can_transform("p", "c2", Time(), timeout=10)
        assert buf.lookup_transform("q", "c1", Time()).transform.translation.x == 3.0


def test_broadcaster_accepts_dicts_and_lists(node_options) -> None:
    with Node("d", options=node_options) as a:
        buf = Buffer(node=a)
        TransformListener(buf, a)
        br = TransformBroadcaster(a)
        assert br.wait_for_subscribers(5)
        br.send_transform([_ts("w", "r1", 1.0, Time(sec=5)), _ts("w", "r2", 2.0, Time(sec=5)).to_dict()])
        assert buf.can_transform("r1", "r2", Time(sec=5), timeout=5)
        with pytest.raises(TypeError):
            br.send_transform([42])  # type: ignore[list-item]
        assert math.isclose(buf.lookup_transform("r1", "r2", Time(sec=5)).transform.translation.x, 1.0)


def test_compiled_send_transform_sends_what_the_python_path_sends(node_options, zenoh_session) -> None:
    """send_transform(one TransformStamped) runs compiled (tf_encoder.OneTransformSender) to Zenoh's put:
    a raw subscriber on the tf key gets the payload and attachment the Python path sends for the same
    transform given as a list; a subclass overriding send_transform keeps its override."""
    from zentf.transport.ingest.tf_encoder import OneTransformSender

    got: list[tuple[bytes, bytes]] = []
    arrived = threading.Condition()

    def on_sample(sample) -> None:
        with arrived:
            got.append((sample.payload.to_bytes(), sample.attachment.to_bytes()))
            arrived.notify_all()

    with Node("compiled_sender", options=node_options) as node:
        sub = zenoh_session.declare_subscriber(node.topic_key("tf"), on_sample)
        try:
            br = TransformBroadcaster(node)
            assert isinstance(br.send_transform, OneTransformSender)
            assert br.wait_for_subscribers(10)
            ts = _ts("world", "robot", 1.5, Time(sec=7, nanosec=9))
            br.send_transform(ts)          # compiled
            br.sendTransform(ts)           # the alias too
            br.send_transform([ts])        # Python path (a list)
            br.send_transform(ts.to_dict())  # Python path (a dict), same map
            with arrived:
                assert arrived.wait_for(lambda: len(got) == 4, 10), got
            assert got[0] == got[1] == got[2]
            assert got[0][1] == node.get_fully_qualified_name().encode()
            assert wire_decode_tf(got[0][0]) == wire_decode_tf(got[3][0])
        finally:
            sub.undeclare()

        class Counting(TransformBroadcaster):
            calls = 0

            def send_transform(self, transform):  # type: ignore[override]
                Counting.calls += 1
                super().send_transform(transform)

        Counting(node).send_transform(ts)
        assert Counting.calls == 1


def wire_decode_tf(payload: bytes) -> list:
    from zentf.transport.wire import codec as wire
    from zentf.core.messages import TFMessage

    return [t.to_dict() for t in wire.decode(payload, TFMessage).transforms]
