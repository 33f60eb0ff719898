"""Sim time (/clock) for timers, clocks and the buffer; MessageFilter delivery and drop reasons."""
from __future__ import annotations

import logging
import threading
import time

import pytest

from zentf.transport.broadcaster import StaticTransformBroadcaster, TransformBroadcaster
from zentf.transport.buffer import Buffer
from zentf.transport.clock import Clock, Rate
from zentf.transport.listener import TransformListener
from zentf.transport.message_filter import FilterFailureReason, MessageFilter
from zentf.core.messages import Clock as ClockMsg
from zentf.core.messages import Header, Point, PointStamped, Quaternion, Transform, TransformStamped, Vector3
from zentf.transport.node import Node
from zentf.core.time import Time

from test_transport_tf import BROADCASTER


def _ts(parent: str, child: str, x: float, stamp: Time) -> TransformStamped:
    return TransformStamped(Header(stamp, parent), child, Transform(Vector3(x, 0, 0), Quaternion(0, 0, 0, 1)))


def _sim_options(node_options, test_namespace):
    """use_sim_time, with /clock remapped into the test namespace so parallel tests never share a clock."""
    return node_options.with_(params={"use_sim_time": True}, remappings={"/clock": f"/{test_namespace}/clock"})


def test_sim_time_drives_clock_and_timers(node_options, test_namespace) -> None:
    sim = _sim_options(node_options, test_namespace)
    with Node("simnode", options=sim) as node, Node("clockpub", options=node_options) as src:
        clock = node.get_clock()
        assert clock.ros_time_is_active and clock.now() == Time()
        pub = src.create_publisher("clock", ClockMsg)   # /<ns>/clock
        assert pub.wait_for_subscribers(5)
        pub.publish(ClockMsg(Time(sec=100)))
        assert clock.sleep_until(Time(sec=100), timeout=5)
        ticks: list[Time] = []
        cond = threading.Condition()

        def tick() -> None:
            with cond:
                ticks.append(clock.now())
                cond.notify_all()

        node.create_timer(1.0, tick)
        for k in range(1, 31):                           # 100.1 ... 103.0 s of sim time, fast
            pub.publish(ClockMsg(Time(nanoseconds=100_000_000_000 + k * 100_000_000)))
            if k % 10 == 0:                              # each whole second must fire the 1 s timer
                with cond:
                    assert cond.wait_for(lambda: len(ticks) == k // 10, 5), ticks
        assert clock.now() == Time(sec=103)
        assert ticks == [Time(sec=101), Time(sec=102), Time(sec=103)]
        # Rate and sleep follow sim time too
        rate = Rate(2.0, clock)
        woke = threading.Event()
        threading.Thread(target=lambda: (rate.sleep(), woke.set()), daemon=True).start()
        assert not woke.wait(0.2)                        # sim time is frozen: no wake-up by wall time
        pub.publish(ClockMsg(Time(sec=104)))
        assert woke.wait(5)


def test_real_clock_topic_with_isolated_router(isolated_router, test_namespace) -> None:
    from zentf.transport.options import NodeOptions, ZenohOptions

    z = ZenohOptions(connect=[isolated_router], no_multicast=True, mode="client")
    with Node("sim", options=NodeOptions(namespace=test_namespace, params={"use_sim_time": True}, zenoh=z)) as node, \
            Node("src", options=NodeOptions(zenoh=z)) as src:
        pub = src.create_publisher("/clock", ClockMsg)
        assert pub.wait_for_subscribers(5)
        pub.publish({"clock": {"sec": 42, "nanosec": 5}})
        assert node.get_clock().sleep_until(Time(42, 5), timeout=5)
        pub.publish_bytes(b"\x93garbage")                # a bad /clock message is dropped, time stays
        pub.publish({"clock": {"sec": 43, "nanosec": 0}})
        assert node.get_clock().sleep_until(Time(43), timeout=5)


def test_jump_back_clears_buffer_but_not_statics(node_options, test_namespace, caplog) -> None:
    sim = _sim_options(node_options, test_namespace)
    with Node("tfsim", options=sim) as node, Node("feeder", options=node_options) as src:
        clock = node.get_clock()
        buf = Buffer(node=node)
        TransformListener(buf, node)
        cpub = src.create_publisher("clock", ClockMsg)
        assert cpub.wait_for_subscribers(5)
        cpub.publish(ClockMsg(Time(sec=200)))
        assert clock.sleep_until(Time(sec=200), timeout=5)
        br = TransformBroadcaster(src)
        StaticTransformBroadcaster(src).send_transform(_ts("s", "t", 1.0, Time(sec=200)))
        assert br.wait_for_subscribers(5)
        br.send_transform(_ts("a", "b", 2.0, clock.now()))
        # lookups at the (sim) now of the node find data stamped in sim time
        assert buf.lookup_transform("a", "b", clock.now(), timeout=5).transform.translation.x == 2.0
        assert buf.can_transform("s", "t", Time(), timeout=5)
        with caplog.at_level(logging.WARNING, logger="zentf.transport.listener"):
            cpub.publish(ClockMsg(Time(sec=150)))        # bag loop: time goes back
            assert buf.wait_for(lambda: not buf.can_transform("a", "b", Time()), 5)
        assert any("Detected jump back in time" in r.getMessage() for r in caplog.records)
        assert buf.can_transform("s", "t", Time())       # statics survive
        br.send_transform(_ts("a", "b", 3.0, Time(sec=150)))   # no TF_OLD_DATA after the clear
        assert buf.lookup_transform("a", "b", Time(sec=150), timeout=5).transform.translation.x == 3.0


def test_wall_clock_rate() -> None:
    clock = Clock()
    rate = Rate(50.0, clock)
    t0 = time.monotonic()
    for _ in range(5):
        rate.sleep()
    assert 0.07 < time.monotonic() - t0 < 0.5
    with pytest.raises(ValueError):
        Rate(0)


# ---------------------------------------------------------------- MessageFilter


def test_message_filter_delivers_and_drops(spawn, node_options) -> None:
    p = spawn.python("-c", BROADCASTER, "robot", "2.0")
    with Node("mf", options=node_options) as node, Node("sensor", options=node_options) as sensor:
        buf = Buffer(node=node)
        TransformListener(buf, node)
        delivered: list[PointStamped] = []
        failures: list[tuple[PointStamped, FilterFailureReason]] = []
        got = threading.Event()
        failed = threading.Event()
        mf = MessageFilter("points", buf, "world", 3, 0.5, node=node, msg_type=PointStamped,
                           callback=lambda m: (delivered.append(m), got.set()),
                           failure_callback=lambda m, r: (failures.append((m, r)), failed.set()))
        pub = sensor.create_publisher("points", PointStamped)
        assert pub.wait_for_subscribers(5)
        assert buf.can_transform("world", "laser", Time(), timeout=20), p.output()
        # 1. a fresh point in 'laser' arrives before (or with) its transform and is delivered
        pub.publish(PointStamped(Header(node.get_clock().now(), "laser"), Point(1.0, 0.0, 0.0)))
        assert got.wait(5)
        out = buf.transform(delivered[0], "world")
        assert (out.point.x, out.point.z) == pytest.approx((3.1, 0.3))
        # 2. empty frame id
        mf.add(PointStamped(Header(node.get_clock().now(), ""), Point()))
        assert failed.wait(5) and failures[-1][1] is FilterFailureReason.EmptyFrameID
        # 3. older than anything in the cache
        failed.clear()
        mf.add(PointStamped(Header(Time(sec=1), "laser"), Point()))
        assert failed.wait(5) and failures[-1][1] is FilterFailureReason.OutTheBack
        # 4. a frame nobody publishes: dropped when the timeout (0.5 s) expires
        failed.clear()
        t0 = time.monotonic()
        mf.add(PointStamped(Header(node.get_clock().now(), "nowhere"), Point()))
        assert failed.wait(5) and failures[-1][1] is FilterFailureReason.NoTransformFound
        assert time.monotonic() - t0 >= 0.45
        # 5. queue of 3: the fourth waiting message pushes the oldest out
        failed.clear()
        for k in range(4):
            mf.add(PointStamped(Header(node.get_clock().now(), "nowhere"), Point(float(k), 0, 0)))
        assert failed.wait(5)
        full = [m for m, r in failures if r is FilterFailureReason.QueueFull]
        assert [m.point.x for m in full] == [0.0]
        assert mf.dropped[FilterFailureReason.QueueFull] == 1
        mf.close()


def test_message_filter_waits_for_late_transform(node_options) -> None:
    with Node("mf2", options=node_options) as node:
        buf = Buffer(node=node)
        got = threading.Event()
        mf = MessageFilter(None, buf, ["map", "odom"], 10, None, callback=lambda m: got.set())
        mf.add(PointStamped(Header(Time(sec=10), "base"), Point()))
        assert not got.is_set()
        buf.set_transform(_ts("odom", "base", 1.0, Time(sec=10)), "test")
        buf.set_transform(_ts("map", "odom", 1.0, Time(sec=10)), "test")
        assert got.wait(5) and mf.delivered == 1
        mf.close()
