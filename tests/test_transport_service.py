"""Services over Zenoh queryables between real processes: calls, handler errors, timeouts, a server
that dies mid-call, the graph tokens, `zentf service`, and turtlesim's spawn/kill/teleport_absolute."""
from __future__ import annotations

import asyncio
import math
import signal
import threading
import time

import pytest
from cli_helpers import assert_one_line_error, zentf

from zentf.core.messages import TurtlePose
from zentf.core.services import Kill, SetBool, Spawn, TeleportAbsolute, Trigger
from zentf.transport.graph import list_services
from zentf.transport.node import Node
from zentf.transport.service import ServiceException, ServiceTimeoutError, ServiceUnavailableError


@pytest.fixture
def server(spawn):
    p = spawn.python("tests/service_server.py")
    p.wait_for_line(r"^serving$", 30)
    return p


@pytest.fixture
def node(node_options):
    n = Node("caller", options=node_options)
    yield n
    n.shutdown()


def test_calls_reach_the_other_process_sync_future_and_asyncio(server, node):
    client = node.create_client("echo", SetBool)
    assert client.wait_for_service(20)
    assert client.call(SetBool.Request(data=True), timeout=10) == SetBool.Response(True, "data was True")
    fut = client.call_async({"data": False}, timeout=10)
    assert fut.result(15) == SetBool.Response(False, "data was False")
    assert asyncio.run(client.acall(SetBool.Request(data=True), timeout=10)).success is True


def test_handler_errors_and_type_mismatch_reach_the_caller_with_the_reason(server, node):
    fail = node.create_client("fail", Trigger)
    assert fail.wait_for_service(20)
    with pytest.raises(ServiceException, match="the disk is full"):
        fail.call(timeout=10)
    wrong = node.create_client("echo", Trigger)  # the server is a SetBool
    assert wrong.wait_for_service(20)
    with pytest.raises(ServiceException, match="std_srvs/srv/SetBool: refused a std_srvs/srv/Trigger_Request"):
        wrong.call(timeout=10)
    with pytest.raises(TypeError, match="takes SetBoolRequest"):
        node.create_client("echo", SetBool).call(Trigger.Request(), timeout=10)


def test_no_server_wait_returns_false_and_a_call_fails_fast(node):
    client = node.create_client("nobody_here", Trigger)
    t0 = time.monotonic()
    assert client.wait_for_service(0.5) is False
    assert 0.4 < time.monotonic() - t0 < 5
    t0 = time.monotonic()
    with pytest.raises(ServiceUnavailableError, match="no response"):
        client.call(timeout=10)
    assert time.monotonic() - t0 < 5


def test_wait_for_service_wakes_when_the_server_starts(spawn, node):
    client = node.create_client("echo", SetBool)
    woke = threading.Event()
    threading.Thread(target=lambda: client.wait_for_service(60) and woke.set(), daemon=True).start()
    assert not woke.wait(0.3)
    spawn.python("tests/service_server.py")
    assert woke.wait(30)
    assert client.call({"data": True}, timeout=10).success


def test_a_slow_handler_times_out_with_the_timeout_named(server, node):
    client = node.create_client("stall", Trigger)
    assert client.wait_for_service(20)
    t0 = time.monotonic()
    with pytest.raises(ServiceTimeoutError, match="no response within 1 s"):
        client.call(timeout=1.0)
    assert 0.9 < time.monotonic() - t0 < 4


def test_a_server_killed_mid_call_fails_the_call_within_its_timeout(server, node):
    client = node.create_client("stall", Trigger)
    assert client.wait_for_service(20)
    t0 = time.monotonic()
    fut = client.call_async(timeout=30)
    server.wait_for_line(r"^handling stall$", 20)
    killed = time.monotonic()
    server.signal(signal.SIGKILL)
    exc = fut.exception(40)
    assert isinstance(exc, ServiceUnavailableError), exc  # the router ends the query: no waiting for the timeout
    assert "went away during the call" in str(exc)
    assert time.monotonic() - t0 < 30 and time.monotonic() - killed < 10


def test_graph_lists_servers_and_clients(server, node, zenoh_session, test_namespace):
    client = node.create_client("echo", SetBool)
    assert client.wait_for_service(20)
    ns = f"/{test_namespace}"
    services = list_services(zenoh_session, test_namespace)
    assert services[f"{ns}/echo"] == [("std_srvs/srv/SetBool", f"{ns}/service_server")]
    assert services[f"{ns}/stall"] == [("std_srvs/srv/Trigger", f"{ns}/service_server")]


