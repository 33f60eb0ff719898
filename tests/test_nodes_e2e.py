"""The demo node programs as real processes on loopback: static frames, laser/camera, drones, turtles."""
from __future__ import annotations

import math
import re

import pytest

NUM = r"(-?\d+\.\d+)"
TRIPLE = rf"\({NUM}, {NUM}, {NUM}\)"


def floats(m: re.Match) -> tuple[float, ...]:
    return tuple(float(g) for g in m.groups())


def stop_cleanly(*procs) -> None:
    """SIGTERM ends every node with status 0 and without a traceback."""
    for p in procs:
        assert p.stop(timeout=10) == 0, p.output()[-2000:]
        assert "Traceback" not in p.output(), p.output()[-2000:]


def test_static_publishers_reach_a_late_frame_listener(spawn):
    """Both argument forms; the listener starts after both sent their one latched message."""
    a = spawn.python("-m", "nodes.static_transform_publisher", "--x", "0.4", "--z", "0.2",
                     "--frame-id", "base_link", "--child-frame-id", "laser")
    b = spawn.python("-m", "nodes.static_transform_publisher", "-0.5", "0", "0.4", "0", "0", "0",
                     "base_link", "camera")
    a.wait_for_line(r"Spinning until stopped - publishing transform .* from 'base_link' to 'laser'", 20)
    b.wait_for_line(r"Spinning until stopped - publishing transform .* from 'base_link' to 'camera'", 20)
    listener = spawn.python("-m", "nodes.frame_listener", "-p", "period:=0.2")
    m = listener.wait_for_line(rf"laser in camera: translation {TRIPLE} rotation", 20)
    assert floats(m) == pytest.approx((0.9, 0.0, -0.2), abs=1e-3)
    stop_cleanly(listener, a, b)


def test_point_listener_prints_the_obstacle_in_base_link(spawn):
    static = spawn.python("-m", "nodes.static_transform_publisher", "0.4", "0", "0.2", "0", "0", "0",
                          "base_link", "laser")
    points = spawn.python("-m", "nodes.point_publisher")
    listener = spawn.python("-m", "nodes.point_listener")
    seen = [floats(listener.wait_for_line(rf"obstacle in base_link: {TRIPLE}", 20)) for _ in range(3)]
    for x, y, z in seen:
        assert (y, z) == pytest.approx((0.0, 0.3), abs=1e-3)
        k = (x - 0.7) / 0.004  # x = 0.4 + 0.3 + 0.004 k
        assert k > -0.3 and abs(k - round(k)) < 0.3, x
    assert seen[0][0] < seen[1][0] < seen[2][0]
    stop_cleanly(listener, points, static)


def test_av2_seen_from_av1_runs_on_the_ellipse(spawn):
    frames = spawn.python("-m", "nodes.frames_publisher")
    plots = spawn.python("-m", "nodes.plots_publisher", "-p", "rate:=20")
    pts = [floats(plots.wait_for_line(rf"av2 in av1: {TRIPLE}", 20)) for _ in range(6)]
    for x, y, z in pts:
        assert 2 * y - z + 1 == pytest.approx(0.0, abs=2e-3)  # in the plane 2y - z + 1 = 0
        u = x + 1.0  # about the centre (-1, -1/2, 0): semi-axis 1/2 along x, sqrt(5)/2 along (0, 1, 2)
        v = ((y + 0.5) + 2 * z) / math.sqrt(5)
        assert (u / 0.5) ** 2 + (v / (math.sqrt(5) / 2)) ** 2 == pytest.approx(1.0, abs=1e-2)
    assert len(set(pts)) > 1  # the drones move
    stop_cleanly(plots, frames)


def test_static_drones_sit_at_their_t0_poses(spawn):
    spawn.python("-m", "nodes.frames_publisher", "-p", "static:=true")
    plots = spawn.python("-m", "nodes.plots_publisher", "-p", "rate:=20")
    m = plots.wait_for_line(rf"av2 in av1: {TRIPLE}", 20)
    assert floats(m) == pytest.approx((-1.0, 0.0, 1.0), abs=1e-3)


def test_follower_turtle_closes_on_turtle1(spawn):
    sim = spawn.python("-m", "nodes.turtlesim")
    sim.wait_for_line(r"spawned turtle1 at", 20)
    b1 = spawn.python("-m", "nodes.turtle_tf_broadcaster", "--name", "tb1", "-p", "turtlename:=turtle1")
    b2 = spawn.python("-m", "nodes.turtle_tf_broadcaster", "--name", "tb2", "-p", "turtlename:=turtle2")
    follower = spawn.python("-m", "nodes.turtle_follower", "-p", "print_period:=0.2")
    sim.wait_for_line(r"spawned turtle2 at \(4\.000, 2\.000, 0\.000\)", 20)
    first = float(follower.wait_for_line(r"distance to turtle1: (\d+\.\d+)", 20).group(1))
    assert first > 2.5  # it starts ~3.9 m away
    deadline_lines = 150  # 30 s of lines at 0.2 s
    for _ in range(deadline_lines):
        d = float(follower.wait_for_line(r"distance to turtle1: (\d+\.\d+)", 20).group(1))
        if d < 0.3:
            break
    assert d < 0.3
    stop_cleanly(follower, b1, b2, sim)


