"""Rates, periods and frequencies a timer cannot serve are refused in one line naming them, at start and
when set at run time; a raising timer or callback is logged rate-limited and the node keeps serving."""
from __future__ import annotations

import time

import pytest
from cli_helpers import zentf

MODEL = "tests/data/urdf/turtlebot3_burger.urdf"


@pytest.mark.parametrize("args, needle", [
    (["nodes.turtlesim", "-p", "rate:=1e-300"], "turtlesim: error: parameter rate must be between"),
    (["nodes.frames_publisher", "-p", "rate:=1e-300"], "frames_publisher: error: parameter rate must be between"),
    (["nodes.frame_listener", "-p", "period:=1e300"], "frame_listener: error: parameter period must be between"),
    (["nodes.point_publisher", "-p", "period:=1e-300"], "point_publisher: error: parameter period must be between"),
    (["nodes.joint_state_publisher", "--rate", "1e-300", MODEL], "joint_state_publisher: error: --rate must be between"),
    (["nodes.joint_state_publisher", "-p", "rate:=1e-300", MODEL],
     "joint_state_publisher: error: parameter rate must be between"),
    (["nodes.joint_state_publisher", "--sweep", "--sweep-period", "1e-300", MODEL],
     "joint_state_publisher: error: --sweep-period must be between"),
    (["nodes.robot_state_publisher", "--publish-frequency", "1e-300", MODEL],
     "robot_state_publisher: error: --publish-frequency must be between"),
])
def test_a_rate_no_timer_can_serve_is_refused_at_start(spawn, args, needle):
    p = spawn.python("-m", *args)
    assert p.wait(30) in (1, 2), p.output()  # (before the fix: the node ran with a dead executor)
    out = [line for line in p.lines if line.strip()]
    assert len(out) == 1 and out[0].startswith(needle), out


def test_a_rate_set_at_run_time_is_refused_and_the_node_keeps_serving(spawn, zenoh_env, test_namespace):
    p = spawn.python("-m", "nodes.turtlesim")
    p.wait_for_line("spawned turtle1", 30)
    node = f"/{test_namespace}/turtlesim"
    r = zentf(["param", "set", node, "rate", "1.0e-300"], zenoh_env)
    assert r.returncode == 1 and "parameter rate must be between 1e-06 and 1e+06 Hz, got 1e-300" in r.stderr, r.stderr
    r = zentf(["param", "get", node, "rate"], zenoh_env)
    assert r.returncode == 0 and "62.5" in r.stdout, (r.stdout, r.stderr)
    r = zentf(["param", "set", node, "rate", "30.0"], zenoh_env)
    assert r.returncode == 0, r.stderr
    r = zentf(["service", "call", "spawn", "turtlesim/srv/Spawn", "{x: 2.0, y: 2.0, name: t9}"], zenoh_env)
    assert r.returncode == 0 and "t9" in r.stdout, (r.stdout, r.stderr)


def test_raising_callbacks_are_logged_rate_limited_and_the_node_keeps_serving(spawn, zenoh_env, test_namespace):
    p = spawn.python("tests/raising_node.py")
    p.wait_for_line("^ready$", 30)
    for _ in range(3):  # the subscription's callback raises on every message
        zentf(["topic", "pub", "--once", "chatter", "std_msgs/msg/String", "{data: hi}"], zenoh_env)
    time.sleep(1.0)  # the 1 kHz timer raises about a thousand times meanwhile (the test's subject)
    r = zentf(["param", "set", f"/{test_namespace}/raising_node", "speed", "2.5"], zenoh_env)
    assert r.returncode == 0, r.stderr  # the executor still serves the parameter services
    text = p.output()
    assert "tick divides by zero" in text and "no such key in the message" in text, text[-2000:]
    assert text.count("Traceback") <= 4, f"{text.count('Traceback')} tracebacks: {text[-2000:]}"
    assert len(p.lines) < 200, len(p.lines)
