"""BufferServer / BufferClient between real processes: the Buffer API without a tf subscription,
event-driven server-side waits, tf2 errors with their class and text, and a server restart."""
from __future__ import annotations

import signal
import threading
import time

import pytest

from zentf.transport.buffer_server import BufferClient
from zentf.core.exceptions import ExtrapolationException, LookupException, TimeoutException, TransformException
from zentf.core.messages import Header, Point, PointStamped
from zentf.core.time import Time
from zentf.transport.graph import node_info
from zentf.transport.node import Node


@pytest.fixture
def client_node(node_options):
    n = Node("bc_user", options=node_options)
    yield n
    n.shutdown()


def _server(spawn):
    p = spawn.python("-m", "nodes.buffer_server")
    p.wait_for_line(r"serving /t_\w+/tf2_buffer_server", 30)
    return p


def test_lookups_transform_and_errors_through_the_server(spawn, client_node, zenoh_session, test_namespace):
    from zentf.demos.frames_publisher import av2_in_av1

    _server(spawn)
    spawn.python("-m", "nodes.static_transform_publisher", "0.4", "0", "0.2", "0", "0", "0", "base_link", "laser")
    spawn.python("-m", "nodes.frames_publisher")
    client = BufferClient(client_node)
    assert client.wait_for_server(20)
    laser = client.lookup_transform("base_link", "laser", Time(), timeout=20)
    tr = laser.transform.translation
    assert (laser.header.frame_id, laser.child_frame_id, tr.x, tr.y, tr.z) == ("base_link", "laser", 0.4, 0.0, 0.2)
    p = client.transform(PointStamped(Header(Time(), "laser"), Point(1.0, 2.0, 3.0)), "base_link", timeout=5)
    assert (p.header.frame_id, p.point.x, p.point.y, p.point.z) == pytest.approx(("base_link", 1.4, 2.0, 3.2))

    ts = client.lookup_transform("av1", "av2", Time(), timeout=20)  # latest common time of the drones
    stamp = ts.header.stamp.nanoseconds
    t = ts.transform.translation
    assert (t.x, t.y, t.z) == pytest.approx(av2_in_av1(stamp / 1e9), abs=1e-9)
    full = client.lookup_transform_full("av1", Time(nanoseconds=stamp), "av2", Time(nanoseconds=stamp), "world",
                                        timeout=5)
    f = full.transform.translation
    assert (f.x, f.y, f.z) == pytest.approx((t.x, t.y, t.z), abs=1e-9)
    assert client.can_transform("av1", "av2", Time(nanoseconds=stamp))

    with pytest.raises(LookupException, match='"nowhere" passed to lookupTransform argument source_frame does not exist'):
        client.lookup_transform("av1", "nowhere", Time())
    # a second sample of both drones first: with one, tf2 says "only time ... is in the buffer" instead
    client.lookup_transform("av1", "av2", Time(nanoseconds=stamp + 1), timeout=20)
    with pytest.raises(ExtrapolationException, match=r"extrapolation [0-9.]+s into the past"):
        client.lookup_transform("av1", "av2", Time(sec=1))
    ok, why = client.can_transform("av1", "nowhere", Time(), return_debug_tuple=True)
    assert not ok and "nowhere" in why

    info = node_info(zenoh_session, f"/{test_namespace}/bc_user")  # the client subscribes to no tf topic
    assert info is not None and info.subscriptions == []
    assert (f"/{test_namespace}/tf2_buffer_server", "tf2_msgs/action/LookupTransform") in info.clients


def test_a_waiting_lookup_is_answered_when_the_frame_arrives(spawn, client_node):
    _server(spawn)
    client = BufferClient(client_node)
    assert client.wait_for_server(20)
    result: dict = {}

    def ask() -> None:
        t0 = time.monotonic()
        try:
            result["ts"] = client.lookup_transform("map", "odom", Time(), timeout=30)
        except TransformException as e:
            result["error"] = e
        result["took"] = time.monotonic() - t0

    th = threading.Thread(target=ask)
    th.start()
    time.sleep(0.5)  # let the request reach the server and start waiting there (the test's subject)
    assert "ts" not in result and "error" not in result
    pub = spawn.python("-m", "nodes.static_transform_publisher", "1", "2", "3", "0", "0", "0", "map", "odom")
    pub.wait_for_line("Spinning until stopped", 30)
    th.join(40)
    assert "ts" in result, result
    assert result["ts"].transform.translation.x == 1.0
    assert result["took"] < 30
    t0 = time.monotonic()
    with pytest.raises(LookupException, match='"never" passed to lookupTransform argument source_frame'):
        client.lookup_transform("map", "never", Time(), timeout=0.5)  # waited on the server, then tf2's error
    assert 0.45 < time.monotonic() - t0 < 10