def test_zentf_service_list_type_call(server, zenoh_env, test_namespace):
    ns = f"/{test_namespace}"
    proc = zentf(["service", "list", "-t"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    for line in (f"{ns}/echo [std_srvs/srv/SetBool]", f"{ns}/fail [std_srvs/srv/Trigger]"):
        assert line in lines, proc.stdout
    proc = zentf(["service", "type", "echo"], zenoh_env)
    assert (proc.returncode, proc.stdout) == (0, "std_srvs/srv/SetBool\n"), proc.stderr
    proc = zentf(["service", "call", "echo", "std_srvs/srv/SetBool", "{data: true}"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("response:\n")[1] == "success: true\nmessage: data was True\n"
    assert_one_line_error(zentf(["service", "call", "fail", "std_srvs/srv/Trigger"], zenoh_env),
                          "service", "the disk is full", code=1)
    assert_one_line_error(zentf(["service", "call", "echo", "std_srvs/srv/SetBool", "{data: [1"], zenoh_env),
                          "DATA is not valid YAML/JSON", code=2)
    assert_one_line_error(zentf(["service", "call", "echo", "std_srvs/srv/SetBool", "{dat: 1}"], zenoh_env),
                          "unknown field 'dat'", code=2)
    assert_one_line_error(zentf(["service", "call", "echo", "nope/srv/X", "{}"], zenoh_env),
                          "unknown service type 'nope/srv/X'", code=2)
    # nobody offers it: one line at once naming what is offered (the 30 s timeout is never waited out)
    assert_one_line_error(zentf(["service", "call", "absent", "std_srvs/srv/Empty", "--timeout", "30"], zenoh_env,
                                timeout=20),
                          f"service {ns}/absent is not offered by any node (offered: {ns}/echo, {ns}/fail, {ns}/frames, {ns}/stall",
                          code=1)
    # a server that is there but does not answer: the timeout applies
    started = time.monotonic()
    assert_one_line_error(zentf(["service", "call", "stall", "std_srvs/srv/Trigger", "--timeout", "1"], zenoh_env),
                          f"service {ns}/stall: no response within 1 s", code=1)
    assert time.monotonic() - started >= 1.0
    assert_one_line_error(zentf(["service", "type", "absent", "--wait", "0.5"], zenoh_env),
                          f"unknown service {ns}/absent", code=1)


def test_turtlesim_spawn_kill_and_teleport_are_services(spawn, node, zenoh_env):
    sim = spawn.python("-m", "nodes.turtlesim")
    sim.wait_for_line(r"spawned turtle1 at", 30)
    spawn_client = node.create_client("spawn", Spawn)
    assert spawn_client.wait_for_service(20)
    assert spawn_client.call(Spawn.Request(x=1.0, y=2.0, theta=0.5, name="t2"), timeout=10).name == "t2"
    sim.wait_for_line(r"spawned t2 at \(1\.000, 2\.000, 0\.500\)", 10)
    assert spawn_client.call(Spawn.Request(x=3.0, y=3.0), timeout=10).name == "turtle2"  # picked a name
    with pytest.raises(ServiceException, match="a turtle named 't2' already exists"):
        spawn_client.call(Spawn.Request(name="t2"), timeout=10)
    with pytest.raises(ServiceException, match="spawn x must be finite"):
        spawn_client.call(Spawn.Request(x=math.nan, name="t3"), timeout=10)

    poses: list[TurtlePose] = []
    seen = threading.Condition()

    def on_pose(p: TurtlePose) -> None:
        with seen:
            poses.append(p)
            seen.notify_all()

    node.create_subscription("t2/pose", TurtlePose, on_pose)
    teleport = node.create_client("t2/teleport_absolute", TeleportAbsolute)
    assert teleport.wait_for_service(20)
    teleport.call(TeleportAbsolute.Request(x=7.0, y=8.0, theta=1.0), timeout=10)
    with seen:
        assert seen.wait_for(lambda: poses and (poses[-1].x, poses[-1].y) == pytest.approx((7.0, 8.0)), 20)
        assert poses[-1].theta == pytest.approx(1.0)

    proc = zentf(["service", "call", "kill", "turtlesim/srv/Kill", "{name: t2}"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    sim.wait_for_line(r"^killed t2$", 10)
    assert _gone(teleport)
    with pytest.raises(ServiceException, match=r"Tried to kill turtle \[t2\], which does not exist"):
        node.create_client("kill", Kill).call(Kill.Request(name="t2"), timeout=10)
    proc = zentf(["service", "call", "spawn", "turtlesim/srv/Spawn", "{x: 4.0, y: 2.0, name: t9}"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.endswith("response:\nname: t9\n")


def _gone(client) -> bool:
    """The killed turtle's teleport service disappears from the network (event-driven wait)."""
    deadline = time.monotonic() + 20
    while client.service_is_ready():
        assert time.monotonic() < deadline, "teleport_absolute of a killed turtle is still served"
        time.sleep(0.05)
    return True


def test_garbage_requests_get_an_error_reply_and_the_server_carries_on(server, zenoh_session, test_namespace, node):
    replies = list(zenoh_session.get(f"{test_namespace}/echo", payload=b"\xc1 not msgpack", timeout=10))
    assert len(replies) == 1 and replies[0].ok is None
    assert "bad request for std_srvs/srv/SetBool" in replies[0].err.payload.to_bytes().decode()
    client = node.create_client("echo", SetBool)
    assert client.wait_for_service(20)
    assert client.call({"data": True}, timeout=10).success


def test_an_error_reply_quoting_a_huge_request_is_cut_and_escaped(server, zenoh_session, test_namespace, node):
    import msgpack

    huge = msgpack.packb({"data": "\x1b[2J\r\n[ERROR] forged \u202e" * 10_000})  # ~250 KB once quoted
    replies = list(zenoh_session.get(f"{test_namespace}/echo", payload=huge, timeout=10))
    text = replies[0].err.payload.to_bytes().decode()
    assert "bad request for std_srvs/srv/SetBool" in text and len(text) <= 4000 and text.isprintable(), len(text)
    # a caller keeps what any server sends it to one short printable line too
    from zentf.transport.service import ERROR_ENCODING

    forger = zenoh_session.declare_queryable(
        f"{test_namespace}/forged", lambda q: q.reply_err(("\x1b[2J" * 50_000).encode(), encoding=ERROR_ENCODING))
    try:
        client = node.create_client("forged", Trigger)
        assert client.wait_for_service(20)
        with pytest.raises(ServiceException) as info:
            client.call(timeout=10)
        assert len(str(info.value)) <= 16_000 and str(info.value).isprintable()
    finally:
        forger.undeclare()
