"""Parameters over the network between real processes: `zentf param list/get/set/dump`, declared types,
on-set callbacks that reject, and `use_sim_time` switched at run time."""
from __future__ import annotations

import threading
import time

import msgpack
import pytest
import yaml
from cli_helpers import assert_one_line_error, zentf

from zentf.core.messages import Clock
from zentf.core.parameters import SetParametersResult
from zentf.core.time import Time
from zentf.transport.node import Node
from zentf.transport.parameters import InvalidParameterTypeException, InvalidParameterValueException


@pytest.fixture
def sim(spawn):
    p = spawn.python("-m", "nodes.turtlesim", "-p", "rate:=50")
    p.wait_for_line(r"spawned turtle1 at", 30)
    return p


def _ok(proc) -> str:
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    return proc.stdout


def test_param_list_get_set_dump_on_turtlesim(sim, zenoh_env, test_namespace):
    assert _ok(zentf(["param", "list", "turtlesim"], zenoh_env)).splitlines() == [
        "  rate", "  spawn_first", "  use_sim_time"]
    assert _ok(zentf(["param", "get", "turtlesim", "rate"], zenoh_env)) == "Double value is: 50.0\n"
    assert _ok(zentf(["param", "get", f"/{test_namespace}/turtlesim", "spawn_first"], zenoh_env)) == \
        "Boolean value is: true\n"
    assert _ok(zentf(["param", "set", "turtlesim", "rate", "20"], zenoh_env)) == "Set parameter successful\n"
    assert _ok(zentf(["param", "get", "turtlesim", "rate", "--hide-type"], zenoh_env)) == "20.0\n"
    assert_one_line_error(zentf(["param", "set", "turtlesim", "rate", "fast"], zenoh_env), "Setting parameter failed",
                          "parameter {rate} is of type {double}, setting it to {string} is not allowed", code=1)
    assert_one_line_error(zentf(["param", "set", "turtlesim", "colour", "1"], zenoh_env),
                          "parameter 'colour' is not declared", code=1)
    assert_one_line_error(zentf(["param", "get", "turtlesim", "colour"], zenoh_env),
                          "parameter colour is not set", code=1)
    dumped = yaml.safe_load(_ok(zentf(["param", "dump", "turtlesim"], zenoh_env)))
    assert dumped == {f"/{test_namespace}/turtlesim": {"ros__parameters": {
        "rate": 20.0, "spawn_first": True, "use_sim_time": False}}}
    # not in the graph: one line at once naming who is (the 30 s timeout is never waited out)
    assert_one_line_error(zentf(["param", "get", "nobody", "rate", "--timeout", "30"], zenoh_env, timeout=20),
                          f"node /{test_namespace}/nobody is not running (running: /{test_namespace}/turtlesim", code=1)


def test_param_list_without_node_lists_every_node(sim, spawn, zenoh_env, test_namespace):
    spawn.python("tests/param_node.py").wait_for_line("^ready$", 30)
    out = _ok(zentf(["param", "list"], zenoh_env))
    ns = f"/{test_namespace}"
    assert f"{ns}/param_node:\n  gains\n  mode\n  speed\n  use_sim_time\n" in out
    assert f"{ns}/turtlesim:\n  rate\n  spawn_first\n  use_sim_time\n" in out


def test_callbacks_may_reject_and_accepted_sets_reach_the_node(spawn, zenoh_env):
    p = spawn.python("tests/param_node.py")
    p.wait_for_line("^ready$", 30)
    assert_one_line_error(zentf(["param", "set", "param_node", "speed", "-1.5"], zenoh_env),
                          "Setting parameter failed: speed must be >= 0", code=1)
    _ok(zentf(["param", "set", "param_node", "speed", "2.5"], zenoh_env))
    p.wait_for_line(r"^speed is now 2\.5$", 10)
    _ok(zentf(["param", "set", "param_node", "gains", "[3, 4.5]"], zenoh_env))  # ints widen in a double array
    assert _ok(zentf(["param", "get", "param_node", "gains"], zenoh_env)) == "Array value is: [3.0, 4.5]\n"
    assert_one_line_error(zentf(["param", "set", "param_node", "gains", "[a, 1]"], zenoh_env),
                          "bad value", code=2)
    assert_one_line_error(zentf(["param", "set", "param_node", "mode", "true"], zenoh_env),
                          "{mode} is of type {string}, setting it to {bool}", code=1)
    assert "speed is now -1.5" not in p.output()