def test_a_client_whose_server_restarts_recovers(spawn, client_node):
    server = _server(spawn)
    spawn.python("-m", "nodes.static_transform_publisher", "1", "0", "0", "0", "0", "0", "map", "odom")
    client = BufferClient(client_node)
    assert client.wait_for_server(20)
    assert client.lookup_transform("map", "odom", Time(), timeout=20).transform.translation.x == 1.0
    server.signal(signal.SIGKILL)
    server.wait(10)
    t0 = time.monotonic()
    with pytest.raises(TimeoutException, match="buffer server"):
        while True:  # until the router has noticed the dead session (a lookup may still be in flight)
            client.lookup_transform("map", "odom", Time(), timeout=1.0)
            assert time.monotonic() - t0 < 30, "lookups kept succeeding after the server was killed"
    _server(spawn)
    assert client.lookup_transform("map", "odom", Time(), timeout=20).transform.translation.x == 1.0


def test_a_garbage_request_is_answered_with_invalid_argument(spawn, zenoh_session, test_namespace, client_node):
    import msgpack

    _server(spawn)
    client = BufferClient(client_node)
    assert client.wait_for_server(20)
    replies = list(zenoh_session.get(f"{test_namespace}/tf2_buffer_server", payload=b"\x93\x01\x02", timeout=10))
    assert len(replies) == 1
    err = msgpack.unpackb(replies[0].ok.payload.to_bytes())["error"]
    assert err["error"] == 4 and err["error_string"].startswith("bad LookupTransform request")
    with pytest.raises(LookupException):  # the server still answers
        client.lookup_transform("a", "b", Time())


def _pin_every_slot(session, key: str, selector_extra: str, gives_up: float) -> None:
    """64 waiting lookups (timeout 1e9 s, for a frame nobody publishes) from callers that give up after
    ``gives_up`` seconds: the attack that held every wait slot of the server."""
    import msgpack
    import zenoh

    goal = msgpack.packb({"target_frame": "map", "source_frame": "pinned", "timeout": {"sec": 10**9, "nanosec": 0}})
    done = threading.Semaphore(0)
    for _ in range(64):
        session.get(f"{key}{selector_extra}", zenoh.handlers.Callback(lambda reply: None, done.release),
                    payload=goal, timeout=gives_up)
    for _ in range(64):  # every caller has given up
        assert done.acquire(timeout=30)


def _slot_frees(client: BufferClient, within: float) -> bool:
    """True once a waiting lookup is taken on (not refused as busy) within ``within`` seconds."""
    t0 = time.monotonic()
    while True:
        try:
            client.lookup_transform("map", "later", Time(), timeout=0.3)
        except TimeoutException as e:
            if "busy" not in str(e):
                raise
            if time.monotonic() - t0 > within:
                return False
        except LookupException:
            return True  # it waited its 0.3 s on the server, then tf2's error: a slot was free


def test_waits_of_callers_that_gave_up_free_their_slots(spawn, client_node, zenoh_session, test_namespace):
    _server(spawn)
    client = BufferClient(client_node)
    assert client.wait_for_server(20)
    # callers that say when they give up (``deadline_ms``, as every zentf client does)
    _pin_every_slot(zenoh_session, f"{test_namespace}/tf2_buffer_server", "?deadline_ms=1000", 1.0)
    assert _slot_frees(client, 3.0), "the waits of callers that gave up still hold every slot"


def test_the_server_caps_every_wait(spawn, client_node, zenoh_session, test_namespace):
    p = spawn.python("-m", "nodes.buffer_server", "-p", "max_wait:=1.0")
    p.wait_for_line(r"serving /t_\w+/tf2_buffer_server", 30)
    client = BufferClient(client_node)
    assert client.wait_for_server(20)
    # callers that do not say when they give up: held at most max_wait
    _pin_every_slot(zenoh_session, f"{test_namespace}/tf2_buffer_server", "", 1.0)
    assert _slot_frees(client, 3.0), "waits of 1e9 s outlived the server's max_wait"
    bad = spawn.python("-m", "nodes.buffer_server", "--name", "b2", "-p", "max_wait:=1e300")
    assert bad.wait(30) == 1 and "max_wait" in bad.output() and len(bad.lines) == 1, bad.output()


def test_error_replies_are_cut_and_escaped(spawn, client_node, zenoh_session, test_namespace):
    import msgpack

    _server(spawn)
    client = BufferClient(client_node)
    assert client.wait_for_server(20)
    frame = "\x1b[2J\r\n[ERROR] forged" + "x" * 100_000
    replies = list(zenoh_session.get(f"{test_namespace}/tf2_buffer_server",
                                     payload=msgpack.packb({"target_frame": frame, "source_frame": "map"}),
                                     timeout=10))
    text = msgpack.unpackb(replies[0].ok.payload.to_bytes())["error"]["error_string"]
    assert len(text) <= 4000 and text.isprintable() and "\\x1b[2J\\r\\n[ERROR] forged" in text, text[:200]
    with pytest.raises(LookupException) as info:  # the client keeps it as it came, one short line
        client.lookup_transform(frame, "map", Time())
    assert len(str(info.value)) <= 4000 and str(info.value).isprintable()
