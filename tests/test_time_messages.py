"""Time/Duration arithmetic and message dict round trips (the msgpack wire form)."""
from __future__ import annotations

import math

import pytest

from zentf.core.messages import (MESSAGE_TYPES, Header, Point, PointStamped, Pose, PoseStamped, Quaternion,
                            TFMessage, Transform, TransformStamped, Vector3, Vector3Stamped)
from zentf.core.time import Duration, Time, to_time


def test_time_and_duration_arithmetic() -> None:
    t = Time(5, 250_000_000)
    d = Duration.from_sec(1.5)
    assert t + d == Time(6, 750_000_000) and d + t == Time(6, 750_000_000)
    assert (Time(7) - Time(5)) == Duration(2) and isinstance(Time(7) - Time(5), Duration)
    assert Time(7) - Duration(2) == Time(5)
    assert d + d == Duration(3) and d - Duration(2) == Duration.from_sec(-0.5)
    with pytest.raises(TypeError):
        _ = Time(1) + Time(2)
    assert t.sec == 5 and t.nanosec == 250_000_000 and t.to_nsec() == 5_250_000_000
    assert t.to_sec() == 5.25 and Time.from_sec(5.25) == t
    assert Time(1) < Time(2) <= Time(2) and Duration(-1) < Duration()
    assert Time().is_zero() and to_time(0) == Time() and to_time(1.5) == Time(1, 500_000_000)
    assert Duration(-1, 500_000_000).to_sec() == -0.5
    assert Duration.from_sec(-0.5).sec == -1 and Duration.from_sec(-0.5).nanosec == 500_000_000
    with pytest.raises(ValueError):
        Time.from_sec(math.nan)
    with pytest.raises(ValueError):
        Time.from_sec(-1.0)
    assert Time.from_dict(t.to_dict()) == t and Duration.from_dict(d.to_dict()) == d


def full_tf() -> TFMessage:
    return TFMessage(transforms=[
        TransformStamped(Header(Time(3, 7), "map"), "odom", Transform(Vector3(1, 2, 3), Quaternion(0, 0, 1, 0))),
        TransformStamped(Header(Time(4), "odom"), "base_link"),
    ])


@pytest.mark.parametrize("msg", [
    Header(), Vector3(1, 2, 3), Point(-1, 0.5, 2), Quaternion(), full_tf(),
    PointStamped(Header(Time(1), "a"), Point(1, 2, 3)), Vector3Stamped(Header(Time(2), "b"), Vector3(0, 0, 1)),
    PoseStamped(Header(Time(3), "c"), Pose(Point(1, 1, 1), Quaternion(0, 0, 0, 1))),
])
def test_round_trip(msg) -> None:
    d = msg.to_dict()
    assert type(msg).from_dict(d) == msg
    assert MESSAGE_TYPES[type(msg).TYPE_NAME] is type(msg)


def test_dict_uses_ros_field_names_and_defaults() -> None:
    d = full_tf().to_dict()
    first = d["transforms"][0]
    assert set(first) == {"header", "child_frame_id", "transform"}
    assert first["header"] == {"stamp": {"sec": 3, "nanosec": 7}, "frame_id": "map"}
    assert first["transform"]["rotation"] == {"x": 0, "y": 0, "z": 1, "w": 0}
    assert Quaternion().w == 1.0 and TransformStamped().transform.rotation.w == 1.0
    assert TransformStamped.from_dict({}).header.frame_id == ""


@pytest.mark.parametrize("bad,field", [
    ({"transforms": [{"header": {"stamp": {"sec": "x"}}}]}, "transforms[0].header.stamp"),
    ({"transforms": [{"transform": {"translation": {"x": "1"}}}]}, "transforms[0].transform.translation.x"),
    ({"transforms": [{"child_frame_id": 5}]}, "transforms[0].child_frame_id"),
    ({"transforms": [{"bogus": 1}]}, "bogus"),
    ({"transforms": {"a": 1}}, "transforms"),
    ({"transforms": [{"header": {"stamp": {"sec": 1, "nanosec": 2_000_000_000}}}]}, "nanosec"),
    ({"transforms": [{"transform": {"rotation": {"w": True}}}]}, "rotation.w"),
    ([], "TFMessage"),
])
def test_malformed_dicts_name_the_field(bad, field) -> None:
    with pytest.raises(ValueError) as e:
        TFMessage.from_dict(bad)
    assert field in str(e.value)
