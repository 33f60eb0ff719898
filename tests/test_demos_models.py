"""Pure models behind the demo nodes: turtle kinematics, drone trajectories, follower and teleop laws."""
from __future__ import annotations

import math

import pytest

from zentf.demos.frames_publisher import av2_in_av1, drone_poses
from zentf.demos.point_publisher import obstacle_position
from zentf.demos.turtle_follower import follow_command
from zentf.demos.turtle_teleop import command_at
from zentf.demos.turtlesim import CENTRE, WORLD_SIZE, Turtle, World, normalize_angle
from zentf.core.math3d import inverse_transform, compose


def test_world_geometry_matches_turtlesim():
    assert CENTRE == pytest.approx(5.544444, abs=1e-6)
    assert WORLD_SIZE == pytest.approx(11.088889, abs=1e-6)


@pytest.mark.parametrize("a, expected", [
    (0.0, 0.0), (math.pi, math.pi), (-math.pi, math.pi), (3 * math.pi / 2, -math.pi / 2),
    (-3 * math.pi / 2, math.pi / 2), (7.0, 7.0 - 2 * math.pi),
])
def test_normalize_angle(a, expected):
    assert normalize_angle(a) == pytest.approx(expected)


def test_turtle_drives_a_circle_and_stops_after_one_second():
    t = Turtle("t", CENTRE, CENTRE, 0.0)
    t.command(1.0, 0.0, 1.0, now=0.0)
    dt, now = 0.001, 0.0
    for _ in range(int(round(math.pi / dt))):  # half a turn of radius 1, but the command expires at 1 s
        now += dt
        t.step(now, dt)
    # after 1 s of command: quarter-ish arc of angle 1 rad, then standing still
    assert t.theta == pytest.approx(1.0, abs=2e-3)
    assert t.x == pytest.approx(CENTRE + math.sin(1.0), abs=2e-3)
    assert t.y == pytest.approx(CENTRE + 1 - math.cos(1.0), abs=2e-3)
    assert t.velocities() == (0.0, 0.0)


def test_turtle_lateral_velocity_and_wall_clamp():
    t = Turtle("t", 1.0, 1.0, math.pi / 2)  # facing +y
    t.command(0.0, 1.0, 0.0, now=0.0)      # lateral +y in body = -x in world
    assert t.step(0.5, 0.5) is False
    assert (t.x, t.y) == pytest.approx((0.5, 1.0))
    assert t.step(0.9, 1.0) is True
    assert t.x == 0.0


def test_world_spawn_rules():
    w = World()
    assert w.spawn("", 1, 1, 0).name == "turtle1"
    assert w.spawn("", 1, 1, 0).name == "turtle2"
    with pytest.raises(ValueError, match="already exists"):
        w.spawn("turtle1", 0, 0, 0)
    with pytest.raises(ValueError, match="invalid turtle name"):
        w.spawn("1abc", 0, 0, 0)
    with pytest.raises(ValueError, match="finite"):
        w.spawn("x", math.nan, 0, 0)
    with pytest.raises(ValueError, match="non-finite"):
        w.command("turtle1", math.inf, 0, 0, 0.0)
    w.command("turtle1", 1.0, 0.0, 0.0, 0.0)
    out = {name: (x, y) for name, x, y, *_ in w.step(0.1, 0.1)}
    assert out["turtle1"] == pytest.approx((1.1, 1.0))
    assert out["turtle2"] == (1.0, 1.0)


@pytest.mark.parametrize("t", [0.0, 0.3, 1.0, 2.5, 4.0, 100.7])
def test_av2_in_av1_lies_on_the_ellipse(t):
    (_, _, p1, q1), (_, _, p2, q2) = drone_poses(t)
    assert sum(c * c for c in q1) == pytest.approx(1.0)
    inv_t, inv_q = inverse_transform(p1, q1)
    rel, _ = compose(inv_t, inv_q, p2, q2)
    assert rel == pytest.approx(av2_in_av1(t), abs=1e-12)
    x, y, z = rel
    assert 2 * y - z + 1 == pytest.approx(0.0, abs=1e-12)  # the plane
    # semi-axis 1/2 along x, sqrt(5)/2 along (0, 1, 2)/sqrt(5) about the centre (-1, -1/2, 0)
    u = x + 1.0
    v = ((y + 0.5) * 1 + z * 2) / math.sqrt(5)
    assert (u / 0.5) ** 2 + (v / (math.sqrt(5) / 2)) ** 2 == pytest.approx(1.0, abs=1e-12)


def test_av1_yaw_follows_time():
    (_, _, p1, q1), _ = drone_poses(math.pi / 2)
    assert p1 == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)
    assert 2 * math.atan2(q1[2], q1[3]) == pytest.approx(math.pi / 2)


def test_obstacle_sequence():
    assert obstacle_position(0) == (0.3, 0.0, 0.1)
    assert obstacle_position(10)[0] == pytest.approx(0.34)


def test_follow_command_is_the_tutorial_law():
    assert follow_command(3.0, 4.0) == pytest.approx((2.5, 4 * math.atan2(4.0, 3.0)))
    assert follow_command(-1.0, 0.0)[1] == pytest.approx(4 * math.pi)


def test_teleop_patterns():
    assert command_at("circle", 12.3, 1.0, 0.5) == (1.0, 0.5)
    assert command_at("square", 0.5, 1.0, 0.5, side=2.0) == (1.0, 0.0)
    assert command_at("square", 2.5, 1.0, 0.5, side=2.0) == (0.0, 0.5)  # turning: pi s
    assert command_at("square", 2.0 + math.pi + 0.1, 1.0, 0.5, side=2.0) == (1.0, 0.0)
    with pytest.raises(ValueError, match="unknown pattern"):
        command_at("zigzag", 0.0, 1.0, 1.0)


def test_a_late_step_follows_the_same_path():
    """One 0.4 s step (a stalled timer) lands where 25 steps of 16 ms do."""
    a, b = Turtle("a", CENTRE, CENTRE, 0.0), Turtle("b", CENTRE, CENTRE, 0.0)
    for t in (a, b):
        t.command(1.0, 0.0, 0.5, now=0.0)
    a.step(0.4, 0.4)
    for k in range(25):
        b.step(0.016 * (k + 1), 0.016)
    assert (a.x, a.y, a.theta) == pytest.approx((b.x, b.y, b.theta), abs=1e-9)