def test_teleop_drives_turtle1_on_its_circle(spawn):
    """v = 1 m/s, w = 0.5 rad/s from (5.544, 5.544) facing +x: radius 2 about (5.544, 7.544)."""
    sim = spawn.python("-m", "nodes.turtlesim")
    sim.wait_for_line(r"spawned turtle1 at", 20)
    tb = spawn.python("-m", "nodes.turtle_tf_broadcaster")
    teleop = spawn.python("-m", "nodes.turtle_teleop", "-p", "linear_speed:=1.0", "-p", "angular_speed:=0.5")
    watch = spawn.python("-m", "nodes.frame_listener", "-p", "target_frame:=world",
                         "-p", "source_frame:=turtle1", "-p", "period:=0.2")
    pts = []
    while len(pts) < 3:
        x, y, z = floats(watch.wait_for_line(rf"turtle1 in world: translation {TRIPLE}", 20))
        if (x, y) != pytest.approx((5.544, 5.544), abs=1e-3):  # moving
            pts.append((x, y, z))
    c = (500 - 1) / 45 / 2  # turtlesim's centre
    for x, y, z in pts:
        assert z == 0.0
        assert math.hypot(x - c, y - (c + 2.0)) == pytest.approx(2.0, abs=0.05)
    assert len({p[:2] for p in pts}) == 3
    stop_cleanly(watch, teleop, tb, sim)


def test_a_second_signal_during_shutdown_still_exits_cleanly(spawn):
    """The launcher escalates SIGINT -> SIGTERM; the node's clean-up must not be cut short by it."""
    import signal

    p = spawn.python("-m", "nodes.point_publisher", "-p", "print_every:=1")
    p.wait_for_line(r"obstacle in laser: ", 20)
    p.signal(signal.SIGINT)
    p.signal(signal.SIGTERM)
    assert p.wait(10) == 0, p.output()[-2000:]
    assert "Traceback" not in p.output()


def test_a_node_whose_reader_goes_away_stops_quietly(zenoh_env):
    """`python -m nodes.point_publisher | head -1`: the node ends (status 0, nothing on stderr)."""
    import subprocess
    import sys

    p = subprocess.Popen([sys.executable, "-m", "nodes.point_publisher", "-p", "print_every:=1"],
                         env=zenoh_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().startswith("obstacle in laser: ")
        p.stdout.close()
        assert p.wait(15) == 0
        assert p.stderr.read() == ""
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(5)


def test_plots_publisher_markers_are_three_growing_line_strips(spawn, node_options):
    """The MarkerArray contract the visualization draws: ns trails, ids 0..2, LINE_STRIP, frames."""
    import threading

    from zentf.core.messages import Marker, MarkerArray
    from zentf.transport.node import Node

    got: list[MarkerArray] = []
    cond = threading.Condition()

    def on_markers(msg: MarkerArray) -> None:
        with cond:
            got.append(msg)
            cond.notify_all()

    with Node("marker_probe", options=node_options) as probe:
        probe.create_subscription("visual_markers", MarkerArray, on_markers)
        spawn.python("-m", "nodes.frames_publisher")
        spawn.python("-m", "nodes.plots_publisher", "-p", "rate:=20", "-p", "trail_length:=5")
        with cond:  # wait until all three trails are full
            assert cond.wait_for(lambda: got and len(got[-1].markers) == 3
                                 and all(len(m.points) == 5 for m in got[-1].markers), 20)
            last = got[-1]
    assert [(m.ns, m.id, m.type, m.header.frame_id) for m in last.markers] == [
        ("trails", 0, Marker.LINE_STRIP, "world"), ("trails", 1, Marker.LINE_STRIP, "world"),
        ("trails", 2, Marker.LINE_STRIP, "av1")]
    for p in last.markers[0].points:  # av1 in world: on the unit circle, z = 0
        assert (math.hypot(p.x, p.y), p.z) == pytest.approx((1.0, 0.0), abs=1e-6)


def test_drones_follow_a_published_sim_clock(isolated_router, test_namespace, zenoh_env, spawn):
    """With use_sim_time the drones are stamped with /clock and sit exactly where the clock says."""
    from zentf.transport.buffer import Buffer
    from zentf.transport.listener import TransformListener
    from zentf.core.messages import Clock
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions, ZenohOptions
    from zentf.core.time import Time

    from zentf.demos.frames_publisher import av2_in_av1

    env = {**zenoh_env, "ZENTF_CONNECT": isolated_router}  # /clock is absolute: keep it to this test
    spawn.python("-m", "nodes.frames_publisher", "-p", "use_sim_time:=true", env=env)
    opts = NodeOptions(namespace=test_namespace,
                       zenoh=ZenohOptions(connect=[isolated_router], no_multicast=True, mode="peer"))
    with Node("sim_clock_probe", options=opts) as probe:
        buffer = Buffer()
        listener = TransformListener(buffer, probe)
        clock = probe.create_publisher("/clock", Clock)
        sent: list[int] = []
        ns = 100 * 10**9
        for _ in range(400):  # each round waits (event-driven, <= 50 ms) for the drones to show up
            ns += 20_000_000
            sent.append(ns)
            clock.publish(Clock(clock=Time(nanoseconds=ns)))
            if buffer.can_transform("av1", "av2", Time(), timeout=0.05):
                break
        ts = buffer.lookup_transform("av1", "av2", Time())
        listener.unregister()
    stamp = ts.header.stamp.nanoseconds
    assert stamp in sent  # stamped with the published sim time, not the wall clock
    tr = ts.transform.translation
    assert (tr.x, tr.y, tr.z) == pytest.approx(av2_in_av1(stamp / 1e9), abs=1e-9)
