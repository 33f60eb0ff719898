"""ros2 topic habits against a live graph: `topic echo TOPIC [TYPE]` with --field/--csv/--no-arr, `topic bw`,
`topic delay` (wall clock and /clock), each under zentf's wire and --wire ros2; bad arguments are one line."""
from __future__ import annotations

import os
import re
import sys

import pytest

from cli_helpers import ZENTF, assert_one_line_error, zentf, zentf_together
from conftest import child_env

POINT = "{header: {stamp: {sec: 99, nanosec: 500000000}, frame_id: cam}, point: {x: 1.5, y: -2.0, z: 0.25}}"


@pytest.fixture(params=["zentf", "ros2"])
def graph_env(request, isolated_router, test_namespace) -> dict[str, str]:
    """A graph of this test's own (it publishes the absolute /clock): zentf's wire in a namespace, or ROS 2's."""
    if request.param == "ros2":
        return request.getfixturevalue("ros2_env")
    return child_env(isolated_router, test_namespace)


def _pub(spawn, env: dict[str, str], *args: str):
    p = spawn([*ZENTF, "topic", "pub", *args, "--rate", "20", "--wait-matching", "0"], env=env)
    p.wait_for_line(r"publishing #1", 60)
    return p


def test_topic_echo_type_field_csv_and_no_arr(spawn, graph_env):
    env = graph_env
    _pub(spawn, env, "stamped", "geometry_msgs/msg/PointStamped", POINT)
    spawn([*ZENTF, "static-transform-publisher", "--x", "1", "--frame-id", "base", "--child-frame-id", "cam"],
          env=env).wait_for_line(r"Spinning until stopped", 60)

    typed = zentf(["topic", "echo", "stamped", "geometry_msgs/msg/PointStamped", "--once", "--timeout", "30"], env)
    assert typed.returncode == 0, typed.stderr
    assert typed.stdout == ("header:\n  stamp:\n    sec: 99\n    nanosec: 500000000\n  frame_id: cam\n"
                            "point:\n  x: 1.5\n  y: -2.0\n  z: 0.25\n---\n"), typed.stdout
    wrong = zentf(["topic", "echo", "stamped", "geometry_msgs/Point", "--once", "--timeout", "30"], env)
    assert_one_line_error(wrong, "has type geometry_msgs/msg/PointStamped, not geometry_msgs/msg/Point", code=2)
    field = zentf(["topic", "echo", "stamped", "--field", "point.y", "--once", "--timeout", "30"], env)
    assert field.stdout == "-2.0\n---\n", (field.stdout, field.stderr)
    csv = zentf(["topic", "echo", "stamped", "--csv", "--once", "--timeout", "30"], env)
    assert csv.stdout == "99,500000000,cam,1.5,-2.0,0.25\n", (csv.stdout, csv.stderr)
    no_arr = zentf(["topic", "echo", "/tf_static" if env.get("ZENTF_WIRE") == "ros2" else "tf_static",
                    "tf2_msgs/msg/TFMessage", "--no-arr", "--once", "--timeout", "30"], env)
    assert no_arr.stdout == "transforms: '<sequence type: geometry_msgs/msg/TransformStamped, length: 1>'\n---\n", \
        (no_arr.stdout, no_arr.stderr)
    bad = zentf(["topic", "echo", "stamped", "geometry_msgs/msg/PointStamped", "--field", "point.w"], env)
    assert_one_line_error(bad, "invalid field 'point.w'", "no field 'w'", code=2)
    late = zentf(["topic", "echo", "stamped", "--field", "header.frame_id.x", "--once", "--timeout", "30"], env)
    assert_one_line_error(late, "invalid field 'header.frame_id.x'", code=2)


