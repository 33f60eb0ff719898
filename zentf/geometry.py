"""Applying transforms to data: tf2_geometry_msgs' do_transform_* and whole-array (numpy) batches.

``transform_points`` and ``lookup_transforms`` are zentf extras: a point cloud or a stamped
trajectory goes through one numpy pass instead of a Python loop of single lookups, with exactly
the semantics of ``BufferCore.lookup_transform`` at every time (see ``lookup_transforms``).
"""
from __future__ import annotations

from typing import Any, Callable, Optional, Sequence

import numpy as np

from .exceptions import TransformException, TypeException
from .math3d import (matrix_from_quaternion, matrix_from_quaternion_batch, quat_rotate_batch,
                     quaternion_multiply, quaternion_multiply_batch, slerp_batch)
from .messages import (Header, Point, PointStamped, Pose, PoseStamped, Quaternion, TransformStamped,
                       Vector3, Vector3Stamped)
from .time import NSEC_PER_SEC, Time

__all__ = [
    "do_transform_point", "do_transform_vector3", "do_transform_vector", "do_transform_pose",
    "do_transform_pose_stamped", "transform", "transform_full", "transform_points", "lookup_transforms",
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


def do_transform_pose(pose: PoseStamped | Pose, transform: TransformStamped) -> PoseStamped | Pose:
    """Transform a pose: position like a point, orientation composed (q_transform · q_pose)."""
    ps = pose.pose if isinstance(pose, PoseStamped) else pose
    m, t = _rot_trans(transform)
    p = ps.position
    x, y, z = _apply(m, p.x, p.y, p.z)
    r = transform.transform.rotation
    o = ps.orientation
    q = quaternion_multiply((r.x, r.y, r.z, r.w), (o.x, o.y, o.z, o.w))
    out = Pose(position=Point(x + t[0], y + t[1], z + t[2]), orientation=Quaternion(*q))
    return PoseStamped(header=_header(transform), pose=out) if isinstance(pose, PoseStamped) else out


def do_transform_pose_stamped(pose: PoseStamped, transform: TransformStamped) -> PoseStamped:
    return do_transform_pose(pose, transform)  # type: ignore[return-value]


_HANDLERS: dict[type, Callable[[Any, TransformStamped], Any]] = {
    PointStamped: do_transform_point,
    Vector3Stamped: do_transform_vector3,
    PoseStamped: do_transform_pose,
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
    """obj (PointStamped, Vector3Stamped, PoseStamped) expressed in target_frame at its own stamp.

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
            if not np.all(np.isfinite(times)):
                raise ValueError("times must be finite")
            out = np.rint(times * NSEC_PER_SEC).astype(np.int64)
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


def _query(cache: Any, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vectorized cache.get: (ok[N], parent[N], values[N,7]) with tf2's rules at every time."""
    n = t.shape[0]
    if cache.is_static:
        s = cache.sample
        return (np.ones(n, bool), np.full(n, s[0], np.int64), np.broadcast_to(np.asarray(s[1:], float), (n, 7)))
    start = cache.start
    # slicing copies the array.array, so no buffer export pins the cache's storage
    st = np.frombuffer(cache.stamps[start:], dtype=np.int64)
    m = st.shape[0]
    ok = np.zeros(n, bool)
    par = np.zeros(n, np.int64)
    vals = np.zeros((n, 7))
    if m == 0:
        return ok, par, vals
    parents = np.frombuffer(cache.parents[start:], dtype=np.int32)
    data = np.frombuffer(cache.data[7 * start:], dtype=float).reshape(-1, 7)
    t_eff = np.where(t == 0, st[-1], t)
    if m == 1:
        ok = t_eff == st[0]
        par[ok] = parents[0]
        vals[ok] = data[0]
        return ok, par, vals
    ok = (t_eff >= st[0]) & (t_eff <= st[-1])
    i = np.clip(np.searchsorted(st, t_eff, side="right") - 1, 0, m - 2)
    j = i + 1
    exact_new = t_eff == st[-1]
    exact_old = t_eff == st[0]
    p_old = parents[i]
    interp = ok & ~exact_new & ~exact_old & (p_old == parents[j])
    par[ok] = p_old[ok]
    vals[ok] = data[i[ok]]
    if exact_new.any():
        par[exact_new] = parents[m - 1]
        vals[exact_new] = data[m - 1]
    if interp.any():
        ii, jj, tt = i[interp], j[interp], t_eff[interp]
        t0 = st[ii]
        r = (tt - t0) / (st[jj] - t0)
        d0, d1 = data[ii], data[jj]
        out = np.empty((ii.shape[0], 7))
        out[:, :3] = (1.0 - r)[:, None] * d0[:, :3] + r[:, None] * d1[:, :3]
        out[:, 3:] = slerp_batch(d0[:, 3:], d1[:, 3:], r)
        vals[interp] = out
    return ok, par, vals


def _inverse_batch(v: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    qi = q * np.array([-1.0, -1.0, -1.0, 1.0])
    return quat_rotate_batch(qi, -v), qi


def lookup_transforms(core: Any, target_frame: str, source_frame: str, times: Any) -> tuple[np.ndarray, np.ndarray]:
    """lookup_transform at every time of times[N] in one vectorized pass.

    Returns (translations[N,3], quaternions[N,4] as x, y, z, w). ``times`` is a sequence of
    ``Time`` or float seconds, or an integer numpy array of nanoseconds; 0 means the latest
    common time, as in a single lookup. Parent switches over the series are honoured (each time
    walks the tree as it was then). If the lookup fails at any time, the exception a single
    ``lookup_transform`` raises at the earliest failing position is raised and nothing is returned.
    """
    from .buffer_core import MAX_GRAPH_DEPTH

    t = _times_ns(times)
    n = t.shape[0]
    with core._lock:
        if target_frame == source_frame:
            v = np.zeros((n, 3))
            q = np.zeros((n, 4))
            q[:, 3] = 1.0
            return v, q
        target_id = core._validate("lookupTransform argument target_frame", target_frame)
        source_id = core._validate("lookupTransform argument source_frame", source_frame)
        t_asked = t
        lct_failed = np.zeros(n, bool)
        zero = t == 0
        if zero.any():
            try:
                t = np.where(zero, core._latest_common_time(target_id, source_id), t)
            except TransformException:
                lct_failed = zero          # those positions raise like a single lookup would
                t = np.where(zero, 1, t)
        caches = core._caches

        # source walk
        frame = np.full(n, source_id, np.int64)
        top = frame.copy()
        active = np.ones(n, bool)
        extrap = np.zeros(n, bool)
        ends_at_target = np.zeros(n, bool)
        sv = np.zeros((n, 3))
        sq = np.zeros((n, 4))
        sq[:, 3] = 1.0
        depth = 0
        while active.any():
            for fid in np.unique(frame[active]).tolist():
                idx = np.flatnonzero(active & (frame == fid))
                cache = caches[fid]
                if cache is None:
                    top[idx] = fid
                    active[idx] = False
                    continue
                ok, par, vals = _query(cache, t[idx])
                bad = idx[~ok]
                top[bad] = fid
                extrap[bad] = True
                active[bad] = False
                good = idx[ok]
                if fid == target_id:
                    ends_at_target[good] = True
                    active[good] = False
                    continue
                vals = vals[ok]
                sv[good] = quat_rotate_batch(vals[:, 3:], sv[good]) + vals[:, :3]
                sq[good] = quaternion_multiply_batch(vals[:, 3:], sq[good])
                top[good] = fid
                frame[good] = par[ok]
            depth += 1
            if depth > MAX_GRAPH_DEPTH and active.any():
                break

        # target walk
        frame = np.full(n, target_id, np.int64)
        active = ~ends_at_target & (frame != top)
        ends_at_source = np.zeros(n, bool)
        failed = np.zeros(n, bool)
        tv = np.zeros((n, 3))
        tq = np.zeros((n, 4))
        tq[:, 3] = 1.0
        depth2 = 0
        while active.any() and depth2 <= MAX_GRAPH_DEPTH:
            for fid in np.unique(frame[active]).tolist():
                idx = np.flatnonzero(active & (frame == fid))
                cache = caches[fid]
                if cache is None:
                    active[idx] = False
                    continue
                ok, par, vals = _query(cache, t[idx])
                bad = idx[~ok]
                failed[bad] = True
                active[bad] = False
                good = idx[ok]
                if fid == source_id:
                    ends_at_source[good] = True
                    active[good] = False
                    continue
                vals = vals[ok]
                tv[good] = quat_rotate_batch(vals[:, 3:], tv[good]) + vals[:, :3]
                tq[good] = quaternion_multiply_batch(vals[:, 3:], tq[good])
                frame[good] = par[ok]
                active[good] = frame[good] != top[good]
            depth2 += 1

        full = ~ends_at_target & ~ends_at_source
        broken = failed | active | (full & (frame != top)) | (depth > MAX_GRAPH_DEPTH) | lct_failed
        if broken.any():
            # the single lookup at the first failing time raises tf2's exact exception
            for k in np.flatnonzero(broken).tolist():
                core._lookup(target_frame, source_frame, int(t_asked[k]))
            raise TransformException("vectorized lookup disagreed with the single lookup")  # pragma: no cover

        out_v = np.empty((n, 3))
        out_q = np.empty((n, 4))
        out_v[ends_at_target] = sv[ends_at_target]
        out_q[ends_at_target] = sq[ends_at_target]
        if ends_at_source.any():
            iv, iq = _inverse_batch(tv[ends_at_source], tq[ends_at_source])
            out_v[ends_at_source] = iv
            out_q[ends_at_source] = iq
        if full.any():
            iv, iq = _inverse_batch(tv[full], tq[full])
            out_v[full] = quat_rotate_batch(iq, sv[full]) + iv
            out_q[full] = quaternion_multiply_batch(iq, sq[full])
        return out_v, out_q


def transform_points_series(core: Any, points: Any, target_frame: str, source_frame: str, times: Any) -> np.ndarray:
    """points[N,3] each stamped times[N] (a trajectory) -> target_frame, one vectorized pass."""
    pts = np.asarray(points, dtype=float)
    v, q = lookup_transforms(core, target_frame, source_frame, times)
    if pts.shape != v.shape:
        raise ValueError(f"points must have shape ({v.shape[0]}, 3), got {pts.shape}")
    m = matrix_from_quaternion_batch(q)
    return np.einsum("nij,nj->ni", m, pts) + v
