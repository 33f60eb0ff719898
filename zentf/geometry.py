"""Applying transforms to data: tf2_geometry_msgs' do_transform_* and whole-array (numpy) batches.

``transform_points`` and ``lookup_transforms`` are zentf extras: a point cloud or a stamped
trajectory goes through one numpy pass instead of a Python loop of single lookups, with exactly
the semantics of ``BufferCore.lookup_transform`` at every time (see ``lookup_transforms``).
"""
from __future__ import annotations

from typing import Any, Callable, Optional

import numpy as np

from .exceptions import TransformException, TypeException
from .math3d import matrix_from_quaternion, matrix_from_quaternion_batch, quaternion_multiply
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


_CHUNK = 16384   # times per vectorized pass: keeps the working set in cache


class _Tables:
    """One frame's samples as per-interval tables for vectorized queries (built once per call)."""

    __slots__ = ("m", "st", "par", "uniform", "rows", "last", "last_parent", "first_stamp", "last_stamp")

    def __init__(self, cache: Any) -> None:
        if cache.is_static:
            s = cache.sample
            self.m = -1                       # static: one sample valid at every time
            self.uniform = s[0]
            self.last = np.asarray(s[1:], float)
            return
        start = cache.start
        # slicing copies the array.array, so no buffer export pins the cache's storage
        st = np.frombuffer(cache.stamps[start:], dtype=np.int64)
        m = self.m = st.shape[0]
        self.st = st
        if m == 0:
            return
        par = np.frombuffer(cache.parents[start:], dtype=np.int32).astype(np.int64)
        d = np.frombuffer(cache.data[7 * start:], dtype=float).reshape(m, 7)
        self.par = par
        self.uniform = int(par[0]) if (par == par[0]).all() else None
        self.last = d[m - 1].copy()
        self.last_parent = int(par[m - 1])
        self.first_stamp, self.last_stamp = int(st[0]), int(st[m - 1])
        if m == 1:
            return
        p0, p1 = d[:-1], d[1:]
        q0, q1 = p0[:, 3:], p1[:, 3:]
        dot = np.einsum("ij,ij->i", q0, q1)
        c = np.abs(dot) / np.sqrt(np.einsum("ij,ij->i", q0, q0) * np.einsum("ij,ij->i", q1, q1))
        theta = np.arccos(np.minimum(c, 1.0))
        zero = theta == 0.0
        isn = np.where(zero, 0.0, 1.0 / np.sin(np.where(zero, 1.0, theta)))
        older = par[:-1] != par[1:]          # parents differ: the older sample applies as is
        inv_dt = np.where(older, 0.0, 1.0 / (st[1:] - st[:-1]))
        rows = np.empty((19, m - 1))
        rows[0], rows[1], rows[2] = inv_dt, theta, isn
        rows[3] = np.where(dot < 0, -isn, isn)
        rows[4] = zero
        rows[5:8] = p0[:, :3].T
        rows[8:11] = (p1[:, :3] - p0[:, :3]).T
        rows[11:15] = q0.T
        rows[15:19] = q1.T
        self.rows = rows

    def query(self, t: np.ndarray) -> tuple[Optional[np.ndarray], Any, tuple]:
        """(ok mask or None if all ok, parent (int or array), 7 value columns) at times t."""
        m = self.m
        if m == -1:
            return None, self.uniform, tuple(self.last)
        n = t.shape[0]
        if m == 0:
            return np.zeros(n, bool), 0, (0.0,) * 7
        t_eff = np.where(t == 0, self.last_stamp, t) if (t == 0).any() else t
        if m == 1:
            ok = t_eff == self.first_stamp
            return (None if ok.all() else ok), self.uniform, tuple(self.last)
        ok = (t_eff >= self.first_stamp) & (t_eff <= self.last_stamp)
        all_ok = ok.all()
        st = self.st
        i = np.searchsorted(st, t_eff, side="right") - 1
        np.clip(i, 0, m - 2, out=i)
        if n > 64 and (i[1:] >= i[:-1]).all():  # sorted times (a trajectory): repeat beats take 5x
            R = np.repeat(self.rows, np.bincount(i, minlength=m - 1), axis=1)
        else:
            R = np.take(self.rows, i, axis=1)
        r = (t_eff - st[i]) * R[0]
        th = R[1]
        s0 = np.sin((1.0 - r) * th)
        s0 *= R[2]
        s0 += R[4]
        s1 = np.sin(r * th)
        s1 *= R[3]
        vals = [R[5] + r * R[8], R[6] + r * R[9], R[7] + r * R[10],
                R[11] * s0 + R[15] * s1, R[12] * s0 + R[16] * s1,
                R[13] * s0 + R[17] * s1, R[14] * s0 + R[18] * s1]
        parent: Any = self.uniform
        exact_new = t_eff == self.last_stamp
        if exact_new.any():           # tf2 returns the newest sample itself (even across parents)
            for k in range(7):
                vals[k][exact_new] = self.last[k]
        if parent is None:
            parent = self.par[i]
            parent[exact_new] = self.last_parent
        return (None if all_ok else ok), parent, tuple(vals)


