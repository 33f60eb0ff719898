"""lookup_velocity: ROS 2 tf2's ``BufferCore::lookupVelocity``, step by step, on zentf's BufferCore.

The twist comes from two lookups of observation_frame <- tracking_frame around ``time``: the
window is ``end = min(time + interval/2, latest common time)``, ``start = max(1e-5 s + interval,
end) - interval`` (so it slides back from the newest data instead of extrapolating), linear
velocity is the change of origin over the window, angular velocity the axis-angle of
``start⁻¹ · end`` (axis taken back to the observation frame) over the window. The result is then
re-expressed with the reference_frame <- tracking_frame transform at ``time`` (rotation, plus
``origin × angular`` for the linear part) and moved to the reference point.

Kept exactly as ROS 2 computes it, including two conventions worth knowing (ROS 1 tf's
``lookupTwist`` had them too): the re-expression uses the tracking frame's rotation, so for a
tracking frame that rotates relative to the observation frame the vectors are turned by that
rotation once more; and the reference-point correction multiplies angular velocity and offset
element by element (tf2's ``Vector3 * Vector3``), not as a cross product. With the short form's
defaults the correction is zero. Two zentf choices: ``time`` = 0 (latest) means the latest common
time, as ROS 1 tf did (ROS 2 would take 0 s literally and extrapolate), and the window is computed
in integer nanoseconds rather than float seconds.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

from .exceptions import InvalidArgumentException
from .messages import Header, Twist, Vector3, VelocityStamped
from .rotation import matrix_from_quaternion, quaternion_from_matrix
from .time import Duration, Time, ns_from_sec, to_duration

__all__ = ["lookup_velocity", "lookup_velocity_full"]

_WINDOW_FLOOR_NS = 10_000   # ROS 2's 0.00001 s: the window never starts before t = 10 µs
_EPS = 2.220446049250313e-16  # TF2SIMD_EPSILON (DBL_EPSILON)


def _basis_origin(core: Any, target: str, source: str, t: int) -> tuple[list[list[float]], tuple[float, float, float]]:
    ts = core.lookup_transform(target, source, Time(nanoseconds=t))
    q, v = ts.transform.rotation, ts.transform.translation
    return matrix_from_quaternion((q.x, q.y, q.z, q.w)), (v.x, v.y, v.z)


def _mul(m: list[list[float]], v: Sequence[float]) -> tuple[float, float, float]:
    return (m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
            m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2])


def _cross(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _point(p: Any) -> tuple[float, float, float]:
    if hasattr(p, "x"):
        return (float(p.x), float(p.y), float(p.z))
    x, y, z = p
    return (float(x), float(y), float(z))


def lookup_velocity(core: Any, tracking_frame: str, observation_frame: str, time: Any,
                    averaging_interval: Any) -> VelocityStamped:
    """Twist of tracking_frame seen from observation_frame (ROS 2 tf2 lookupVelocity, short form)."""
    return lookup_velocity_full(core, tracking_frame, observation_frame, observation_frame, (0.0, 0.0, 0.0),
                                tracking_frame, time, averaging_interval)


def lookup_velocity_full(core: Any, tracking_frame: str, observation_frame: str, reference_frame: str,
                         reference_point: Any, reference_point_frame: str, time: Any,
                         averaging_interval: Any) -> VelocityStamped:
    """ROS 2 tf2 lookupVelocity, full form (reference frame and reference point given)."""
    interval = (averaging_interval.nanoseconds if isinstance(averaging_interval, Duration)
                else to_duration(averaging_interval).nanoseconds)
    if interval <= 0:
        raise InvalidArgumentException(f"averaging_interval must be positive, got {interval} ns")
    rp = _point(reference_point)
    t = time.nanoseconds if isinstance(time, Time) else ns_from_sec(time, "time")
    if t < 0:
        raise InvalidArgumentException(f"time cannot be negative ({time!r})")
    latest = core.get_latest_common_time(observation_frame, tracking_frame).nanoseconds
    if t == 0:
        t = latest
    end = min(t + interval // 2, latest)
    start = max(_WINDOW_FLOOR_NS + interval, end) - interval
    span = (end - start) / 1e9  # ROS 2's corrected_averaging_interval

    sb, so = _basis_origin(core, observation_frame, tracking_frame, start)
    eb, eo = _basis_origin(core, observation_frame, tracking_frame, end)
    rel = [[sum(sb[k][i] * eb[k][j] for k in range(3)) for j in range(3)] for i in range(3)]  # start⁻¹·end
    qx, qy, qz, qw = quaternion_from_matrix(rel)
    s2 = 1.0 - qw * qw
    if s2 < 10.0 * _EPS:  # tf2 Quaternion::getAxis: arbitrary axis for no rotation
        axis = (1.0, 0.0, 0.0)
    else:
        s = math.sqrt(s2)
        axis = (qx / s, qy / s, qz / s)
    angle = 2.0 * math.acos(max(-1.0, min(1.0, qw)))  # tf2 Quaternion::getAngle
    o = _mul(sb, axis)
    twist_vel = ((eo[0] - so[0]) / span, (eo[1] - so[1]) / span, (eo[2] - so[2]) / span)
    w = angle / span
    twist_rot = (o[0] * w, o[1] * w, o[2] * w)

    ib, io = _basis_origin(core, reference_frame, tracking_frame, t)
    out_rot = _mul(ib, twist_rot)
    lin = _mul(ib, twist_vel)
    c = _cross(io, out_rot)
    out_vel = (lin[0] + c[0], lin[1] + c[1], lin[2] + c[2])

    # re-reference about the reference point (element-wise product, exactly as tf2 writes it)
    rp_orig = io  # the tracking origin in reference_frame: the same lookup as above
    rb, ro = _basis_origin(core, reference_frame, reference_point_frame, t)
    rd = _mul(rb, rp)
    rp_desired = (rd[0] + ro[0], rd[1] + ro[1], rd[2] + ro[2])
    delta = (rp_desired[0] - rp_orig[0], rp_desired[1] - rp_orig[1], rp_desired[2] - rp_orig[2])
    out_vel = (out_vel[0] + out_rot[0] * delta[0], out_vel[1] + out_rot[1] * delta[1],
               out_vel[2] + out_rot[2] * delta[2])

    return VelocityStamped(header=Header(Time(nanoseconds=start + interval // 2), reference_frame),
                           body_frame_id=tracking_frame, reference_frame_id=reference_frame,
                           velocity=Twist(Vector3(*out_vel), Vector3(*out_rot)))