def test_declared_types_locally(node_options):
    opts = node_options.with_(params={"rate": 20, "label": 7})
    with Node("typed", options=opts) as node:
        assert node.declare_parameter("rate", 62.5).value == 20.0  # an int override widens to the double type
        assert isinstance(node.get_parameter("rate").value, float)
        assert node.declare_parameter("label", "x").value == 7  # kept as given; sets are checked from now on
        node.set_parameter("rate", 5)
        assert node.get_parameter("rate").value == 5.0
        with pytest.raises(InvalidParameterTypeException, match=r"parameter \{rate\} is of type \{double\}"):
            node.set_parameter("rate", "x")
        node.add_on_set_parameters_callback(lambda ps: SetParametersResult(False, "frozen"))
        with pytest.raises(InvalidParameterValueException, match="frozen"):
            node.set_parameter("rate", 1.0)
        assert node.get_parameter("rate").value == 5.0


def test_use_sim_time_set_at_run_time_switches_the_node_clock(isolated_router, spawn, zenoh_env, node_options,
                                                              test_namespace):
    """frames_publisher stamps tf with its clock: wall time, then /clock once use_sim_time is set, then wall."""
    from zentf.transport.options import ZenohOptions

    env = {**zenoh_env, "ZENTF_CONNECT": isolated_router}  # /clock is absolute: keep it to this test
    spawn.python("-m", "nodes.frames_publisher", "-p", "rate:=20", env=env).wait_for_line("publishing", 30)
    opts = node_options.with_(zenoh=ZenohOptions(connect=[isolated_router], no_multicast=True, mode="client"))
    stamps: list[int] = []
    cond = threading.Condition()

    def on_tf(sample) -> None:
        st = msgpack.unpackb(sample.payload.to_bytes())["transforms"][0]["header"]["stamp"]
        with cond:
            stamps.append(st["sec"] * 10**9 + st["nanosec"])
            cond.notify_all()

    def wait_stamp(pred, timeout: float = 20.0) -> int:
        with cond:
            start = len(stamps)
            assert cond.wait_for(lambda: any(pred(s) for s in stamps[start:]), timeout), stamps[-5:]
            return next(s for s in stamps[start:] if pred(s))

    with Node("clock_probe", options=opts) as probe:
        sub = probe.session.declare_subscriber(f"{test_namespace}/tf", on_tf)
        wall = time.time_ns()
        wait_stamp(lambda s: abs(s - wall) < 60 * 10**9)
        assert _ok(zentf(["param", "set", "frames_publisher", "use_sim_time", "true"], env)) == \
            "Set parameter successful\n"
        clock = probe.create_publisher("/clock", Clock)
        sim_ns = 1000 * 10**9
        stop = threading.Event()

        def tick() -> None:
            ns = sim_ns
            while not stop.is_set():
                ns += 50_000_000
                clock.publish(Clock(clock=Time(nanoseconds=ns)))
                stop.wait(0.02)

        t = threading.Thread(target=tick, daemon=True)
        t.start()
        try:
            wait_stamp(lambda s: sim_ns < s < sim_ns + 10**12)
            assert _ok(zentf(["param", "get", "frames_publisher", "use_sim_time"], env)) == "Boolean value is: true\n"
            _ok(zentf(["param", "set", "frames_publisher", "use_sim_time", "false"], env))
            wall = time.time_ns()
            wait_stamp(lambda s: abs(s - wall) < 60 * 10**9)
        finally:
            stop.set()
            t.join(5)
            sub.undeclare()