def _accumulate(acc: Optional[list], v: tuple) -> list:
    """acc = v ∘ acc for (tx, ty, tz, qx, qy, qz, qw) columns: quatRotate(q, t_acc) + p, q·q_acc."""
    px, py, pz, x, y, z, w = v
    if acc is None:
        return [np.array(c, dtype=float) if np.ndim(c) else c for c in v]
    sx, sy, sz, qx, qy, qz, qw = acc
    ax = w * sx + y * sz - z * sy
    ay = w * sy + z * sx - x * sz
    az = w * sz + x * sy - y * sx
    aw = -x * sx - y * sy - z * sz
    return [-aw * x + ax * w - ay * z + az * y + px,
            -aw * y + ay * w - az * x + ax * z + py,
            -aw * z + az * w - ax * y + ay * x + pz,
            w * qx + x * qw + y * qz - z * qy,
            w * qy + y * qw + z * qx - x * qz,
            w * qz + z * qw + x * qy - y * qx,
            w * qw - x * qx - y * qy - z * qz]


def _inverse_cols(acc: list) -> list:
    tx, ty, tz, x, y, z, w = acc
    x, y, z = -x, -y, -z
    vx, vy, vz = -tx, -ty, -tz
    ax = w * vx + y * vz - z * vy
    ay = w * vy + z * vx - x * vz
    az = w * vz + x * vy - y * vx
    aw = -x * vx - y * vy - z * vz
    return [-aw * x + ax * w - ay * z + az * y, -aw * y + ay * w - az * x + ax * z,
            -aw * z + az * w - ax * y + ay * x, x, y, z, w]


def _full(n: int, acc: Optional[list]) -> np.ndarray:
    """acc columns (or identity) as an [n, 7] array."""
    out = np.zeros((n, 7))
    if acc is None:
        out[:, 6] = 1.0
    else:
        for k in range(7):
            out[:, k] = acc[k]
    return out


class _Walk:
    """One side of tf2's walk for a set of times, vectorized; frames may differ per time."""

    def __init__(self, tables: Callable[[int], Optional[_Tables]], t: np.ndarray) -> None:
        self.tables = tables
        self.t = t

    def run(self, start: int, stop_at: Any, early_out: int, source_side: bool, max_depth: int) -> dict:
        """Walk up from `start`; stop where the frame equals stop_at (array per time) when the
        target side walks, at roots, at failed queries, or at early_out (after its query).
        Returns per-time arrays: acc (n,7), frame, top, failed, early, looped."""
        t = self.t
        n = t.shape[0]
        frame = np.full(n, start, np.int64)
        top = frame.copy()
        acc = np.zeros((7, n))          # rows: tx, ty, tz, qx, qy, qz, qw (contiguous)
        acc[6] = 1.0
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
                return dict(acc=acc, frame=frame, top=top, failed=failed, early=early, looped=True)
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
                ok, parent, vals = tab.query(t if whole else t[idx])
                if ok is not None:
                    bad = idx[~ok]
                    failed[bad] = True
                    if source_side:
                        top[bad] = fid
                    active[bad] = False
                    keep = np.flatnonzero(ok)
                    idx = idx[keep]
                    whole = False
                    vals = tuple(v[keep] if np.ndim(v) else v for v in vals)
                    if np.ndim(parent):
                        parent = parent[keep]
                    if idx.size == 0:
                        continue
                if fid == early_out:
                    early[idx] = True
                    active[idx] = False
                    continue
                if whole and none_started:
                    for k in range(7):
                        acc[k] = vals[k]
                elif whole and started.all():
                    new = _accumulate(list(acc), vals)
                    for k in range(7):
                        acc[k] = new[k]
                else:
                    sub = acc[:, idx]
                    first = ~started[idx]
                    new = _accumulate(list(sub), vals)
                    for k in range(7):
                        sub[k] = np.where(first, vals[k], new[k])
                    acc[:, idx] = sub
                started[idx] = True
                none_started = False
                if source_side:
                    top[idx] = fid
                frame[idx] = parent
                if stop_at is not None:
                    active[idx] = frame[idx] != stop_at[idx]
        return dict(acc=acc, frame=frame, top=top, failed=failed, early=early, looped=False)


