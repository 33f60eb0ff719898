"""`zentf topic`, `zentf node` and `zentf graph` as subprocesses against real node processes."""
from __future__ import annotations

import json
import re
import shutil
import threading
import time

import pytest
from cli_helpers import ZENTF, zentf


def _static(spawn, *args: str):
    p = spawn.python("-m", "nodes.static_transform_publisher", *args)
    p.wait_for_line(r"Spinning until stopped", 30)
    return p


def _node_list(env) -> list[str]:
    proc = zentf(["node", "list"], env)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split()


def test_node_list_shows_exactly_the_live_nodes_and_drops_a_killed_one(spawn, zenoh_env, test_namespace):
    _static(spawn, "--name", "alpha", "0", "0", "0", "0", "0", "0", "a", "b")
    beta = _static(spawn, "--name", "beta", "0", "0", "0", "0", "0", "0", "b", "c")
    ns = f"/{test_namespace}"
    both = [f"{ns}/alpha", f"{ns}/beta"]
    deadline = time.monotonic() + 20
    while (names := _node_list(zenoh_env)) != both:  # one fresh CLI process per call
        assert set(names) <= set(both), names  # never anything else (CLI tools are hidden)
        assert time.monotonic() < deadline, names
    beta.kill()  # SIGKILL: no clean shutdown, the session just dies
    deadline = time.monotonic() + 20
    while (names := _node_list(zenoh_env)) != [f"{ns}/alpha"]:
        assert set(names) <= set(both), names
        assert time.monotonic() < deadline, names
    proc = zentf(["node", "list", "--count"], zenoh_env)
    assert proc.stdout.strip() == "1"


