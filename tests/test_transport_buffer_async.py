"""Buffer's asyncio (*_async) and concurrent.futures (*_future) waits: woken by inserts, timeouts, cancel."""
from __future__ import annotations

import asyncio
import concurrent.futures
import textwrap
import threading
import time

import pytest

from zentf.transport.buffer import Buffer
from zentf.core.exceptions import ExtrapolationException, LookupException
from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
from zentf.core.time import Time
from zentf.transport.listener import TransformListener
from zentf.transport.node import Node


def ts(parent: str, child: str, x: float, stamp: Time | None = None) -> TransformStamped:
    return TransformStamped(Header(stamp or Time(), parent), child,
                            Transform(Vector3(x, 0.0, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0)))


def pending(buf: Buffer) -> int:
    return len(buf._pending)


def test_async_lookup_wakes_on_insert_from_another_thread() -> None:
    buf = Buffer()
    buf.set_transform(ts("map", "odom", 1.0, Time(10)), "test", is_static=True)

    async def main() -> None:
        task = asyncio.ensure_future(buf.lookup_transform_async("map", "base", Time(10)))
        fut = buf.wait_for_transform_future("map", "base", Time(10))
        await asyncio.sleep(0)  # let the task register its wait
        assert not task.done() and not fut.done() and pending(buf) == 2
        loop = asyncio.get_running_loop()
        await loop.run_in_executor(None, buf.set_transform, ts("odom", "base", 2.0, Time(10)), "test")
        t = await asyncio.wait_for(task, 10)
        assert t.transform.translation.x == 3.0 and t.header.frame_id == "map"
        assert fut.result(10) is True
        assert pending(buf) == 0
        # already available: resolves at once, no wait registered
        assert await buf.wait_for_transform_async("map", "base", Time(10)) is True
        full = await buf.lookup_transform_full_async("base", Time(10), "odom", Time(10), "map", timeout=5)
        assert full.transform.translation.x == -2.0

    asyncio.run(main())


def test_async_timeouts_give_false_or_tf2s_error() -> None:
    buf = Buffer()
    buf.set_transform(ts("a", "b", 1.0, Time(5)), "test")

    async def main() -> None:
        t0 = time.monotonic()
        assert await buf.wait_for_transform_async("a", "nowhere", Time(), timeout=0.2) is False
        assert 0.15 < time.monotonic() - t0 < 5
        with pytest.raises(LookupException):
            await buf.lookup_transform_async("a", "nowhere", Time(), timeout=0.1)
        with pytest.raises(ExtrapolationException):
            await buf.lookup_transform_async("a", "b", Time(7), timeout=0.1)
        with pytest.raises(ExtrapolationException):
            await buf.lookup_transform_full_async("b", Time(7), "a", Time(5), "a", timeout=0.1)
        assert pending(buf) == 0

    asyncio.run(main())


def test_async_cancellation_drops_the_wait() -> None:
    buf = Buffer()

    async def main() -> None:
        task = asyncio.ensure_future(buf.lookup_transform_async("a", "b", Time()))
        await asyncio.sleep(0)
        assert pending(buf) == 1
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        assert pending(buf) == 0
        # asyncio.wait_for's own timeout cancels the inner wait too
        with pytest.raises(asyncio.TimeoutError):
            await asyncio.wait_for(buf.wait_for_transform_async("a", "b", Time()), 0.1)
        assert pending(buf) == 0
        buf.set_transform(ts("a", "b", 1.0), "test")  # nobody left to wake: no error

    asyncio.run(main())
    with pytest.raises(RuntimeError, match="running asyncio loop"):
        buf.wait_for_transform_async("a", "b", Time())