def lookup_transforms(core: Any, target_frame: str, source_frame: str, times: Any) -> tuple[np.ndarray, np.ndarray]:
    """lookup_transform at every time of times[N] in one vectorized pass.

    Returns (translations[N,3], quaternions[N,4] as x, y, z, w). ``times`` is a sequence of
    ``Time`` or float seconds, or an integer numpy array of nanoseconds; 0 means the latest
    common time, as in a single lookup. Parent switches over the series are honoured (each time
    walks the tree as it was then). If the lookup fails at any time, the exception a single
    ``lookup_transform`` raises at the earliest failing position is raised and nothing is returned.
    The buffer lock is held per chunk of 16k times, not for the whole call.
    """
    from .buffer_core import MAX_GRAPH_DEPTH

    t_all = _times_ns(times)
    n_all = t_all.shape[0]
    out = np.empty((n_all, 7))
    with core._lock:
        if target_frame == source_frame:
            out[:] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
            return out[:, :3], out[:, 3:]
        target_id = core._validate("lookupTransform argument target_frame", target_frame)
        source_id = core._validate("lookupTransform argument source_frame", source_frame)
    any_zero = bool((t_all == 0).any())
    cache_tables: dict[int, Optional[_Tables]] = {}

    def tables(fid: int) -> Optional[_Tables]:
        if fid not in cache_tables:
            c = core._caches[fid]
            cache_tables[fid] = None if c is None else _Tables(c)
        return cache_tables[fid]

    def replay(bad: np.ndarray, t_asked: np.ndarray) -> None:
        # the single lookup at the first failing time raises tf2's exact exception
        for k in np.flatnonzero(bad).tolist():
            core._lookup(target_frame, source_frame, int(t_asked[k]))
        raise TransformException("vectorized lookup disagreed with the single lookup")  # pragma: no cover

    version = None
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
            walk = _Walk(tables, t)
            # a walk longer than the number of frames must be going round a loop: stop there and
            # let the single lookup produce tf2's loop error (it walks MAX_GRAPH_DEPTH steps)
            depth_limit = min(MAX_GRAPH_DEPTH, len(core._caches))
            src = walk.run(source_id, None, target_id, True, depth_limit)
            ends_at_target = src["early"]
            top = src["top"]
            tgt = walk.run(target_id, np.where(ends_at_target, target_id, top), source_id, False, depth_limit)
            ends_at_source = tgt["early"]
            full = ~ends_at_target & ~ends_at_source
            broken = tgt["failed"] | (full & (tgt["frame"] != top)) | lct_bad
            if src["looped"] or tgt["looped"] or broken.any():
                replay(broken | np.full(n, src["looped"] or tgt["looped"]), t_asked)
        s_acc, t_acc = src["acc"], tgt["acc"]
        res = out[lo:lo + n]
        if ends_at_target.any():
            res[ends_at_target] = s_acc[:, ends_at_target].T
        if ends_at_source.any():
            inv = _inverse_cols(list(t_acc[:, ends_at_source]))
            res[ends_at_source] = np.stack(inv, axis=1)
        if full.all():
            inv = _inverse_cols(list(t_acc))
            res[:] = np.stack(_accumulate(list(s_acc), tuple(inv)), axis=1)  # inv(target) ∘ source
        elif full.any():
            inv = _inverse_cols(list(t_acc[:, full]))
            res[full] = np.stack(_accumulate(list(s_acc[:, full]), tuple(inv)), axis=1)
    return out[:, :3], out[:, 3:]


def transform_points_series(core: Any, points: Any, target_frame: str, source_frame: str, times: Any) -> np.ndarray:
    """points[N,3] each stamped times[N] (a trajectory) -> target_frame, one vectorized pass."""
    pts = np.asarray(points, dtype=float)
    v, q = lookup_transforms(core, target_frame, source_frame, times)
    if pts.shape != v.shape:
        raise ValueError(f"points must have shape ({v.shape[0]}, 3), got {pts.shape}")
    m = matrix_from_quaternion_batch(q)
    return np.einsum("nij,nj->ni", m, pts) + v
