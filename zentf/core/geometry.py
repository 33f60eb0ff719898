"""Applying transforms to data: tf2_geometry_msgs' do_transform_* and ``transform`` through a buffer.

Whole arrays (a point cloud, a stamped trajectory) go through ``zentf.core.batch`` instead.
"""
from __future__ import annotations

from typing import Any, Callable

from .exceptions import TypeException
from .messages import (Header, Point, PointStamped, Pose, PoseStamped, PoseWithCovariance, PoseWithCovarianceStamped,
                       Quaternion, QuaternionStamped, Transform, TransformStamped, Twist, TwistStamped, Vector3,
                       Vector3Stamped, Wrench, WrenchStamped)
from .rotation import matrix_from_quaternion, quaternion_from_matrix, quaternion_multiply

__all__ = [
    "do_transform_point", "do_transform_vector3", "do_transform_vector", "do_transform_pose",
    "do_transform_pose_stamped", "do_transform_pose_with_covariance", "do_transform_quaternion",
    "do_transform_transform", "do_transform_wrench", "do_transform_twist", "transform_covariance", "transform",
    "transform_full", "registered_types",
]


def _rot_trans(t: TransformStamped) -> tuple[list[list[float]], tuple[float, float, float]]:
    tr = t.transform
    q = tr.rotation
    v = tr.translation
    return matrix_from_quaternion((q.x, q.y, q.z, q.w)), (v.x, v.y, v.z)


def _apply(m: list[list[float]], x: float, y: float, z: float) -> tuple[float, float, float]:
    return (m[0][0] * x + m[0][1] * y + m[0][2] * z,
            m[1][0] * x + m[1][1] * y + m[1][2] * z,
            m[2][0] * x + m[2][1] * y + m[2][2] * z)


def _header(t: TransformStamped) -> Header:
    return Header(stamp=t.header.stamp, frame_id=t.header.frame_id)


def do_transform_point(point: PointStamped | Point, transform: TransformStamped) -> PointStamped | Point:
    """Rotate and translate a point; a PointStamped gets the transform's header (tf2 convention)."""
    p = point.point if isinstance(point, PointStamped) else point
    m, t = _rot_trans(transform)
    x, y, z = _apply(m, p.x, p.y, p.z)
    out = Point(x + t[0], y + t[1], z + t[2])
    return PointStamped(header=_header(transform), point=out) if isinstance(point, PointStamped) else out


def do_transform_vector3(vector: Vector3Stamped | Vector3, transform: TransformStamped) -> Vector3Stamped | Vector3:
    """Rotate a vector; translation does not apply to directions."""
    v = vector.vector if isinstance(vector, Vector3Stamped) else vector
    m, _ = _rot_trans(transform)
    out = Vector3(*_apply(m, v.x, v.y, v.z))
    return Vector3Stamped(header=_header(transform), vector=out) if isinstance(vector, Vector3Stamped) else out


do_transform_vector = do_transform_vector3


def _mat_mul(a: list[list[float]], b: list[list[float]]) -> list[list[float]]:
    """tf2 ``Matrix3x3 operator*`` (same sums in the same order, so the same bits)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    (b00, b01, b02), (b10, b11, b12), (b20, b21, b22) = b
    return [[a00 * b00 + a01 * b10 + a02 * b20, a00 * b01 + a01 * b11 + a02 * b21, a00 * b02 + a01 * b12 + a02 * b22],
            [a10 * b00 + a11 * b10 + a12 * b20, a10 * b01 + a11 * b11 + a12 * b21, a10 * b02 + a11 * b12 + a12 * b22],
            [a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, a20 * b02 + a21 * b12 + a22 * b22]]


def _cross(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float, float]:
    """tf2 ``Vector3::cross``."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _compose_pose(transform: TransformStamped, p: Any, o: Any) -> tuple[Point, Quaternion]:
    """tf2::Transform(transform) * tf2::Transform(o, p), read back as tf2's ``toMsg`` does.

    tf2_geometry_msgs composes through rotation matrices and takes the quaternion back with
    ``Matrix3x3::getRotation`` (w >= 0 whenever the trace is positive), so the result's sign is
    a function of the rotation alone, not of the signs of the inputs (q and -q give one answer).
    """
    m, t = _rot_trans(transform)
    x, y, z = _apply(m, p.x, p.y, p.z)
    basis = _mat_mul(m, matrix_from_quaternion((o.x, o.y, o.z, o.w)))
    return Point(x + t[0], y + t[1], z + t[2]), Quaternion(*quaternion_from_matrix(basis))


