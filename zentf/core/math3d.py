"""Rigid-transform math with tf2's exact conventions (LinearMath), scalar and batched.

The rotation helpers (quaternions, matrices, roll/pitch/yaw) live in ``zentf.core.rotation``, free
of numpy, and are re-exported here; this module adds transforms (compose, inverse, 4x4 matrices)
and the ``*_batch`` functions, which take numpy arrays for whole time series or point clouds.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .rotation import (Quat, Vec3, matrix_from_quaternion, quat_rotate, quaternion_conjugate, quaternion_from_matrix,
                       quaternion_from_rpy, quaternion_inverse, quaternion_multiply, quaternion_normalize,
                       rpy_from_quaternion, slerp)

__all__ = [
    "Quat", "Vec3", "quaternion_from_rpy", "rpy_from_quaternion", "quaternion_multiply",
    "quaternion_inverse", "quaternion_conjugate", "quaternion_normalize", "quat_rotate",
    "compose", "inverse_transform", "slerp", "lerp", "matrix_from_quaternion",
    "quaternion_from_matrix", "matrix_from_transform", "transform_from_matrix",
    "quat_rotate_batch", "quaternion_multiply_batch", "slerp_batch", "matrix_from_quaternion_batch",
]


def compose(t1: Sequence[float], q1: Sequence[float], t2: Sequence[float], q2: Sequence[float]) -> tuple[Vec3, Quat]:
    """(t1,q1)∘(t2,q2): apply the second transform first, then the first."""
    r = quat_rotate(q1, t2)
    return (r[0] + t1[0], r[1] + t1[1], r[2] + t1[2]), quaternion_multiply(q1, q2)


def inverse_transform(t: Sequence[float], q: Sequence[float]) -> tuple[Vec3, Quat]:
    qi = quaternion_inverse(q)
    r = quat_rotate(qi, t)
    return (-r[0], -r[1], -r[2]), qi


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
