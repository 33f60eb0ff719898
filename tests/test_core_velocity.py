"""BufferCore.lookup_velocity: ROS 2 tf2's lookupVelocity, on its own unit tests and on the drones.

Expected values come from geometry2 (ROS 2) tests ported here — tf2_py/test/test_buffer_core.py
``test_velocity``, tf2_ros/test/test_buffer.cpp ``test_twist`` and tf2_ros/test/velocity_test.cpp
(the square paths) — and from central finite differences of the drones' analytic motion
(zentf/demos/frames_publisher.py) put through ROS 2's convention (see zentf/core/velocity.py).
"""
from __future__ import annotations

import math

import pytest

from zentf.demos.frames_publisher import av2_in_av1, drone_poses
from zentf.core.buffer_core import BufferCore
from zentf.core.exceptions import ExtrapolationException, InvalidArgumentException, LookupException
from zentf.core.math3d import quaternion_from_rpy, quaternion_normalize
from zentf.core.messages import Point, VelocityStamped
from zentf.core.time import Duration, Time

NOW_NS = 1_700_000_000 * 1_000_000_000


def twist(v: VelocityStamped) -> tuple[float, ...]:
    lin, ang = v.velocity.linear, v.velocity.angular
    return (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)


def test_tf2_py_velocity_case() -> None:
    """tf2_py test_velocity: x = 3 t for t = 0..4 s; time 0, interval 4.001 s -> 3 m/s."""
    core = BufferCore()
    for ti in range(5):
        core.set_transform_raw("PARENT", "THISFRAME", ti * 1_000_000_000, ti * 3.0, 0, 0, 0, 0, 0, 1, "unittest", False)
    tw0 = core.lookup_velocity("THISFRAME", "PARENT", Time(), Duration(4, 1_000_000))
    assert tw0.velocity.linear.x == pytest.approx(3.0, abs=1e-2)
    tw1 = core.lookup_velocity_full("THISFRAME", "PARENT", "PARENT", (0, 0, 0), "THISFRAME", Time(),
                                    Duration(4, 1_000_000))
    assert tw0 == tw1
    assert tw0.header.frame_id == "PARENT" and tw0.body_frame_id == "THISFRAME"


def test_tf2_ros_twist_case() -> None:
    """tf2_ros test_twist: x = 0.3 i at now + i s (i = -10..4), interval 4.001 s at now -> 0.3 m/s."""
    core = BufferCore()
    for i in range(-10, 5):
        core.set_transform_raw("PARENT", "THISFRAME", NOW_NS + i * 1_000_000_000, i * 0.3, 0, 0, 0, 0, 0, 1,
                               "unittest", False)
    tw1 = core.lookup_velocity_full("THISFRAME", "PARENT", "PARENT", Point(0, 0, 0), "THISFRAME",
                                    Time(nanoseconds=NOW_NS), 4.001)
    assert twist(tw1) == pytest.approx((0.3, 0, 0, 0, 0, 0), abs=1e-6)


def square_core(angular: bool) -> BufferCore:
    """velocity_test.cpp's fixtures: bar moves (or rolls/pitches/yaws) 0.1 per 0.1 s along a square."""
    core = BufferCore()
    x, y, z = (-0.1 if angular else 0.0), 0.0, 0.0
    t = 0.1
    while t < 6 if angular else t <= 6:
        if t < 1:
            x += 0.1
        elif t < 2:
            if angular:
                x -= 0.1
            else:
                y += 0.1
        elif t < 3:
            if angular:
                y += 0.1
            else:
                x -= 0.1
        elif t < 4:
            y -= 0.1
        elif t < 5:
            z += 0.1
        else:
            z -= 0.1
        stamp = NOW_NS + round(t * 1e9)
        if angular:
            q = quaternion_normalize(quaternion_from_rpy(x, y, z))
            core.set_transform_raw("foo", "bar", stamp, 0, 0, 0, *q, "unittest", False)
            core.set_transform_raw("foo", "stationary_offset_child", stamp, 1, 0, 0, 0, 0, 0, 1, "unittest", False)
            core.set_transform_raw("stationary_offset_parent", "foo", stamp, 0, 0, -1, 0, 0, 0, 1, "unittest", False)
        else:
            core.set_transform_raw("foo", "bar", stamp, x, y, z, 0, 0, 0, 1, "unittest", False)
            core.set_transform_raw("foo", "stationary_offset_child", stamp, 1, 0, 0, 0, 0, 0, 1, "unittest", False)
            core.set_transform_raw("stationary_offset_parent", "foo", stamp, 0, 0, 1, 0, 0, 0, 1, "unittest", False)
        t += 0.1
    return core


def at(s: float) -> Time:
    return Time(nanoseconds=NOW_NS + round(s * 1e9))


def test_linear_velocity_to_three_frames() -> None:
    core = square_core(angular=False)
    expected = {0.5: (1, 0, 0), 1.5: (0, 1, 0), 2.5: (-1, 0, 0), 3.5: (0, -1, 0), 4.5: (0, 0, 1), 5.5: (0, 0, -1)}
    for frame in ("foo", "stationary_offset_child", "stationary_offset_parent"):
        for s, lin in expected.items():
            got = twist(core.lookup_velocity("bar", frame, at(s), 0.1))
            assert got == pytest.approx((*lin, 0, 0, 0), abs=1e-6), (frame, s)