def test_node_info_lists_publications_and_subscriptions(spawn, zenoh_env, test_namespace):
    _static(spawn, "--name", "laser_tf", "0.4", "0", "0.2", "0", "0", "0", "base_link", "laser")
    spawn.python("-m", "nodes.frame_listener", "--name", "listener", "-p", "period:=0.2")
    ns = f"/{test_namespace}"
    proc = zentf(["node", "info", "laser_tf"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[:5] == [f"{ns}/laser_tf", "  Subscribers:", "  Publishers:",
                                            f"    {ns}/tf_static: tf2_msgs/msg/TFMessage", "  Service Servers:"]
    # the node's own token comes first and its listener's subscriptions right after: wait until both show
    want = (f"    {ns}/tf: tf2_msgs/msg/TFMessage", f"    {ns}/tf_static: tf2_msgs/msg/TFMessage")
    deadline = time.monotonic() + 20
    while True:
        proc = zentf(["node", "info", f"{ns}/listener"], zenoh_env)
        subs = proc.stdout.split("  Publishers:")[0]
        if proc.returncode == 0 and all(w in subs for w in want):
            break
        assert time.monotonic() < deadline, (proc.stdout, proc.stderr)
    assert all(w in subs for w in want)


def test_graph_has_the_node_topic_edges(spawn, zenoh_env, test_namespace, tmp_path):
    frames = spawn.python("-m", "nodes.frames_publisher", "--name", "drones")
    frames.wait_for_line(r"publishing av1 and av2 in world", 30)
    listener = spawn.python("-m", "nodes.frame_listener", "--name", "watcher", "-p", "source_frame:=av2",
                            "-p", "target_frame:=av1", "-p", "period:=0.2")
    listener.wait_for_line(r"av2 in av1", 30)
    ns = f"/{test_namespace}"
    proc = zentf(["graph", "-o", str(tmp_path / "graph.svg")], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    assert f"{ns}/drones\n  -> {ns}/tf [tf2_msgs/msg/TFMessage]" in proc.stdout, proc.stdout
    assert f"{ns}/watcher\n  <- {ns}/tf [tf2_msgs/msg/TFMessage]\n  <- {ns}/tf_static" in proc.stdout, proc.stdout
    dot = (tmp_path / "graph.gv").read_text()
    edges = set(re.findall(r'^\s*"([^"]+)" -> "([^"]+)";', dot, re.M))
    assert (f"n:{ns}/drones", f"t:{ns}/tf") in edges
    assert (f"t:{ns}/tf", f"n:{ns}/watcher") in edges
    assert (f"t:{ns}/tf_static", f"n:{ns}/watcher") in edges
    assert not any("_zentf_" in a or "_zentf_" in b for a, b in edges)  # CLI tools are hidden
    if shutil.which("dot"):
        assert "<svg" in (tmp_path / "graph.svg").read_text()


def test_topic_list_and_echo_decode_points(spawn, zenoh_env, test_namespace):
    points = spawn.python("-m", "nodes.point_publisher")
    points.wait_for_line(r"obstacle in laser", 30)
    ns = f"/{test_namespace}"
    proc = zentf(["topic", "list", "-t"], zenoh_env)
    assert f"{ns}/laser_point [geometry_msgs/msg/PointStamped]" in proc.stdout.splitlines(), proc.stdout
    proc = zentf(["topic", "echo", "laser_point", "--once", "--timeout", "20"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"^header:\n  stamp:\n    sec: \d+\n    nanosec: \d+\n  frame_id: laser\npoint:\n"
                     r"  x: \d+\.\d+\n  y: 0\.0\n  z: 0\.1\n---$", proc.stdout, re.M), proc.stdout
    proc = zentf(["topic", "echo", "laser_point", "--count", "2", "--json", "--timeout", "20"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    msgs = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(msgs) == 2 and all(m["header"]["frame_id"] == "laser" for m in msgs)
    assert msgs[1]["point"]["x"] > msgs[0]["point"]["x"] and msgs[0]["point"]["z"] == pytest.approx(0.1)


def test_topic_echo_shows_raw_bytes_of_an_unknown_payload(spawn, zenoh_session, test_namespace):
    env_echo = spawn([*ZENTF, "topic", "echo", "blob", "--once", "--json"])
    stop = threading.Event()

    def put_until_stopped() -> None:
        while not stop.is_set():
            zenoh_session.put(f"{test_namespace}/blob", b"\x00\xffhello")
            stop.wait(0.1)

    t = threading.Thread(target=put_until_stopped, daemon=True)
    t.start()
    try:
        m = env_echo.wait_for_line(r'^\{"encoding": "([^"]*)", "size": 7, "raw_hex": "00ff68656c6c6f"\}$', 30)
    finally:
        stop.set()
        t.join(5)
    assert "msgpack" not in m.group(1)
    assert env_echo.wait(10) == 0


def test_topic_pub_reaches_topic_echo(spawn, zenoh_env):
    echo = spawn([*ZENTF, "topic", "echo", "cmd_point", "--once", "--json"])
    proc = zentf(["topic", "pub", "cmd_point", "geometry_msgs/Point", '{"x": 1.5, "y": -2}', "--times", "30",
                  "--rate", "10", "--wait-matching", "10"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    m = echo.wait_for_line(r"^\{.*\}$", 10)
    assert json.loads(m.group(0)) == {"x": 1.5, "y": -2.0, "z": 0.0}


def test_topic_hz_measures_the_rate(spawn, zenoh_env):
    frames = spawn.python("-m", "nodes.frames_publisher")
    frames.wait_for_line(r"publishing av1 and av2 in world", 30)
    proc = zentf(["topic", "hz", "tf", "--duration", "2.5"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    rates = [float(x) for x in re.findall(r"^average rate: (\d+\.\d+)$", proc.stdout, re.M)]
    assert rates and 35.0 < rates[-1] < 65.0, proc.stdout
    assert re.search(r"^\tmin: \d+\.\d+s max: \d+\.\d+s std dev: \d+\.\d+s window: \d+$", proc.stdout, re.M)
