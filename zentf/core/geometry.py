"""Applying transforms to data: tf2_geometry_msgs' do_transform_* and whole-array (numpy) batches.

``transform_points`` and ``lookup_transforms`` are zentf extras: a point cloud or a stamped
trajectory goes through one numpy pass instead of a Python loop of single lookups, with exactly
the semantics of ``BufferCore.lookup_transform`` at every time (see ``lookup_transforms``).
"""
from __future__ import annotations

import importlib
import logging
import math
from typing import Any, Callable, Optional

import numpy as np

from .constants import MAX_GRAPH_DEPTH
from .exceptions import TransformException, TypeException
from .math3d import (matrix_from_quaternion, matrix_from_quaternion_batch, quaternion_from_matrix,
                     quaternion_multiply)
from .messages import (Header, Point, PointStamped, Pose, PoseStamped, PoseWithCovariance, PoseWithCovarianceStamped,
                       Quaternion, QuaternionStamped, Transform, TransformStamped, Twist, TwistStamped, Vector3,
                       Vector3Stamped, Wrench, WrenchStamped)
from .time import Time, ns_from_sec_array

__all__ = [
    "do_transform_point", "do_transform_vector3", "do_transform_vector", "do_transform_pose",
    "do_transform_pose_stamped", "do_transform_pose_with_covariance", "do_transform_quaternion",
    "do_transform_transform", "do_transform_wrench", "do_transform_twist", "transform_covariance", "transform", "transform_full", "transform_points", "lookup_transforms",
    "registered_types",
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


# ------------------------------------------------------------------------ vectorized extras

def transform_points(core: Any, points: Any, target_frame: str, source_frame: str, time: Any) -> np.ndarray:
    """points[N,3] in source_frame -> [N,3] in target_frame at time (one lookup, one matmul)."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
    ts = core.lookup_transform(target_frame, source_frame, time)
    m, t = _rot_trans(ts)
    return pts @ np.asarray(m).T + np.asarray(t)


def _times_ns(times: Any) -> np.ndarray:
    """Times as int64 ns: Time objects, float seconds, or an integer numpy array of ns."""
    if isinstance(times, np.ndarray):
        if times.dtype.kind in "iu":
            out = times.astype(np.int64, copy=False)
        elif times.dtype.kind == "f":
            out = ns_from_sec_array(times)  # ROS's whole seconds + rounded fraction, per element
        else:
            out = np.array([_one_ns(t) for t in times.ravel()], dtype=np.int64)
    else:
        out = np.array([_one_ns(t) for t in times], dtype=np.int64)
    out = out.ravel()
    if out.size and out.min() < 0:
        raise ValueError("times cannot be negative")
    return out


def _one_ns(t: Any) -> int:
    if isinstance(t, Time):
        return t.nanoseconds
    return Time.from_sec(t).nanoseconds


_CHUNK = 8192    # times per vectorized pass: the working set (~45 rows of 8k floats) stays near L2

# Taylor coefficients of sin(x)/x and cos(x) in x²: slerp phases are at most π/2, and the number
# of terms is picked per link from the largest phase so the truncation error stays below 1e-16
# (a polynomial costs ~2 ns per time where np.sin/np.cos cost ~15 ns each).
_SIN = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(14)]
_COS = [(-1.0) ** k / math.factorial(2 * k) for k in range(14)]


def _terms(theta: float) -> int:
    """Taylor terms so that θ^(2K)/(2K)! (which bounds both remainders for θ ≤ π/2) is below
    1e-16, under the rounding of a unit quaternion's components."""
    k = 1
    while k < 13 and theta ** (2 * k) / math.factorial(2 * k) >= 1e-16:
        k += 1
    return k


# Row layout of a link value (9 rows): px, py, pz, qw, qx, qy, qz, qx, qy — the x, y rows are
# repeated after z so that a cross product is two multiplies of shifted row views.
# An accumulator has 11 rows: sx, sy, sz, sx, sy, then the same 6 quaternion rows.


class _Tables:
    """One frame's samples as per-interval slerp/lerp constants for vectorized queries.

    Row j of ``k`` (j < m - 1) interpolates from sample j to sample j + 1; the last row is the
    newest sample itself (tf2 returns it as is at its stamp). Stamps are kept as float ns relative
    to ``base`` (exact below 2^53 ns). With x = (t - st[j])·ω the value is
    p0 + (t - st[j])·vel and q0·cos x + a·sin x (tf2's slerp rewritten: one sin, one cos).
    Intervals across a parent switch, and zero angles, have ω = vel = a = 0 (the older sample).
    """

    __slots__ = ("m", "st", "par", "uniform", "k", "theta", "static", "first_stamp", "last_stamp",
                 "last_parent", "unit")

    def __init__(self, cache: Any, base: int) -> None:
        if cache.is_static:
            s = cache.sample
            self.m = -1                       # static: one sample valid at every time
            self.uniform = s[0]
            v = np.empty((9, 1))
            v[0:7, 0] = (s[1], s[2], s[3], s[7], s[4], s[5], s[6])
            v[7:9] = v[4:6]
            self.static = v
            self.unit = abs(s[4] ** 2 + s[5] ** 2 + s[6] ** 2 + s[7] ** 2 - 1.0) <= _UNIT_TOL
            return
        st, par, d = cache.columns()   # copies, oldest first
        m = self.m = st.shape[0]
        self.st = st
        if m == 0:
            return
        par = par.astype(np.int64)
        self.par = par
        self.uniform = int(par[0]) if (par == par[0]).all() else None
        self.last_parent = int(par[m - 1])
        self.first_stamp, self.last_stamp = int(st[0]), int(st[m - 1])
        k = np.zeros((16, m))     # stamp - base, ω, p0 (3), vel (3), q0 (w, x, y, z), a (w, x, y, z)
        k[0] = st - base
        k[2:5] = d[:, :3].T
        k[8] = d[:, 6]
        k[9:12] = d[:, 3:6].T
        theta = np.zeros(m)
        if m > 1:
            p0, p1 = d[:-1], d[1:]
            q0, q1 = p0[:, 3:], p1[:, 3:]
            dot = np.einsum("ij,ij->i", q0, q1)
            c = np.abs(dot) / np.sqrt(np.einsum("ij,ij->i", q0, q0) * np.einsum("ij,ij->i", q1, q1))
            th = np.arccos(np.minimum(c, 1.0))
            same = par[:-1] == par[1:]        # parents differ: the older sample applies as is
            th[~same] = 0.0
            live = th != 0.0
            dt = (st[1:] - st[:-1]).astype(float)
            k[5:8, :-1] = np.where(same, (p1[:, :3] - p0[:, :3]).T / dt, 0.0)
            k[1, :-1] = th / dt
            sin_th = np.where(live, np.sin(th), 1.0)
            sgn = np.where(dot < 0, -1.0, 1.0)
            a = (q1 * sgn[:, None] - q0 * np.cos(th)[:, None]) / sin_th[:, None]   # x, y, z, w
            a[~live] = 0.0
            k[12, :-1] = a[:, 3]
            k[13:16, :-1] = a[:, :3].T
            theta[:-1] = th
        self.k = k
        self.theta = theta
        # unit samples interpolate to unit quaternions (|q0 cos x + a sin x|² = 1, a ⊥ q0), so the
        # cheaper rotation formula agrees with q·v·q* to ~1e-15 relative
        self.unit = bool((np.abs(np.einsum("ij,ij->i", d[:, 3:], d[:, 3:]) - 1.0) <= _UNIT_TOL).all())

    def query(self, t: np.ndarray, tf: np.ndarray, t_sorted: bool,
              has_zero: bool) -> tuple[Optional[np.ndarray], Any, np.ndarray]:
        """t (int ns) and tf (float ns - base) -> (ok mask or None if all ok, parent (int or array), link value rows (9, n) or (9, 1))."""
        m = self.m
        if m == -1:
            return None, self.uniform, self.static
        n = t.shape[0]
        if m == 0:
            return np.zeros(n, bool), 0, _IDENTITY9
        if has_zero:                      # time 0 (all-static chain: latest common time 0) = newest
            zero = t == 0
            t = np.where(zero, self.last_stamp, t)
            tf = np.where(zero, float(self.k[0, m - 1]), tf)
            t_sorted = False
        if t_sorted and self.first_stamp <= t[0] and t[n - 1] <= self.last_stamp:
            # sorted times map to runs of one interval: count each run and repeat the constants
            pos = np.searchsorted(t, self.st, side="left")
            counts = np.empty(m, np.int64)
            np.subtract(pos[1:], pos[:-1], out=counts[:-1])
            counts[m - 1] = n - pos[m - 1]
            g = np.repeat(self.k, counts, axis=1)
            parent: Any = self.uniform if self.uniform is not None else np.repeat(self.par, counts)
            theta = float(self.theta[counts > 0].max())
            ok = None
        else:
            i = np.searchsorted(self.st, t, side="right") - 1
            good = (i >= 0) & (t <= self.last_stamp)
            ok = None if good.all() else good
            np.clip(i, 0, m - 1, out=i)
            g = np.take(self.k, i, axis=1)
            parent = self.uniform if self.uniform is not None else self.par[i]
            theta = float(self.theta[i].max())
        v = np.empty((9, n))
        rr = np.subtract(tf, g[0], out=g[0])                # t - stamp, exact
        x = np.multiply(rr, g[1], out=g[1])                 # phase
        vel = g[5:8]
        vel *= rr
        np.add(g[2:5], vel, out=v[0:3])
        kt = _terms(theta)
        if kt == 1:                                         # every phase is 0: no rotation change
            v[3:7] = g[8:12]
        else:
            x2 = np.multiply(x, x, out=g[2])
            sp = np.multiply(x2, _SIN[kt - 1])
            cp = np.multiply(x2, _COS[kt - 1])
            for j in range(kt - 2, 0, -1):
                sp += _SIN[j]
                sp *= x2
                cp += _COS[j]
                cp *= x2
            sp += 1.0
            sp *= x
            cp += 1.0
            q = v[3:7]
            np.multiply(g[8:12], cp, out=q)
            tmp = np.multiply(g[12:16], sp, out=g[12:16])
            q += tmp
        v[7:9] = v[4:6]
        return ok, parent, v


_OUT_ROWS = [0, 1, 2, 6, 7, 8, 5]    # accumulator rows -> tx, ty, tz, qx, qy, qz, qw
_LINK_ROWS = [0, 1, 2, 5, 6, 7, 8, 9, 10]  # accumulator rows -> link value rows
_IDENTITY9 = np.array([[0.0], [0.0], [0.0], [1.0], [0.0], [0.0], [0.0], [0.0], [0.0]])


def _set_acc(acc: np.ndarray, v: np.ndarray) -> None:
    """acc = v (link rows to accumulator rows)."""
    acc[0:3] = v[0:3]
    acc[3:5] = v[0:2]
    acc[5:11] = v[3:9]


_UNIT_TOL = 4e-15     # |q|² - 1 of a stored quaternion for the unit-norm rotation formula


def _compose(acc: np.ndarray, v: np.ndarray, unit: bool = False) -> None:
    """acc = v ∘ acc in place, exactly tf2's accum: s' = quatRotate(q, s) + p (q·s·q*, no unit
    norm assumed unless ``unit``), q' = q·q_acc. v may be (9, 1) (a static link): rows broadcast."""
    n = acc.shape[1]
    u5 = v[4:9]
    u = v[4:7]
    w = v[3:4]
    s5 = acc[0:5]
    s = acc[0:3]
    a5 = np.empty((5, n))
    av = a5[0:3]
    t3 = np.empty((3, n))
    if unit:
        # |q| = 1: q·s·q* = s + w·c + u × c with c = 2·(u × s) (13 fewer row passes)
        np.multiply(u5[1:4], s5[2:5], out=av)
        np.multiply(u5[2:5], s5[1:4], out=t3)
        av -= t3
        av *= 2.0
        a5[3:5] = a5[0:2]
        np.multiply(w, av, out=t3)
        s += t3
        np.multiply(u5[1:4], a5[2:5], out=t3)
        s += t3
        np.multiply(u5[2:5], a5[1:4], out=t3)
        s -= t3
        s += v[0:3]
        s5[3:5] = s5[0:2]
        _qmul(acc, v, av, t3)
        return
    # a = q·(0, s): vector w·s + u × s, scalar -(u·s)
    np.multiply(u5[1:4], s5[2:5], out=av)
    np.multiply(u5[2:5], s5[1:4], out=t3)
    av -= t3
    np.multiply(w, s, out=t3)
    av += t3
    a5[3:5] = a5[0:2]
    np.multiply(u, s, out=t3)
    dot = t3[0] + t3[1]
    dot += t3[2]
    # s' = (a·q*).vector + p = w·a + u × a + (u·s)·u + p
    np.multiply(w, av, out=s)
    np.multiply(u5[1:4], a5[2:5], out=t3)
    s += t3
    np.multiply(u5[2:5], a5[1:4], out=t3)
    s -= t3
    np.multiply(dot, u, out=t3)
    s += t3
    s += v[0:3]
    s5[3:5] = s5[0:2]
    _qmul(acc, v, av, t3)


def _qmul(acc: np.ndarray, v: np.ndarray, cr: np.ndarray, t3: np.ndarray) -> None:
    """acc's quaternion = v's · acc's (cr, t3: scratch rows)."""
    u5 = v[4:9]
    u = v[4:7]
    w = v[3:4]
    # q' = q·Q: vector w·V + W·u + u × V, scalar w·W - u·V
    qv5 = acc[6:11]
    qv = acc[6:9]
    ww = acc[5]
    np.multiply(u5[1:4], qv5[2:5], out=cr)
    np.multiply(u5[2:5], qv5[1:4], out=t3)
    cr -= t3
    np.multiply(ww, u, out=t3)
    cr += t3
    np.multiply(u, qv, out=t3)
    dot = t3[0] + t3[1]
    dot += t3[2]
    ww *= w[0]
    ww -= dot
    qv *= w
    qv += cr
    acc[9:11] = acc[6:8]


def _identity_acc(n: int) -> np.ndarray:
    acc = np.zeros((11, n))
    acc[5] = 1.0
    return acc


def _inverse_acc(acc: np.ndarray) -> np.ndarray:
    """tf2's inverse (q* and quatRotate(q*, -t)) of accumulator rows, as a link value (9 rows)."""
    n = acc.shape[1]
    conj = np.empty((9, n))
    conj[0:3] = 0.0
    conj[3] = acc[5]
    np.negative(acc[6:11], out=conj[4:9])
    out = _identity_acc(n)
    np.negative(acc[0:5], out=out[0:5])
    _compose(out, conj)
    v = np.empty((9, n))
    v[0:3] = out[0:3]
    v[3:9] = out[5:11]
    return v


class _Walk:
    """One side of tf2's walk for a set of times, vectorized; frames may differ per time."""

    def __init__(self, tables: Callable[[int], Optional[_Tables]], t: np.ndarray, base: int,
                 t_sorted: bool) -> None:
        self.tables = tables
        self.t = t
        self.tf = (t - base).astype(float)
        self.t_sorted = t_sorted
        self.has_zero = bool(t[0] == 0) if t_sorted else bool((t == 0).any())

    def run(self, start: int, stop_at: Any, early_out: int, source_side: bool, max_depth: int) -> dict:
        """Walk up from `start`; stop where the frame equals stop_at (array per time) when the
        target side walks, at roots, at failed queries, or at early_out (after its query).
        Returns per-time arrays: acc (11, n), frame, top, failed, early, looped, and any (whether
        any link was composed at all: if not, acc is the identity)."""
        t = self.t
        n = t.shape[0]
        frame = np.full(n, start, np.int64)
        top = frame.copy()
        acc = _identity_acc(n)
        started = np.zeros(n, bool)
        none_started = True
        failed = np.zeros(n, bool)
        early = np.zeros(n, bool)
        active = np.ones(n, bool) if stop_at is None else frame != stop_at
        depth = 0
        while True:
            act = np.flatnonzero(active)
            if act.size == 0:
                break
            depth += 1
            if depth > max_depth + 1:
                return dict(acc=acc, frame=frame, top=top, failed=failed, early=early, looped=True,
                            any=not none_started)
            fr = frame[act]
            f0 = int(fr[0])
            groups = [(f0, act)] if (fr == f0).all() else [(int(f), act[fr == f]) for f in np.unique(fr)]
            for fid, idx in groups:
                whole = idx.size == n
                tab = self.tables(fid)
                if tab is None:                      # a root: no cache
                    if source_side:
                        top[idx] = fid
                    active[idx] = False
                    continue
                ok, parent, vals = (tab.query(t, self.tf, self.t_sorted, self.has_zero) if whole else
                                    tab.query(t[idx], self.tf[idx], self.t_sorted, self.has_zero))
                if ok is not None:
                    bad = idx[~ok]
                    failed[bad] = True
                    if source_side:
                        top[bad] = fid
                    active[bad] = False
                    keep = np.flatnonzero(ok)
                    idx = idx[keep]
                    whole = False
                    if vals.shape[1] > 1:
                        vals = vals[:, keep]
                    if np.ndim(parent):
                        parent = parent[keep]
                    if idx.size == 0:
                        continue
                if fid == early_out:
                    early[idx] = True
                    active[idx] = False
                    continue
                if whole and none_started:
                    _set_acc(acc, vals)
                elif whole and started.all():
                    _compose(acc, vals)
                else:
                    sub = acc[:, idx]
                    first = ~started[idx]
                    _compose(sub, vals)
                    if first.any():
                        init = _identity_acc(idx.size)
                        _set_acc(init, vals)
                        sub[:, first] = init[:, first]
                    acc[:, idx] = sub
                started[idx] = True
                none_started = False
                if source_side:
                    top[idx] = fid
                frame[idx] = parent
                if stop_at is not None:
                    active[idx] = frame[idx] != stop_at[idx]
        return dict(acc=acc, frame=frame, top=top, failed=failed, early=early, looped=False,
                    any=not none_started)


def _fast_chain(tables: Callable[[int], Optional["_Tables"]], t: np.ndarray, tf: np.ndarray, t_sorted: bool,
                source_id: int, target_id: int, depth_limit: int) -> Optional[np.ndarray]:
    """The common case, without per-time masks: every frame on both walks has one parent over its
    whole buffer and every query succeeds at every time. Returns the result's accumulator rows,
    or None for the general walk (which also produces the errors)."""
    n = t.shape[0]

    def walk(start: int, stop: int, early_out: int) -> Optional[tuple]:
        # static links are composed once, into `pending` (one column), and applied to the per-time
        # accumulator when the next dynamic link (or the end) comes: composition is associative
        acc: Optional[np.ndarray] = None
        pending: Optional[np.ndarray] = None
        pending_unit = True

        def flush() -> Optional[np.ndarray]:
            if pending is None:
                return acc
            if acc is None:
                return np.repeat(pending, n, axis=1)
            _compose(acc, pending[_LINK_ROWS], pending_unit)
            return acc

        f = start
        steps = 0
        while f != stop:
            tab = tables(f)
            if tab is None:                       # a root
                return flush(), f, False
            if tab.m == 0 or (tab.m > 0 and tab.uniform is None):
                return None                       # no data, or a parent switch: general walk
            ok, parent, v = tab.query(t, tf, t_sorted, False)
            if ok is not None:
                return None
            if f == early_out:                    # tf2 queries it (it must be available) first
                return flush(), f, True
            if v.shape[1] == 1:                   # static
                if pending is None:
                    pending = np.empty((11, 1))
                    _set_acc(pending, v)
                else:
                    _compose(pending, v, tab.unit)
                pending_unit = pending_unit and tab.unit
            elif acc is None:
                acc = np.empty((11, n))
                if pending is None:
                    _set_acc(acc, v)
                else:
                    acc[:] = pending
                    _compose(acc, v, tab.unit)
                pending = None
            else:
                if pending is not None:
                    _compose(acc, pending[_LINK_ROWS], pending_unit)
                    pending = None
                _compose(acc, v, tab.unit)
            pending_unit = pending_unit if pending is not None else True
            f = parent
            steps += 1
            if steps > depth_limit:
                return None
        return flush(), f, False

    src = walk(source_id, -1, target_id)
    if src is None:
        return None
    s_acc, top, early = src
    if early:
        return s_acc
    tgt = walk(target_id, top, source_id)
    if tgt is None:
        return None
    t_acc, end, early = tgt
    if early:
        res = _identity_acc(n)
        _set_acc(res, _inverse_acc(t_acc))
        return res
    if end != top:
        return None                               # not connected: the general walk raises
    if s_acc is None:
        s_acc = _identity_acc(n)
    if t_acc is not None:
        _compose(s_acc, _inverse_acc(t_acc))      # inv(target) ∘ source
    return s_acc


# numba path: None = not tried yet, False = numba missing (or disabled), else the compiled kernel.
# USE_NUMBA = False forces the numpy path (tests run both).
USE_NUMBA = True
_kernel: Any = None


def _numba_kernel() -> Any:
    """The compiled chain kernel, or None without numba (imported on first use, not at import zentf)."""
    global _kernel
    if not USE_NUMBA:
        return None
    if _kernel is None:
        try:
            _kernel = importlib.import_module(__package__ + "._chain_kernel")
        except ImportError:
            _kernel = False
        except Exception as e:        # numba present but unusable (e.g. no writable cache dir)
            logging.getLogger(__name__).debug("numba kernel unavailable, numpy path: %s", e)
            _kernel = False
    return _kernel or None


def fast_path() -> str:
    """Which implementation lookup_transforms uses for plain chains: "numba" or "numpy"."""
    return "numba" if _numba_kernel() is not None else "numpy"


def _plan_chain(tables: Callable[[int], Optional["_Tables"]], t: np.ndarray, source_id: int, target_id: int,
                depth_limit: int) -> Optional[tuple]:
    """_fast_chain's walks without the arithmetic, for the compiled kernel: returns (links, n_src,
    mode) with links as (tables, j0, j1) slices of interval constants or (None, value (7,), unit)
    for folded static runs; None where _fast_chain would return None."""
    t0, t1 = int(t[0]), int(t[-1])

    def walk(start: int, stop: int, early_out: int) -> Optional[tuple]:
        links: list = []
        pending: Optional[np.ndarray] = None
        pending_unit = True

        def flush() -> None:
            if pending is not None:
                links.append((None, pending[[0, 1, 2, 5, 6, 7, 8]].ravel(), pending_unit))

        f = start
        steps = 0
        while f != stop:
            tab = tables(f)
            if tab is None:
                flush()
                return links, f, False
            if tab.m == 0 or (tab.m > 0 and tab.uniform is None):
                return None
            if tab.m > 0 and not (tab.first_stamp <= t0 and t1 <= tab.last_stamp):
                return None
            if f == early_out:
                flush()
                return links, f, True
            if tab.m == -1:
                if pending is None:
                    pending = np.empty((11, 1))
                    _set_acc(pending, tab.static)
                else:
                    _compose(pending, tab.static, tab.unit)
                pending_unit = pending_unit and tab.unit
                f = tab.uniform
            else:
                flush()
                pending, pending_unit = None, True
                j0 = int(np.searchsorted(tab.st, t0, side="right")) - 1
                j1 = int(np.searchsorted(tab.st, t1, side="right"))
                links.append((tab, j0, j1))
                f = tab.uniform
            steps += 1
            if steps > depth_limit:
                return None
        flush()
        return links, f, False

    src = walk(source_id, -1, target_id)
    if src is None:
        return None
    s_links, top, early = src
    if early:
        return s_links, len(s_links), 1
    tgt = walk(target_id, top, source_id)
    if tgt is None:
        return None
    t_links, end, early = tgt
    if early:
        return t_links, 0, 2
    if end != top:
        return None
    return s_links + t_links, len(s_links), 0


def _run_kernel(kern: Any, plan: tuple, tf: np.ndarray) -> np.ndarray:
    """Gather the planned links' interval constants (only the intervals this chunk touches) and
    run the compiled kernel: (7, n) rows tx, ty, tz, qx, qy, qz, qw."""
    links, n_src, mode = plan
    n_links = len(links)
    off = np.zeros(n_links, np.int64)
    cnt = np.zeros(n_links, np.int64)
    kt = np.ones(n_links, np.int64)
    unit = np.zeros(n_links, np.bool_)
    cval = np.zeros((max(n_links, 1), 7))
    parts = []
    total = 0
    for li, link in enumerate(links):
        tab = link[0]
        if tab is None:
            cval[li] = link[1]
            unit[li] = link[2]
            continue
        j0, j1 = link[1], link[2]
        parts.append(tab.k[:, j0:j1])
        off[li] = total
        cnt[li] = j1 - j0
        total += j1 - j0
        kt[li] = _terms(float(tab.theta[j0:j1].max()))
        unit[li] = tab.unit
    # one row of 16 constants per interval (two cache lines), links one after another
    k = np.concatenate([p.T for p in parts]) if parts else np.zeros((1, 16))
    out = np.empty((7, tf.shape[0]))
    kern.chain_kernel(tf, k, off, cnt, kt, unit, cval, n_src, mode, kern._SIN, kern._COS, out)
    return out


def lookup_transforms(core: Any, target_frame: str, source_frame: str, times: Any) -> tuple[np.ndarray, np.ndarray]:
    """lookup_transform at every time of times[N] in one vectorized pass.

    Returns (translations[N,3], quaternions[N,4] as x, y, z, w), transposed views of one (7, N)
    array (column-major; ``np.ascontiguousarray`` if C order matters). ``times`` is a sequence of
    ``Time`` or float seconds, or an integer numpy array of nanoseconds; 0 means the latest
    common time, as in a single lookup. Parent switches over the series are honoured (each time
    walks the tree as it was then). If the lookup fails at any time, the exception a single
    ``lookup_transform`` raises at the earliest failing position is raised and nothing is returned.
    The buffer lock is held per chunk of 8k times, not for the whole call.

    Cost: with numba installed (the ``fast`` extra) a chain where every frame keeps one parent and
    every time is inside every buffer runs in one compiled pass per time (``fast_path()`` tells
    which path is in use; the first call compiles, or loads numba's on-disk cache). Otherwise, and
    for parent switches, time 0 and errors, numpy passes: per chain link and time about 115 passes
    over one float row (interval constants gathered by run length, Taylor slerp, in-place
    quaternion compose): ~35-40 ns on a 2-core EPYC, against ~2-3 µs per link for a single
    lookup. See bench/lookup.py.
    """

    t_all = _times_ns(times)
    n_all = t_all.shape[0]
    out = np.empty((7, n_all))    # rows: the results are returned as transposed views
    with core._lock:
        if target_frame == source_frame:
            out[:] = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])[:, None]
            return out[0:3].T, out[3:7].T
        target_id = core._validate("lookupTransform argument target_frame", target_frame)
        source_id = core._validate("lookupTransform argument source_frame", source_frame)
    any_zero = bool((t_all == 0).any())
    kern = _numba_kernel()
    cache_tables: dict[int, Optional[_Tables]] = {}

    def tables(fid: int) -> Optional[_Tables]:
        if fid not in cache_tables:
            c = core._caches[fid]
            cache_tables[fid] = None if c is None else _Tables(c, base)
        return cache_tables[fid]

    def replay(bad: np.ndarray, t_asked: np.ndarray) -> None:
        # the single lookup at the first failing time raises tf2's exact exception
        for k in np.flatnonzero(bad).tolist():
            core._lookup(target_frame, source_frame, int(t_asked[k]))
        raise TransformException("vectorized lookup disagreed with the single lookup")  # pragma: no cover

    version = None
    base = 0              # stamps become float ns relative to base: exact within ±2^50 ns
    lct: Optional[int] = None
    lct_error = False
    for lo in range(0, n_all, _CHUNK):
        # the lock is taken per chunk so a listener is never held up for a whole batch; a chunk
        # sees one consistent state, and data that changed in between is picked up (like a loop
        # of single lookups would)
        with core._lock:
            if core._version != version:
                version = core._version
                cache_tables.clear()
                lct, lct_error = None, False
                if any_zero:
                    try:
                        lct = core._latest_common_time(target_id, source_id)
                    except TransformException:
                        lct_error = True
            t_asked = t_all[lo:lo + _CHUNK]
            n = t_asked.shape[0]
            zero = t_asked == 0
            lct_bad = zero if lct_error else np.zeros(n, bool)  # these raise like a single lookup
            t = np.where(zero, 1 if lct is None else lct, t_asked) if zero.any() else t_asked
            t_sorted = bool((t[1:] >= t[:-1]).all())
            nz = t[t != 0] if (t[0] == 0 if t_sorted else zero.any() or (t == 0).any()) else t
            if nz.size and (abs(int(nz.min()) - base) >= 1 << 50 or abs(int(nz.max()) - base) >= 1 << 50):
                base = int(nz.min())
                cache_tables.clear()
            # a walk longer than the number of frames must be going round a loop: stop there and
            # let the single lookup produce tf2's loop error (it walks MAX_GRAPH_DEPTH steps)
            depth_limit = min(MAX_GRAPH_DEPTH, len(core._caches))
            walk = _Walk(tables, t, base, t_sorted)
            res_acc = None
            rows = None
            order = None
            if not walk.has_zero and not (lct_error and zero.any()) and kern is not None:
                # the compiled kernel: one pass per time over the whole chain
                order = None if t_sorted else np.argsort(t, kind="stable")
                ts = t if order is None else t[order]
                plan = _plan_chain(tables, ts, source_id, target_id, depth_limit)
                if plan is not None:
                    rows = _run_kernel(kern, plan, walk.tf if order is None else walk.tf[order])
                    res_acc = rows
                else:
                    order = None
            if rows is None and not walk.has_zero and not (lct_error and zero.any()):
                if t_sorted:
                    res_acc = _fast_chain(tables, t, walk.tf, True, source_id, target_id, depth_limit)
                else:   # sorted, every link's intervals are runs: sorting once beats gathering per link
                    order = np.argsort(t, kind="stable")
                    res_acc = _fast_chain(tables, t[order], walk.tf[order], True, source_id, target_id,
                                          depth_limit)
            if res_acc is None:
                order = None
                src = walk.run(source_id, None, target_id, True, depth_limit)
                ends_at_target = src["early"]
                top = src["top"]
                tgt = walk.run(target_id, np.where(ends_at_target, target_id, top), source_id, False, depth_limit)
                ends_at_source = tgt["early"]
                full = ~ends_at_target & ~ends_at_source
                broken = tgt["failed"] | (full & (tgt["frame"] != top)) | lct_bad
                if src["looped"] or tgt["looped"] or broken.any():
                    replay(broken | np.full(n, src["looped"] or tgt["looped"]), t_asked)
        if res_acc is None:
            s_acc, t_acc = src["acc"], tgt["acc"]
            if not tgt["any"]:
                res_acc = s_acc                   # the target is the top: inv(identity) ∘ source
            else:
                res_acc = s_acc.copy()
                if full.all():
                    _compose(res_acc, _inverse_acc(t_acc))      # inv(target) ∘ source
                elif full.any():
                    sub = res_acc[:, full]
                    _compose(sub, _inverse_acc(t_acc[:, full]))
                    res_acc[:, full] = sub
                if ends_at_source.any():
                    inv = _inverse_acc(t_acc[:, ends_at_source])
                    ident = _identity_acc(inv.shape[1])
                    _set_acc(ident, inv)
                    res_acc[:, ends_at_source] = ident
        if rows is None:
            rows = res_acc[_OUT_ROWS]
        if order is None:
            out[:, lo:lo + n] = rows
        else:
            out[:, lo:lo + n][:, order] = rows
    return out[0:3].T, out[3:7].T


def transform_points_series(core: Any, points: Any, target_frame: str, source_frame: str, times: Any) -> np.ndarray:
    """points[N,3] each stamped times[N] (a trajectory) -> target_frame, one vectorized pass."""
    pts = np.asarray(points, dtype=float)
    v, q = lookup_transforms(core, target_frame, source_frame, times)
    if pts.shape != v.shape:
        raise ValueError(f"points must have shape ({v.shape[0]}, 3), got {pts.shape}")
    m = matrix_from_quaternion_batch(q)
    return np.einsum("nij,nj->ni", m, pts) + v