def do_transform_pose(pose: PoseStamped | Pose, transform: TransformStamped) -> PoseStamped | Pose:
    """Transform a pose as tf2_geometry_msgs does: composed through matrices, quaternion via getRotation."""
    ps = pose.pose if isinstance(pose, PoseStamped) else pose
    position, orientation = _compose_pose(transform, ps.position, ps.orientation)
    out = Pose(position=position, orientation=orientation)
    return PoseStamped(header=_header(transform), pose=out) if isinstance(pose, PoseStamped) else out


def do_transform_pose_stamped(pose: PoseStamped, transform: TransformStamped) -> PoseStamped:
    return do_transform_pose(pose, transform)  # type: ignore[return-value]


def transform_covariance(covariance: Any, transform: TransformStamped) -> list[float]:
    """6x6 pose covariance rotated as tf2_geometry_msgs' ``transformCovariance``.

    [R 0; 0 R] C [R' 0; 0 R']: each 3x3 block (position, orientation and both cross blocks) becomes
    R·block·R'. The translation does not enter (tf2's choice: no lever-arm term).
    """
    c = [float(v) for v in covariance]
    if len(c) != 36:
        raise ValueError(f"covariance must have 36 numbers, got {len(c)}")
    r, _ = _rot_trans(transform)
    rt = [[r[j][i] for j in range(3)] for i in range(3)]
    out = [0.0] * 36
    for bi in (0, 3):
        for bj in (0, 3):
            block = [[c[(bi + i) * 6 + bj + j] for j in range(3)] for i in range(3)]
            res = _mat_mul(_mat_mul(r, block), rt)
            for i in range(3):
                for j in range(3):
                    out[(bi + i) * 6 + bj + j] = res[i][j]
    return out


def do_transform_pose_with_covariance(pose: PoseWithCovarianceStamped | PoseWithCovariance,
                                      transform: TransformStamped) -> PoseWithCovarianceStamped | PoseWithCovariance:
    """Pose as do_transform_pose, covariance rotated block by block (tf2_geometry_msgs)."""
    stamped = isinstance(pose, PoseWithCovarianceStamped)
    pwc = pose.pose if stamped else pose
    position, orientation = _compose_pose(transform, pwc.pose.position, pwc.pose.orientation)
    out = PoseWithCovariance(pose=Pose(position, orientation),
                             covariance=transform_covariance(pwc.covariance, transform))
    return PoseWithCovarianceStamped(header=_header(transform), pose=out) if stamped else out


def do_transform_quaternion(quaternion: QuaternionStamped | Quaternion,
                            transform: TransformStamped) -> QuaternionStamped | Quaternion:
    """q_transform · q (tf2_geometry_msgs multiplies quaternions here, so no sign change)."""
    stamped = isinstance(quaternion, QuaternionStamped)
    q = quaternion.quaternion if stamped else quaternion
    r = transform.transform.rotation
    out = Quaternion(*quaternion_multiply((r.x, r.y, r.z, r.w), (q.x, q.y, q.z, q.w)))
    return QuaternionStamped(header=_header(transform), quaternion=out) if stamped else out


def do_transform_transform(data: TransformStamped | Transform, transform: TransformStamped) -> TransformStamped | Transform:
    """A TransformStamped taken as data: transform * data (tf2_geometry_msgs), child_frame_id kept."""
    stamped = isinstance(data, TransformStamped)
    tr = data.transform if stamped else data
    position, rotation = _compose_pose(transform, tr.translation, tr.rotation)
    out = Transform(Vector3(position.x, position.y, position.z), rotation)
    if stamped:
        return TransformStamped(header=_header(transform), child_frame_id=data.child_frame_id, transform=out)
    return out


