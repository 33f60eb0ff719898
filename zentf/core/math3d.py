"""Quaternion and rigid-transform math with tf2's exact conventions (LinearMath), scalar and batched.

Quaternions are (x, y, z, w) tuples, like geometry_msgs. The scalar functions are plain Python on
floats because for one transform they beat numpy by an order of magnitude (bench/lookup.py); the
``*_batch`` functions take numpy arrays for whole time series or point clouds.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = [
    "Quat", "Vec3", "quaternion_from_rpy", "rpy_from_quaternion", "quaternion_multiply",
    "quaternion_inverse", "quaternion_conjugate", "quaternion_normalize", "quat_rotate",
    "compose", "inverse_transform", "slerp", "lerp", "matrix_from_quaternion",
    "quaternion_from_matrix", "matrix_from_transform", "transform_from_matrix",
    "quat_rotate_batch", "quaternion_multiply_batch", "slerp_batch", "matrix_from_quaternion_batch",
]

Quat = tuple[float, float, float, float]
Vec3 = tuple[float, float, float]

_acos, _sin, _cos, _sqrt, _atan2, _asin = math.acos, math.sin, math.cos, math.sqrt, math.atan2, math.asin


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
    """(roll, pitch, yaw) as tf2 ``Matrix3x3::getEulerYPR`` / ``getRPY`` (solution 1)."""
    m = matrix_from_quaternion(q)
    m20 = m[2][0]
    if abs(m20) >= 1.0:
        delta = _atan2(m[2][1], m[2][2])
        return (delta, math.pi / 2.0 if m20 < 0 else -math.pi / 2.0, 0.0)
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


def compose(t1: Sequence[float], q1: Sequence[float], t2: Sequence[float], q2: Sequence[float]) -> tuple[Vec3, Quat]:
    """(t1,q1)∘(t2,q2): apply the second transform first, then the first."""
    r = quat_rotate(q1, t2)
    return (r[0] + t1[0], r[1] + t1[1], r[2] + t1[2]), quaternion_multiply(q1, q2)


def inverse_transform(t: Sequence[float], q: Sequence[float]) -> tuple[Vec3, Quat]:
    qi = quaternion_inverse(q)
    r = quat_rotate(qi, t)
    return (-r[0], -r[1], -r[2]), qi


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


def lerp(a: Sequence[float], b: Sequence[float], t: float) -> Vec3:
    """tf2 ``Vector3::setInterpolate3``: (1−t)·a + t·b."""
    s = 1.0 - t
    return (s * a[0] + t * b[0], s * a[1] + t * b[1], s * a[2] + t * b[2])


def matrix_from_transform(t: Sequence[float], q: Sequence[float]) -> np.ndarray:
    """4x4 homogeneous matrix."""
    m = np.eye(4)
    m[:3, :3] = matrix_from_quaternion(q)
    m[:3, 3] = t
    return m


def transform_from_matrix(m: Sequence[Sequence[float]]) -> tuple[Vec3, Quat]:
    """Inverse of ``matrix_from_transform`` (rotation via tf2's getRotation)."""
    mm = [[float(m[i][j]) for j in range(3)] for i in range(3)]
    return (float(m[0][3]), float(m[1][3]), float(m[2][3])), quaternion_from_matrix(mm)


# ---------------------------------------------------------------- batched (numpy) versions

def quat_rotate_batch(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """q·v·q̄ for q[...,4] and v[...,3] (broadcasting), same algebra as ``quat_rotate``."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    u = q[..., :3]
    w = q[..., 3:4]
    uv = np.cross(u, v)
    # q v q̄ = v (w² − |u|²) + 2 u (u·v) + 2 w (u × v)
    return (v * (w * w - np.sum(u * u, axis=-1, keepdims=True))
            + 2.0 * u * np.sum(u * v, axis=-1, keepdims=True) + 2.0 * w * uv)


def quaternion_multiply_batch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack((aw * bx + ax * bw + ay * bz - az * by,
                     aw * by + ay * bw + az * bx - ax * bz,
                     aw * bz + az * bw + ax * by - ay * bx,
                     aw * bw - ax * bx - ay * by - az * bz), axis=-1)


def slerp_batch(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Element-wise tf2 slerp for q0[N,4], q1[N,4], t[N]."""
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    s = np.sqrt(np.sum(q0 * q0, axis=-1, keepdims=True) * np.sum(q1 * q1, axis=-1, keepdims=True))
    theta = np.arccos(np.clip(np.abs(dot) / s, -1.0, 1.0))
    zero = theta == 0.0
    safe = np.where(zero, 1.0, theta)
    d = 1.0 / np.sin(safe)
    s0 = np.sin((1.0 - t) * safe)
    s1 = np.sin(t * safe) * np.where(dot < 0, -1.0, 1.0)
    out = (q0 * s0 + q1 * s1) * d
    return np.where(zero, q0, out)


def matrix_from_quaternion_batch(q: np.ndarray) -> np.ndarray:
    """[N,3,3] rotation matrices (divides by |q|² like tf2)."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xs, ys, zs = x * s, y * s, z * s
    wx, wy, wz = w * xs, w * ys, w * zs
    xx, xy, xz = x * xs, x * ys, x * zs
    yy, yz, zz = y * ys, y * zs, z * zs
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1.0 - (yy + zz); m[..., 0, 1] = xy - wz; m[..., 0, 2] = xz + wy
    m[..., 1, 0] = xy + wz; m[..., 1, 1] = 1.0 - (xx + zz); m[..., 1, 2] = yz - wx
    m[..., 2, 0] = xz - wy; m[..., 2, 1] = yz + wx; m[..., 2, 2] = 1.0 - (xx + yy)
    return m
