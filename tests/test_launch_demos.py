"""The demo launch files, started by `zentf launch`, checked from an independent listener on the router."""
from __future__ import annotations

import math
import sys
import textwrap
import threading
from pathlib import Path
from typing import Iterator

import pytest

from conftest import REPO, Proc
from zentf.transport.buffer import Buffer
from zentf.transport.graph import GraphWatcher
from zentf.transport.listener import TransformListener
from zentf.transport.node import Node
from zentf.transport.options import NodeOptions
from zentf.core.time import Time

NUM = r"(-?\d+\.\d+)"
TRIPLE = rf"\({NUM}, {NUM}, {NUM}\)"


def tag(name: str) -> str:
    """The launcher's output prefix of a node (its full name includes the test namespace)."""
    return rf"\[(?:[\w/]+/)?{name}\]"


@pytest.fixture
def launch(zenoh_env: dict[str, str], tmp_path: Path) -> Iterator:
    """launch(file, *args) -> Proc of `python -m zentf.launch` in this test's namespace, stopped at teardown."""
    procs: list[Proc] = []

    def _launch(file: str, *args: str) -> Proc:
        p = Proc([sys.executable, "-m", "zentf.launch", file, "--no-color", *args], env=zenoh_env, cwd=REPO)
        procs.append(p)
        return p

    try:
        yield _launch
    finally:
        for p in procs:
            p.stop(timeout=5)
            assert "Traceback" not in p.output(), p.output()


def listen(node_options: NodeOptions, namespace: str | None = None) -> tuple[Node, Buffer]:
    opts = node_options if namespace is None else node_options.with_(namespace=namespace)
    node = Node("test_listener", options=opts, check_unique=False)
    buf = Buffer(node=node)
    TransformListener(buf, node)
    return node, buf


def wait_nodes(session, namespace: str, names: set[str], timeout: float = 30.0) -> None:
    with GraphWatcher(session, namespace=namespace) as g:
        ok = g.wait_for(lambda entries: names <= {e.name for e in entries if e.kind == "node"}, timeout)
        assert ok, f"nodes alive in {namespace}: {sorted(e.name for e in g._entries if e.kind == 'node')}"


def xyz(ts) -> tuple[float, float, float]:
    t = ts.transform.translation
    return (t.x, t.y, t.z)


def test_drones_fly_and_plots_follow(launch, node_options, zenoh_session, test_namespace):
    p = launch("drones")
    node, buf = listen(node_options)
    try:
        wait_nodes(zenoh_session, test_namespace, {"frames_publisher", "plots_publisher"})
        a = buf.lookup_transform("world", "av1", Time(), timeout=30)
        assert math.hypot(*xyz(a)[:2]) == pytest.approx(1.0, abs=1e-6)  # av1 on the unit circle
        assert buf.wait_for(lambda: buf.lookup_transform("world", "av1", Time()).header.stamp
                            != a.header.stamp, 5)
        p.wait_for_line(rf"{tag('plots_publisher')} av2 in av1: {TRIPLE}", 30)
    finally:
        node.shutdown()


def test_static_true_makes_frames_publisher_publish_fixed_poses(launch, node_options, test_namespace):
    p = launch("drones", "static:=true", "plots:=false")
    p.wait_for_line(rf"{tag('frames_publisher')} published static poses", 30)
    node, buf = listen(node_options)
    try:
        av2_in_av1 = buf.lookup_transform("av1", "av2", Time(), timeout=30)
        assert xyz(av2_in_av1) == pytest.approx((-1.0, 0.0, 1.0), abs=1e-9)
        # only static transforms answer at any time (dynamic ones would raise ExtrapolationException)
        old = buf.lookup_transform("world", "av1", Time(12345))
        assert xyz(old) == pytest.approx((1.0, 0.0, 0.0), abs=1e-9)
        assert "plots_publisher" not in p.output()
    finally:
        node.shutdown()


def test_laser_demo_listeners_print_through_the_launcher(launch, node_options):
    p = launch("laser")
    node, buf = listen(node_options)
    try:
        cam = buf.lookup_transform("camera", "laser", Time(), timeout=30)
        assert xyz(cam) == pytest.approx((0.9, 0.0, -0.2), abs=1e-9)
        m = p.wait_for_line(rf"{tag('frame_listener')} laser in camera: translation {TRIPLE}", 30)
        assert tuple(map(float, m.groups())) == pytest.approx((0.9, 0.0, -0.2))
        m = p.wait_for_line(rf"{tag('point_listener')} obstacle in base_link: {TRIPLE}", 30, from_start=True)
        assert tuple(map(float, m.groups()))[1:] == pytest.approx((0.0, 0.3))
    finally:
        node.shutdown()