@pytest.mark.parametrize("args, needle", [
    (["echo", "x", "--csv", "--json"], "--csv and --json exclude each other"),
    (["echo", "x", "--field", ".."], "invalid field value '..'"),
    (["echo", "x", "no_pkg_type"], "unknown message type 'no_pkg_type'"),
    (["echo", "x", "--truncate-length", "-1"], "--truncate-length"),
    (["bw", "x", "--window", "0"], "--window"),
    (["bw", "bad topic!"], "invalid topic name"),
    (["delay", "x", "--duration", "nan"], "nan is not finite"),
    (["delay", "x", "--period", "0"], "--period"),
])
def test_topic_tools_bad_arguments_are_one_line(args, needle):
    """Refused before anything is opened (no ZENTF_* setting: nothing to reach)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    assert_one_line_error(zentf(["topic", *args], env), needle, code=2)


def _size(env: dict[str, str]) -> int:
    """Bytes of POINT on the wire: msgpack for zentf, CDR for ROS 2."""
    from zentf.cli.topic import parse_message

    msg = parse_message("geometry_msgs/msg/PointStamped", POINT)
    if env.get("ZENTF_WIRE") == "ros2":
        from zentf.ros import encode

        return len(encode(msg))
    from zentf.transport.wire.codec import encode

    return len(encode(msg))


def test_topic_bw_reports_bytes_per_second_and_sizes(spawn, graph_env):
    _pub(spawn, graph_env, "stamped", "geometry_msgs/msg/PointStamped", POINT)
    proc = zentf(["topic", "bw", "stamped", "--duration", "2.5"], graph_env)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert re.fullmatch(r"Subscribed to \[/.*stamped\]", lines[0]), lines
    size = _size(graph_env)
    rate, unit, n = re.fullmatch(r"(\d+(?:\.\d\d)?) (B|KB)/s from (\d+) messages", lines[-2]).groups()
    div = 1000 if unit == "KB" else 1  # ROS 2's units: B below 1000 B/s, then KB with two decimals
    shown = f"{size / div:.2f} KB" if div > 1 else f"{size} B"
    assert lines[-1] == f"\tMessage size mean: {shown} min: {shown} max: {shown}", lines
    assert int(n) >= 2 and 0.2 * size * 20 < float(rate) * div < 3 * size * 20, lines  # ~20 Hz, loaded machine
    quiet = zentf(["topic", "bw", "silence", "--duration", "0.5"], graph_env)
    assert_one_line_error(quiet, "nothing published on", code=1)


def test_topic_delay_in_sim_time_and_on_the_wall_clock(spawn, graph_env):
    env = graph_env
    _pub(spawn, env, "stamped", "geometry_msgs/msg/PointStamped", POINT)
    # stamps 99.5 s on the wall clock: decades late
    wall = zentf(["topic", "delay", "stamped", "--duration", "2"], env)
    assert wall.returncode == 0, wall.stderr
    assert float(re.search(r"^average delay: (\d+\.\d+)$", wall.stdout, re.M).group(1)) > 1e9, wall.stdout
    # /clock at 100 s: the delay is 0.5 s of sim time, as soon as /clock is published (or from the start)
    _pub(spawn, env, "/clock", "rosgraph_msgs/msg/Clock", "{clock: {sec: 100}}")
    runs = zentf_together([["topic", "delay", "stamped", "--duration", "2.5", *flags]
                           for flags in ([], ["--use-sim-time"])], env)  # both at once: their windows overlap
    for proc in runs:
        assert proc.returncode == 0, proc.stderr
        last = proc.stdout.strip().splitlines()[-2:]
        assert last[0] == "average delay: 0.500", proc.stdout
        assert re.fullmatch(r"\tmin: 0\.500s max: 0\.500s std dev: 0\.00000s window: \d+", last[1]), proc.stdout
    headerless = zentf(["topic", "delay", "/clock", "--duration", "5"], env)
    assert_one_line_error(headerless, "/clock carries rosgraph_msgs/msg/Clock, which has no header", code=2)


def test_topic_delay_of_a_live_publisher_is_small(spawn, zenoh_env):
    """The laser demo's point publisher stamps with its clock's now: the delay is transit, far under a second."""
    spawn([sys.executable, "-m", "nodes.point_publisher"]).wait_for_line(r"obstacle in laser", 60)
    proc = zentf(["topic", "delay", "laser_point", "--duration", "2.5"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    assert 0.0 <= float(re.search(r"^average delay: (-?\d+\.\d+)$", proc.stdout, re.M).group(1)) < 0.5, proc.stdout
