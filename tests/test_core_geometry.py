"""do_transform_* and transform() through a buffer, on known values."""
from __future__ import annotations

import pytest

from zentf import ExtrapolationException, TypeException
from zentf.core.buffer_core import BufferCore
from zentf.core.geometry import do_transform_point, do_transform_pose, do_transform_vector3, transform, transform_full
from zentf.core.messages import (Header, Point, PointStamped, Pose, PoseStamped, Quaternion, Transform,
                                 TransformStamped, Vector3, Vector3Stamped)
from zentf.core.time import Time

FLIP_X = (1.0, 0.0, 0.0, 0.0)  # 180 degrees about x


def edge(parent: str, child: str, sec: float, t, q) -> TransformStamped:
    return TransformStamped(Header(Time.from_sec(sec), parent), child, Transform(Vector3(*t), Quaternion(*q)))


def test_do_transform_known_values_from_tf2_geometry_msgs() -> None:
    t = edge("A", "B", 2, (10, 20, 30), FLIP_X)
    p = do_transform_point(PointStamped(Header(Time(2), "B"), Point(1, 2, 3)), t)
    assert (p.point.x, p.point.y, p.point.z) == pytest.approx((11, 18, 27))
    assert p.header.frame_id == "A" and p.header.stamp == Time(2)
    v = do_transform_vector3(Vector3Stamped(Header(Time(2), "B"), Vector3(1, 2, 3)), t)
    assert (v.vector.x, v.vector.y, v.vector.z) == pytest.approx((1, -2, -3))
    assert do_transform_vector3(Vector3(1, 0, 0), edge("a", "b", 0, (1, 2, 3), (0, 1, 0, 0))).x == pytest.approx(-1)
    pose = do_transform_pose(Pose(Point(1, 2, 3), Quaternion(0, 0, 0, 1)), t)
    assert (pose.position.x, pose.position.y, pose.position.z) == pytest.approx((11, 18, 27))
    assert (pose.orientation.x, pose.orientation.w) == pytest.approx((1, 0))


def test_transform_through_buffer_and_type_errors() -> None:
    core = BufferCore()
    core.set_transform(edge("A", "B", 2, (10, 20, 30), FLIP_X), "x")
    p = transform(core, PointStamped(Header(Time(2), "A"), Point(1, 2, 3)), "B")
    assert (p.point.x, p.point.y, p.point.z) == pytest.approx((-9, 18, 27))
    assert p.header.frame_id == "B"
    pose = core.transform(PoseStamped(Header(Time(2), "A"), Pose(Point(1, 2, 3))), "B")
    assert (pose.pose.position.x, pose.pose.position.y) == pytest.approx((-9, 18))
    full = transform_full(core, PointStamped(Header(Time(2), "A"), Point(1, 2, 3)), "B", Time(2), "A")
    assert (full.point.x, full.point.y, full.point.z) == pytest.approx((-9, 18, 27))
    with pytest.raises(TypeException, match="not loaded or supported"):
        transform(core, Point(1, 2, 3), "B")
    with pytest.raises(TypeException):
        transform(core, PointStamped(Header(Time(2), "A")), "B", new_type=PoseStamped)
    with pytest.raises(ExtrapolationException):
        transform(core, PointStamped(Header(Time(5), "A")), "B")