def test_turtles_follower_spawns_and_chases(launch, node_options, zenoh_session, test_namespace):
    p = launch("turtles")
    node, buf = listen(node_options)
    try:
        wait_nodes(zenoh_session, test_namespace, {"turtlesim", "turtle1_tf_broadcaster", "turtle2_tf_broadcaster",
                                                   "follower", "teleop"})
        p.wait_for_line(rf"{tag('turtlesim')} spawned turtle2 at", 30, from_start=True)
        t = buf.lookup_transform("turtle2", "turtle1", Time(), timeout=30)
        assert math.hypot(*xyz(t)) > 0.0
        p.wait_for_line(rf"{tag('follower')} distance to turtle1: \d+\.\d+", 30, from_start=True)
    finally:
        node.shutdown()


def test_multi_robot_namespaces_isolate_trees_sharing_world(launch, node_options, zenoh_session, test_namespace):
    launch("multi_robot")
    n1, b1 = listen(node_options, f"{test_namespace}/robot1")
    n2, b2 = listen(node_options, f"{test_namespace}/robot2")
    try:
        laser1 = b1.lookup_transform("world", "robot1/laser", Time(), timeout=30)
        assert xyz(laser1) == pytest.approx((0.4, 1.0, 0.2), abs=1e-6)
        cam2 = b2.lookup_transform("world", "robot2/camera", Time(), timeout=30)
        assert xyz(cam2) == pytest.approx((2.0, -1.0 - 0.5, 0.4), abs=1e-6)  # yaw 90 deg: x -> y
        assert "robot2/" not in b1.all_frames_as_yaml() and "robot1/" not in b2.all_frames_as_yaml()
        wait_nodes(zenoh_session, f"{test_namespace}/robot2", {"base_static", "point_listener"})
    finally:
        n1.shutdown()
        n2.shutdown()


def test_remappings_and_namespaces_land_where_they_should(launch, tmp_path, zenoh_session, test_namespace):
    f = tmp_path / "remap.yaml"
    f.write_text(textwrap.dedent("""
        groups:
          - namespace: team
            nodes:
              - module: nodes.point_publisher
                name: pp
                namespace: unit
                remappings: {laser_point: moved_point}
                parameters: {period: 0.05}
        """))
    got: dict[str, threading.Event] = {k: threading.Event() for k in ("moved", "original")}
    base = f"{test_namespace}/team/unit"
    subs = [zenoh_session.declare_subscriber(f"{base}/moved_point", lambda s: got["moved"].set()),
            zenoh_session.declare_subscriber(f"{base}/laser_point", lambda s: got["original"].set())]
    try:
        launch(str(f))
        wait_nodes(zenoh_session, f"{test_namespace}/team/unit", {"pp"})
        assert got["moved"].wait(30)
        assert not got["original"].is_set()
    finally:
        for s in subs:
            s.undeclare()


def test_a_killed_zentf_node_with_respawn_comes_back_on_the_graph(launch, tmp_path, zenoh_session, test_namespace):
    import os
    import signal

    f = tmp_path / "respawn.yaml"
    f.write_text(textwrap.dedent("""
        nodes:
          - module: nodes.frames_publisher
            respawn: true
            respawn_delay: 0.2
        """))
    events: list[tuple[str, bool]] = []
    cond = threading.Condition()

    def on_change(entry, alive: bool) -> None:
        if entry.kind == "node" and entry.name == "frames_publisher":
            with cond:
                events.append((entry.name, alive))
                cond.notify_all()

    with GraphWatcher(zenoh_session, on_change, namespace=test_namespace):
        p = launch(str(f))
        pid = int(p.wait_for_line(r"frames_publisher started \(pid (\d+)\)", 30).group(1))
        with cond:
            assert cond.wait_for(lambda: ("frames_publisher", True) in events, 30)
        os.kill(pid, signal.SIGKILL)
        p.wait_for_line(r"frames_publisher was killed by SIGKILL; respawning in 0.2 s", 10)
        new_pid = int(p.wait_for_line(r"frames_publisher respawned \(pid (\d+)\)", 10).group(1))
        assert new_pid != pid
        with cond:  # gone from the graph, then alive again
            assert cond.wait_for(lambda: events[-2:] == [("frames_publisher", False), ("frames_publisher", True)]
                                 or events.count(("frames_publisher", True)) >= 2, 30), events
        p.wait_for_line(r"publishing av1 and av2 in world", 30, from_start=False)