def _screw(transform: TransformStamped, axis: Vector3, moment: Vector3) -> tuple[Vector3, Vector3]:
    """The rigid-body (adjoint) map shared by wrenches and twists: (R·a, R·m + t × R·a)."""
    r, t = _rot_trans(transform)
    a = _apply(r, axis.x, axis.y, axis.z)
    m = _apply(r, moment.x, moment.y, moment.z)
    extra = _cross(t, a)
    return Vector3(*a), Vector3(m[0] + extra[0], m[1] + extra[1], m[2] + extra[2])


def do_transform_wrench(wrench: WrenchStamped | Wrench, transform: TransformStamped) -> WrenchStamped | Wrench:
    """force' = R·f, torque' = R·τ + t × force' (tf2_geometry_msgs of ROS 2 and noetic's last release).

    geometry2 0.7.6 (the Debian tf2 the differential tests use) only rotated both vectors; the
    torque of a force moved by t was added later (ros/geometry2 noetic-devel and ros2/geometry2
    both have it): zentf follows the current tf2 of both ROS versions.
    """
    stamped = isinstance(wrench, WrenchStamped)
    w = wrench.wrench if stamped else wrench
    force, torque = _screw(transform, w.force, w.torque)
    out = Wrench(force, torque)
    return WrenchStamped(header=_header(transform), wrench=out) if stamped else out


def do_transform_twist(twist: TwistStamped | Twist, transform: TransformStamped) -> TwistStamped | Twist:
    """angular' = R·ω, linear' = R·v + t × angular': tf2_kdl's ``KDL::Frame * KDL::Twist``.

    tf2_geometry_msgs has no TwistStamped (ROS 2 has VelocityStamped, which applies the same screw
    transform but then adds the input twist back); tf2's TwistStamped conversion is tf2_kdl's, and
    that is the one followed here, with tf2's rotation matrix. The twist is the velocity of a body
    measured at the origin of the source frame, expressed in it; the result is the same motion at
    the origin of the target frame, expressed there.
    """
    stamped = isinstance(twist, TwistStamped)
    tw = twist.twist if stamped else twist
    angular, linear = _screw(transform, tw.angular, tw.linear)
    out = Twist(linear, angular)
    return TwistStamped(header=_header(transform), twist=out) if stamped else out


_HANDLERS: dict[type, Callable[[Any, TransformStamped], Any]] = {
    PointStamped: do_transform_point,
    Vector3Stamped: do_transform_vector3,
    PoseStamped: do_transform_pose,
    PoseWithCovarianceStamped: do_transform_pose_with_covariance,
    QuaternionStamped: do_transform_quaternion,
    TransformStamped: do_transform_transform,
    WrenchStamped: do_transform_wrench,
    TwistStamped: do_transform_twist,
}


def registered_types() -> list[type]:
    """Stamped types transform() knows."""
    return list(_HANDLERS)


def _handler(obj: Any, new_type: Any) -> Callable[[Any, TransformStamped], Any]:
    handler = _HANDLERS.get(type(obj))
    if handler is None:
        raise TypeException(f"Type {type(obj).__name__} is not loaded or supported")
    if new_type is not None and new_type is not type(obj):
        raise TypeException(f"Cannot convert {type(obj).__name__} to {getattr(new_type, '__name__', new_type)}")
    return handler


def transform(buffer: Any, obj: Any, target_frame: str, new_type: Any = None, timeout: Any = None) -> Any:
    """obj (any registered_types() message) expressed in target_frame at its own stamp.

    ``buffer`` is anything with tf2's ``lookup_transform(target, source, time[, timeout])``.
    """
    handler = _handler(obj, new_type)
    h = obj.header
    if timeout is None:
        ts = buffer.lookup_transform(target_frame, h.frame_id, h.stamp)
    else:
        ts = buffer.lookup_transform(target_frame, h.frame_id, h.stamp, timeout)
    return handler(obj, ts)


def transform_full(buffer: Any, obj: Any, target_frame: str, target_time: Any, fixed_frame: str,
                   new_type: Any = None, timeout: Any = None) -> Any:
    """Like transform(), through fixed_frame: obj at its stamp, target at target_time."""
    handler = _handler(obj, new_type)
    h = obj.header
    args = (target_frame, target_time, h.frame_id, h.stamp, fixed_frame)
    ts = (buffer.lookup_transform_full(*args) if timeout is None
          else buffer.lookup_transform_full(*args, timeout))
    return handler(obj, ts)