@pytest.mark.parametrize("frame,expected", [
    ("foo", {0.5: (0, 0, 0, 1, 0, 0), 1.5: (0, 0, 0, -1, 0, 0), 2.5: (0, 0, 0, 0, 1, 0),
             3.5: (0, 0, 0, 0, -1, 0), 4.5: (0, 0, 0, 0, 0, 1), 5.5: (0, 0, 0, 0, 0, -1)}),
    ("stationary_offset_child", {0.5: (0, 0, 0, 1, 0, 0), 1.5: (0, 0, 0, -1, 0, 0), 2.5: (0, 0, -1, 0, 1, 0),
                                 3.5: (0, 0, 1, 0, -1, 0), 4.5: (0, 1, 0, 0, 0, 1), 5.5: (0, -1, 0, 0, 0, -1)}),
    ("stationary_offset_parent", {0.5: (0, -1, 0, 1, 0, 0), 1.5: (0, 1, 0, -1, 0, 0), 2.5: (1, 0, 0, 0, 1, 0),
                                  3.5: (-1, 0, 0, 0, -1, 0), 4.5: (0, 0, 0, 0, 0, 1), 5.5: (0, 0, 0, 0, 0, -1)}),
])
def test_angular_velocity_square(frame: str, expected: dict) -> None:
    core = square_core(angular=True)
    for s, tw in expected.items():
        v = core.lookup_velocity("bar", frame, at(s), 0.1)
        assert twist(v) == pytest.approx(tw, abs=1e-6), (frame, s, twist(v))
        # stamped at the middle of the averaging window
        assert v.header.stamp == at(s) and v.header.frame_id == frame


def test_window_slides_back_from_the_newest_data_and_errors() -> None:
    core = BufferCore()
    for k in range(11):  # constant 2 m/s along y for 1 s
        core.set_transform_raw("odom", "base", NOW_NS + k * 100_000_000, 0, 0.2 * k, 0, 0, 0, 0, 1, "t", False)
    newest = core.lookup_velocity("base", "odom", Time(), 0.4)  # Time() = latest common time
    assert twist(newest) == pytest.approx((0, 2, 0, 0, 0, 0), abs=1e-9)
    assert newest.header.stamp == Time(nanoseconds=NOW_NS + 800_000_000)  # window [0.6, 1.0] s
    late = core.lookup_velocity("base", "odom", Time(nanoseconds=NOW_NS + 1_000_000_000), 0.4)
    assert twist(late) == twist(newest)
    with pytest.raises(ExtrapolationException):
        core.lookup_velocity("base", "odom", Time(nanoseconds=NOW_NS - 5_000_000_000), 0.4)
    with pytest.raises(LookupException):
        core.lookup_velocity("base", "nowhere", Time(), 0.4)
    with pytest.raises(InvalidArgumentException, match="averaging_interval"):
        core.lookup_velocity("base", "odom", Time(), 0)


def drones_core(seconds: float = 4.0, rate: int = 100) -> BufferCore:
    core = BufferCore(cache_time=60.0)
    step = 1_000_000_000 // rate
    for k in range(int(seconds * rate) + 1):
        ns = NOW_NS + k * step
        for parent, child, tr, q in drone_poses(ns / 1e9):
            core.set_transform_raw(parent, child, ns, *tr, *q, "frames_publisher", False)
    return core


def rz(theta: float, v: tuple[float, float, float]) -> tuple[float, float, float]:
    c, s = math.cos(theta), math.sin(theta)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])


def cross(a: tuple, b: tuple) -> tuple:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def central(f, t: float, h: float) -> tuple[float, float, float]:
    a, b = f(t + h), f(t - h)
    return tuple((x - y) / (2 * h) for x, y in zip(a, b))


@pytest.mark.parametrize("offset", [1.0, 1.37, 2.5])
def test_drones_against_finite_differences(offset: float) -> None:
    """av2 (no rotation) in world: plain finite difference; av1 and av2-from-av1: ROS 2's convention."""
    core = drones_core()
    h = 0.05
    when = Time(nanoseconds=NOW_NS + round(offset * 1e9))
    t = when.nanoseconds / 1e9

    def av1(tt: float) -> tuple:
        return drone_poses(tt)[0][2]

    def av2(tt: float) -> tuple:
        return drone_poses(tt)[1][2]

    # av2 moves without turning: its velocity in world is the derivative of (sin t, 0, cos 2t)
    v2 = core.lookup_velocity("av2", "world", when, 2 * h)
    assert twist(v2)[:3] == pytest.approx(central(av2, t, h), abs=1e-5)
    assert twist(v2)[:3] == pytest.approx((math.cos(t), 0.0, -2 * math.sin(2 * t)), abs=1e-2)
    assert twist(v2)[3:] == pytest.approx((0, 0, 0), abs=1e-9)

    # av1 yaws at 1 rad/s; ROS 2 re-expresses with world<-av1 (yaw t) and adds origin x angular
    v1 = core.lookup_velocity("av1", "world", when, 2 * h)
    w = (0.0, 0.0, 1.0)
    expected = tuple(a + b for a, b in zip(rz(t, central(av1, t, h)), cross(av1(t), w)))
    assert twist(v1)[3:] == pytest.approx(w, abs=2e-5)  # stamps at 1.7e9 s: yaw t is known to ~2e-7 rad
    assert twist(v1)[:3] == pytest.approx(expected, abs=1e-4)

    # av2 seen from av1: the ellipse, turning at -1 rad/s; re-expressed with av1<-av2 (yaw -t)
    v21 = core.lookup_velocity("av2", "av1", when, 2 * h)
    w21 = (0.0, 0.0, -1.0)
    p = av2_in_av1(t)
    expected = tuple(a + b for a, b in zip(rz(-t, central(av2_in_av1, t, h)), cross(p, w21)))
    assert twist(v21)[3:] == pytest.approx(w21, abs=2e-5)
    assert twist(v21)[:3] == pytest.approx(expected, abs=1e-4)