def test_futures_for_threads() -> None:
    buf = Buffer()
    fut = buf.lookup_transform_future("a", "b", Time())
    wait_full = buf.wait_for_transform_full_future("a", Time(), "b", Time(), "a")
    assert not fut.done() and pending(buf) == 2
    threading.Thread(target=buf.set_transform, args=(ts("a", "b", 4.0), "test")).start()
    assert fut.result(10).transform.translation.x == 4.0
    assert wait_full.result(10) is True
    assert buf.lookup_transform_full_future("a", Time(), "b", Time(), "a", timeout=1).result(10) is not None

    t0 = time.monotonic()
    assert buf.wait_for_transform_future("a", "c", Time(), timeout=0.2).result(10) is False
    assert 0.15 < time.monotonic() - t0 < 5
    with pytest.raises(LookupException):
        buf.lookup_transform_future("a", "c", Time(), timeout=0.1).result(10)

    slow = buf.lookup_transform_future("a", "c", Time())
    assert pending(buf) == 1
    assert slow.cancel() and slow.cancelled()
    assert pending(buf) == 0
    with pytest.raises(concurrent.futures.TimeoutError):  # the caller's own timeout leaves the wait pending
        buf.wait_for_transform_future("a", "c", Time()).result(0.05)
    buf.close()  # close releases every waiter with False
    assert pending(buf) == 0
    assert buf.wait_for_transform_future("a", "c", Time()).result(1) is False


def test_many_waiters_each_woken_by_their_own_frame() -> None:
    buf = Buffer()
    futs = {i: buf.wait_for_transform_future("root", f"f{i}", Time(), timeout=30) for i in range(50)}
    for i in range(0, 50, 2):
        buf.set_transform(ts("root", f"f{i}", float(i)), "test")
    for i, f in futs.items():
        if i % 2 == 0:
            assert f.result(10) is True
        else:
            assert not f.done()
    assert pending(buf) == 25
    buf.close()


BROADCASTER = textwrap.dedent("""
    import sys
    from zentf.transport.node import Node, init_logging
    from zentf.transport.broadcaster import TransformBroadcaster
    from zentf.core.messages import TransformStamped, Header, Transform, Vector3, Quaternion
    init_logging()
    node = Node(sys.argv[1])
    dyn = TransformBroadcaster(node)
    def tick():
        dyn.send_transform(TransformStamped(Header(node.get_clock().now(), "world"), "drone",
                                            Transform(Vector3(7.0, 0.0, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0))))
    node.create_timer(0.02, tick)
    print("ready", flush=True)
    node.spin()
""")


def test_async_waits_across_processes(spawn, node_options) -> None:
    """A listener awaits a transform that a broadcaster in another process starts sending later."""
    with Node("async_listener", options=node_options) as node:
        buf = Buffer(node=node)
        TransformListener(buf, node)

        async def main() -> None:
            task = asyncio.ensure_future(buf.lookup_transform_async("world", "drone", Time(), timeout=30))
            fut = buf.lookup_transform_future("world", "drone", Time(), timeout=30)
            await asyncio.sleep(0)
            assert not task.done()
            p = spawn.python("-c", BROADCASTER, "drone_bcast")
            t = await task
            assert t.transform.translation.x == 7.0, p.output()
            assert fut.result(30).transform.translation.x == 7.0  # the spawn fixture stops p

        asyncio.run(main())
        assert pending(buf) == 0


def test_waiters_are_woken_from_a_c_counter_without_a_callback_per_insert() -> None:
    """Every insert bumps BufferCore's C generation; Buffer's Python wake-up runs only while something
    waits (here a pending future; blocked threads: the blocking tests), and the want goes back to zero."""
    buf = Buffer()
    assert buf._insert_callbacks == [] and buf._wake_wanted == 0
    calls = []
    wake = buf._wake
    buf._wake = lambda: (calls.append(1), wake())  # the instance attribute is what the C side calls
    gen = buf._generation
    assert buf.set_transform(ts("a", "b", 1.0, Time(1)), "test")
    assert not buf.set_transform(ts("a", "b", float("nan"), Time(2)), "test")  # refused: no bump
    assert buf._generation == gen + 1 and calls == []  # nobody waits: no Python call

    fut = buf.wait_for_transform_future("a", "d", Time(), timeout=20)
    assert buf._wake_wanted == 1  # registered before it returned
    assert buf.set_transform(ts("b", "d", 1.0, Time(1)), "test")
    assert fut.result(10) is True and calls and buf._wake_wanted == 0
    fut = buf.wait_for_transform_future("a", "nowhere", Time(), timeout=20)
    fut.cancel()
    assert buf._wake_wanted == 0
