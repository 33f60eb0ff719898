"""Rotations with tf2's LinearMath conventions on plain floats: quaternions, matrices, roll/pitch/yaw.

No numpy here: ``zentf tf echo`` prints through these at start-up, and for one rotation plain
Python beats numpy by an order of magnitude. ``zentf.core.math3d`` re-exports them beside the
rigid-transform and batched (numpy) functions. Quaternions are (x, y, z, w) like geometry_msgs;
matrices are row-major lists of rows.
"""
from __future__ import annotations

import math
from typing import Sequence

__all__ = [
    "Quat", "Vec3", "quaternion_from_rpy", "rpy_from_quaternion", "matrix_from_quaternion",
    "quaternion_from_matrix", "quaternion_multiply", "quaternion_conjugate", "quaternion_inverse",
    "quaternion_normalize", "quat_rotate", "slerp",
]

Quat = tuple[float, float, float, float]
Vec3 = tuple[float, float, float]

_acos, _sin, _cos, _sqrt, _atan2, _asin = math.acos, math.sin, math.cos, math.sqrt, math.atan2, math.asin
_HALF_PI = math.pi / 2.0          # tf2's TF2SIMD_PI / 2.0, the same double


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> Quat:
    """tf2 ``Quaternion::setRPY``: fixed axes X (roll), Y (pitch), Z (yaw), i.e. R = Rz·Ry·Rx."""
    hr, hp, hy = roll * 0.5, pitch * 0.5, yaw * 0.5
    cr, sr, cp, sp, cy, sy = _cos(hr), _sin(hr), _cos(hp), _sin(hp), _cos(hy), _sin(hy)
    return (sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def matrix_from_quaternion(q: Sequence[float]) -> list[list[float]]:
    """3x3 rotation matrix, tf2 ``Matrix3x3::setRotation`` (divides by |q|², so any scale works)."""
    x, y, z, w = q
    d = x * x + y * y + z * z + w * w
    if d == 0.0:
        raise ValueError("cannot build a rotation from a zero quaternion")
    s = 2.0 / d
    xs, ys, zs = x * s, y * s, z * s
    wx, wy, wz = w * xs, w * ys, w * zs
    xx, xy, xz = x * xs, x * ys, x * zs
    yy, yz, zz = y * ys, y * zs, z * zs
    return [[1.0 - (yy + zz), xy - wz, xz + wy],
            [xy + wz, 1.0 - (xx + zz), yz - wx],
            [xz - wy, yz + wx, 1.0 - (xx + yy)]]


def quaternion_from_matrix(m: Sequence[Sequence[float]]) -> Quat:
    """tf2 ``Matrix3x3::getRotation`` (same branch choice, so the same sign as tf2)."""
    trace = m[0][0] + m[1][1] + m[2][2]
    t = [0.0, 0.0, 0.0, 0.0]
    if trace > 0.0:
        s = _sqrt(trace + 1.0)
        t[3] = s * 0.5
        s = 0.5 / s
        t[0] = (m[2][1] - m[1][2]) * s
        t[1] = (m[0][2] - m[2][0]) * s
        t[2] = (m[1][0] - m[0][1]) * s
    else:
        if m[0][0] < m[1][1]:
            i = 2 if m[1][1] < m[2][2] else 1
        else:
            i = 2 if m[0][0] < m[2][2] else 0
        j, k = (i + 1) % 3, (i + 2) % 3
        s = _sqrt(m[i][i] - m[j][j] - m[k][k] + 1.0)
        t[i] = s * 0.5
        s = 0.5 / s
        t[3] = (m[k][j] - m[j][k]) * s
        t[j] = (m[j][i] + m[i][j]) * s
        t[k] = (m[k][i] + m[i][k]) * s
    return (t[0], t[1], t[2], t[3])


def rpy_from_quaternion(q: Sequence[float]) -> tuple[float, float, float]:
    """(roll, pitch, yaw) with R = Rz(yaw)·Ry(pitch)·Rx(roll): tf2's ``Matrix3x3::getRPY`` wherever
    the angles are defined, the rotation's true roll at gimbal lock.

    Off the singularity this is getRPY (solution 1), operation for operation. At it (|R20| = 1,
    pitch ±π/2) only roll − yaw (pitch +π/2) or roll + yaw (pitch −π/2) is defined; like tf2 the
    yaw is 0 there, but tf2 then takes roll = atan2(R21, R22), two entries that are zero at the
    singularity, so its roll is rounding noise. Row 0 is (0, sin(roll − yaw), cos(roll − yaw)) at
    +π/2 and (0, −sin(roll + yaw), −cos(roll + yaw)) at −π/2: the roll read there is the one that,
    with that pitch and yaw 0, rebuilds the rotation.
    """
    m = matrix_from_quaternion(q)
    m20 = m[2][0]
    if m20 <= -1.0:
        return (_atan2(m[0][1], m[0][2]), _HALF_PI, 0.0)
    if m20 >= 1.0:
        return (_atan2(-m[0][1], -m[0][2]), -_HALF_PI, 0.0)
    pitch = -_asin(m20)
    c = _cos(pitch)
    return (_atan2(m[2][1] / c, m[2][2] / c), pitch, _atan2(m[1][0] / c, m[0][0] / c))


def quaternion_multiply(a: Sequence[float], b: Sequence[float]) -> Quat:
    """Hamilton product a·b (apply b first, then a), tf2 ``Quaternion::operator*``."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by + ay * bw + az * bx - ax * bz,
            aw * bz + az * bw + ax * by - ay * bx,
            aw * bw - ax * bx - ay * by - az * bz)


def quaternion_conjugate(q: Sequence[float]) -> Quat:
    return (-q[0], -q[1], -q[2], q[3])


def quaternion_inverse(q: Sequence[float]) -> Quat:
    """tf2 ``Quaternion::inverse`` is the conjugate (no division by the norm); so is this."""
    return (-q[0], -q[1], -q[2], q[3])


def quaternion_normalize(q: Sequence[float]) -> Quat:
    n = _sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n == 0.0:
        raise ValueError("cannot normalize a zero quaternion")
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def quat_rotate(q: Sequence[float], v: Sequence[float]) -> Vec3:
    """tf2 ``quatRotate``: q·v·q̄ (exact for any q, like tf2 — a non-unit q also scales)."""
    x, y, z, w = q
    vx, vy, vz = v
    # t = q * (v, 0)
    tx = w * vx + y * vz - z * vy
    ty = w * vy + z * vx - x * vz
    tz = w * vz + x * vy - y * vx
    tw = -x * vx - y * vy - z * vz
    # t * conj(q)
    return (tw * -x + tx * w + ty * -z - tz * -y,
            tw * -y + ty * w + tz * -x - tx * -z,
            tw * -z + tz * w + tx * -y - ty * -x)


def slerp(q0: Sequence[float], q1: Sequence[float], t: float) -> Quat:
    """tf2 ``Quaternion::slerp``: shortest path, angle from the normalized dot, no renormalization."""
    x0, y0, z0, w0 = q0
    x1, y1, z1, w1 = q1
    dot = x0 * x1 + y0 * y1 + z0 * z1 + w0 * w1
    s = _sqrt((x0 * x0 + y0 * y0 + z0 * z0 + w0 * w0) * (x1 * x1 + y1 * y1 + z1 * z1 + w1 * w1))
    c = (-dot if dot < 0 else dot) / s
    theta = _acos(-1.0 if c < -1.0 else (1.0 if c > 1.0 else c))  # = angleShortestPath / 2
    if theta == 0.0:
        return (x0, y0, z0, w0)
    d = 1.0 / _sin(theta)
    s0 = _sin((1.0 - t) * theta)
    s1 = _sin(t * theta)
    if dot < 0:
        s1 = -s1
    return ((x0 * s0 + x1 * s1) * d, (y0 * s0 + y1 * s1) * d,
            (z0 * s0 + z1 * s1) * d, (w0 * s0 + w1 * s1) * d)
