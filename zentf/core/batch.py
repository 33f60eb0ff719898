"""Whole arrays through the tree at once: ``lookup_transforms`` over a series of times, ``transform_points``.

The walk is BufferCore's own: ``BufferCore.chain_plan`` walks the tree for a whole range of times
in one call and returns the links a lookup composes there, with each link's samples. This module
only does the arithmetic, for every time of the range in vectorized passes: numpy, or with numba
(the ``fast`` extra) one compiled pass per time (``_chain_kernel``). Where the walk changes inside a
range (a parent switch, a buffer's end) the range is planned in pieces; a piece of a few times, and
the times where the lookup fails, go through the single ``lookup_transform``, so the answers, and
the errors, are the single lookup's at every time (to rounding: the slerp here is a Taylor series).
"""
from __future__ import annotations

import importlib
import logging
import math
from typing import Any, Optional

import numpy as np

from .exceptions import TransformException
from .math3d import matrix_from_quaternion, matrix_from_quaternion_batch
from .time import Time, ns_from_sec_array

__all__ = ["lookup_transforms", "transform_points", "transform_points_series", "fast_path"]

logger = logging.getLogger(__name__)

_CHUNK = 8192     # times per numpy pass: the working set (~45 rows of 8k floats) stays near L2
_FEW = 4          # a piece of the series this short goes through single lookups (planning costs more)
_SPAN = 1 << 50   # ns a planned piece may span: float ns relative to its first time stay exact

# numba path: None = not tried yet, False = numba missing (or unusable), else the compiled kernel.
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
            logger.debug("numba kernel unavailable, numpy path: %s", e)
            _kernel = False
    return _kernel or None


def fast_path() -> str:
    """Which implementation composes lookup_transforms' chains: "numba" or "numpy"."""
    return "numba" if _numba_kernel() is not None else "numpy"


def transform_points(core: Any, points: Any, target_frame: str, source_frame: str, time: Any) -> np.ndarray:
    """points[N,3] in source_frame -> [N,3] in target_frame at time (one lookup, one matmul)."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
    tr = core.lookup_transform(target_frame, source_frame, time).transform
    q, v = tr.rotation, tr.translation
    m = matrix_from_quaternion((q.x, q.y, q.z, q.w))
    return pts @ np.asarray(m).T + np.array([v.x, v.y, v.z])


def transform_points_series(core: Any, points: Any, target_frame: str, source_frame: str, times: Any) -> np.ndarray:
    """points[N,3] each stamped times[N] (a trajectory) -> target_frame, one vectorized pass."""
    pts = np.asarray(points, dtype=float)
    v, q = lookup_transforms(core, target_frame, source_frame, times)
    if pts.shape != v.shape:
        raise ValueError(f"points must have shape ({v.shape[0]}, 3), got {pts.shape}")
    m = matrix_from_quaternion_batch(q)
    return np.einsum("nij,nj->ni", m, pts) + v


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


def lookup_transforms(core: Any, target_frame: str, source_frame: str, times: Any) -> tuple[np.ndarray, np.ndarray]:
    """lookup_transform at every time of times[N] in one vectorized pass.

    Returns (translations[N,3], quaternions[N,4] as x, y, z, w), transposed views of one (7, N)
    array (column-major; ``np.ascontiguousarray`` if C order matters). ``times`` is a sequence of
    ``Time`` or float seconds, or an integer numpy array of nanoseconds; 0 means the latest
    common time, as in a single lookup. Parent switches over the series are honoured (each time
    walks the tree as it was then). If the lookup fails at any time, the exception a single
    ``lookup_transform`` raises at the earliest failing position is raised and nothing is returned.
    The buffer's lock is held only while a range of the series is planned, never for the arithmetic.
    Cost: see bench/lookup.py and docs/performance.md (``fast_path()`` tells which path composes).
    """
    t_all = _times_ns(times)
    n = t_all.shape[0]
    out = np.empty((7, n))    # rows: the results are returned as transposed views
    if target_frame == source_frame:
        out[:] = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])[:, None]
        return out[0:3].T, out[3:7].T
    if n > 1 and not bool((t_all[1:] >= t_all[:-1]).all()):
        order: Optional[np.ndarray] = np.argsort(t_all, kind="stable")
        ts = t_all[order]
    else:
        order, ts = None, t_all       # sorted already (a trajectory): positions are indices

    def at(lo: int, hi: int) -> Any:
        """The caller's positions of sorted times lo..hi-1."""
        return slice(lo, hi) if order is None else order[lo:hi]

    def earliest(lo: int, hi: int) -> int:
        """The sorted index, among lo..hi-1, of the earliest position."""
        return lo if order is None else lo + int(np.argmin(order[lo:hi]))

    failure = _Failure(n)
    zeros = int(np.searchsorted(ts, 0, side="right"))
    if zeros:   # the latest common time: one single lookup answers for all of them
        _single(core, target_frame, source_frame, 0, at(0, zeros), earliest(0, zeros), order, out, failure)
    kern = _numba_kernel()
    pieces = [(zeros, n)] if zeros < n else []
    while pieces:
        lo, hi = pieces.pop()
        i = earliest(lo, hi)
        if failure.error is not None and (i if order is None else int(order[i])) > failure.position:
            continue                      # an earlier time already fails
        t_lo, t_hi = int(ts[lo]), int(ts[hi - 1])
        if hi - lo <= _FEW:
            for j in range(lo, hi):
                _single(core, target_frame, source_frame, int(ts[j]), at(j, j + 1), j, order, out, failure)
            continue
        if t_hi - t_lo >= _SPAN:
            mid = (lo + hi) // 2
            pieces += [(mid, hi), (lo, mid)]
            continue
        plan = core.chain_plan(target_frame, source_frame, t_lo, t_hi)
        if plan is None:                  # fails at every time here: the earliest one says why
            if not _single(core, target_frame, source_frame, int(ts[i]), at(i, i + 1), i, order, out, failure):
                continue
            mid = (lo + hi) // 2          # it answered after all (data came in meanwhile): plan again
            pieces += [(mid, hi), (lo, mid)]
            continue
        if isinstance(plan, int):         # the walk changes at time `plan`
            mid = lo + int(np.searchsorted(ts[lo:hi], plan, side="left"))
            pieces += [(mid, hi), (lo, mid)]
            continue
        links, n_source = plan
        tf = (ts[lo:hi] - t_lo).astype(float)
        rows = _compose_chain(kern, _links(links, t_lo), n_source, tf)
        if order is None and hi - lo == n:
            out = rows                    # the whole series in one piece: no copy
        else:
            out[:, at(lo, hi)] = rows
    if failure.error is not None:
        raise failure.error
    return out[0:3].T, out[3:7].T


class _Failure:
    """The earliest position (in the caller's order) whose lookup failed, and its exception."""

    __slots__ = ("position", "error")

    def __init__(self, n: int) -> None:
        self.position = n
        self.error: Optional[TransformException] = None


def _single(core: Any, target: str, source: str, t: int, positions: Any, i: int, order: Optional[np.ndarray],
            out: np.ndarray, failure: _Failure) -> bool:
    """The single lookup at t for these positions; False, and the failure noted, if it raised (i:
    the sorted index of the earliest of them)."""
    try:
        tr = core.lookup_transform(target, source, Time(nanoseconds=t)).transform
    except TransformException as e:
        first = i if order is None else int(order[i])
        if first < failure.position:
            failure.position, failure.error = first, e
        return False
    v, q = tr.translation, tr.rotation
    out[:, positions] = np.array([v.x, v.y, v.z, q.x, q.y, q.z, q.w])[:, None]
    return True


# Taylor coefficients of sin(x)/x and cos(x) in x²: slerp phases are at most π/2, and the number
# of terms is picked per link from the largest phase so the truncation error stays below 1e-16
# (a few multiply-adds per time are much cheaper than np.sin and np.cos).
_SIN = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(14)]
_COS = [(-1.0) ** k / math.factorial(2 * k) for k in range(14)]
_UNIT_TOL = 4e-15     # |q|² - 1 of a stored quaternion for the unit-norm rotation formula


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
_OUT_ROWS = [0, 1, 2, 6, 7, 8, 5]    # accumulator rows -> tx, ty, tz, qx, qy, qz, qw
_LINK_ROWS = [0, 1, 2, 5, 6, 7, 8, 9, 10]  # accumulator rows -> link value rows


class _Link:
    """One link of a planned chain as interpolation constants (or its one value, if static).

    Row j of ``k`` (j < m - 1) interpolates from sample j to sample j + 1; the last row is the
    last sample itself (tf2 returns it as is from its stamp on). Stamps are float ns relative to
    the piece's first time. With x = (t - st[j])·ω the value is p0 + (t - st[j])·vel and
    q0·cos x + a·sin x (tf2's slerp rewritten: one sin, one cos). Zero angles have ω = a = 0.
    Built by ``_links`` for a whole chain at once.
    """

    __slots__ = ("stamps", "k", "theta", "theta_max", "value", "unit")

    def __init__(self, stamps: Optional[np.ndarray], k: Any, theta: Any, theta_max: float, value: Any,
                 unit: bool) -> None:
        self.stamps = stamps
        self.k = k
        self.theta = theta
        self.theta_max = theta_max
        self.value = value
        self.unit = unit

    def rows(self, tf: np.ndarray) -> np.ndarray:
        """The link's value (9, n) at sorted times tf (float ns relative to the piece's first time)."""
        n = tf.shape[0]
        st = self.k[0]
        # sorted times map to runs of one interval: count each run and repeat the constants
        pos = np.searchsorted(tf, st, side="left")
        counts = np.empty(st.shape[0], np.int64)
        np.subtract(pos[1:], pos[:-1], out=counts[:-1])
        counts[-1] = n - pos[-1]
        g = np.repeat(self.k, counts, axis=1)
        theta = float(self.theta[counts > 0].max())
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
        return v


def _links(plan_links: list[tuple], base: int) -> list[_Link]:
    """The planned links' constants, computed for all the chain's samples in one pass (per link,
    the numpy calls of a short series over a deep chain cost more than its arithmetic)."""
    out: list[Optional[_Link]] = [None] * len(plan_links)
    dyn = []
    for i, (stamps, d) in enumerate(plan_links):
        if stamps is None:            # static: one value at every time
            v = np.empty((9, 1))
            v[0:7, 0] = d[0, [0, 1, 2, 6, 3, 4, 5]]
            v[7:9] = v[4:6]
            out[i] = _Link(None, None, None, 0.0, v, bool(abs(float(d[0, 3:] @ d[0, 3:]) - 1.0) <= _UNIT_TOL))
        else:
            dyn.append(i)
    if not dyn:
        return out  # type: ignore[return-value]
    sizes = np.array([plan_links[i][0].shape[0] for i in dyn], np.int64)
    starts = np.zeros(len(dyn), np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    st = np.concatenate([plan_links[i][0] for i in dyn])
    d = np.concatenate([plan_links[i][1] for i in dyn]).T.copy()   # rows px, py, pz, qx, qy, qz, qw
    m = st.shape[0]
    k = np.zeros((16, m))     # stamp - base, ω, p0 (3), vel (3), q0 (w, x, y, z), a (w, x, y, z)
    k[0] = st - base
    k[2:5] = d[0:3]
    k[8] = d[6]
    k[9:12] = d[3:6]
    theta = np.zeros(m)
    if m > 1:
        # pair j interpolates sample j to j + 1; a pair across two links' samples is no interval
        seams = starts[1:] - 1
        q0, q1 = d[3:7, :-1], d[3:7, 1:]
        dot = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
        n0 = q0[0] * q0[0] + q0[1] * q0[1] + q0[2] * q0[2] + q0[3] * q0[3]
        n1 = q1[0] * q1[0] + q1[1] * q1[1] + q1[2] * q1[2] + q1[3] * q1[3]
        th = np.arccos(np.minimum(np.abs(dot) / np.sqrt(n0 * n1), 1.0))
        th[seams] = 0.0
        live = th != 0.0
        dt = (st[1:] - st[:-1]).astype(float)
        dt[seams] = 1.0
        vel = k[5:8, :-1]
        np.subtract(d[0:3, 1:], d[0:3, :-1], out=vel)
        vel /= dt
        vel[:, seams] = 0.0
        k[1, :-1] = th / dt
        sin_th = np.where(live, np.sin(th), 1.0)
        sgn = np.where(dot < 0, -1.0, 1.0)
        a = (q1 * sgn - q0 * np.cos(th)) / sin_th    # rows x, y, z, w
        a[:, ~live] = 0.0
        k[12, :-1] = a[3]
        k[13:16, :-1] = a[0:3]
        theta[:-1] = th
    # unit samples interpolate to unit quaternions (|q0 cos x + a sin x|² = 1, a ⊥ q0), so the
    # cheaper rotation formula agrees with q·v·q* to ~1e-15 relative
    norm2 = d[3] * d[3] + d[4] * d[4] + d[5] * d[5] + d[6] * d[6]
    unit = np.logical_and.reduceat(np.abs(norm2 - 1.0) <= _UNIT_TOL, starts)
    theta_max = np.maximum.reduceat(theta, starts)
    for j, i in enumerate(dyn):
        lo, hi = int(starts[j]), int(starts[j] + sizes[j])
        out[i] = _Link(plan_links[i][0], k[:, lo:hi], theta[lo:hi], float(theta_max[j]), None, bool(unit[j]))
    return out  # type: ignore[return-value]


def _fold_statics(links: list[_Link]) -> list[tuple]:
    """One side's links as ("dyn", link) and ("const", value (9, 1), unit) entries: a run of static
    links is composed once (composition is associative), not per time."""
    out: list[tuple] = []
    pending: Optional[np.ndarray] = None
    unit = True
    for link in links:
        if link.stamps is None:
            if pending is None:
                pending = np.empty((11, 1))
                _set_acc(pending, link.value)
                unit = link.unit
            else:
                _compose(pending, link.value, link.unit)
                unit = unit and link.unit
            continue
        if pending is not None:
            out.append(("const", pending[_LINK_ROWS], unit))
            pending = None
        out.append(("dyn", link))
    if pending is not None:
        out.append(("const", pending[_LINK_ROWS], unit))
    return out


def _compose_chain(kern: Any, links: list[_Link], n_source: int, tf: np.ndarray) -> np.ndarray:
    """inverse(T) ∘ S at sorted times tf (S: links[:n_source] composed, T: the rest): (7, n) rows
    tx, ty, tz, qx, qy, qz, qw."""
    sides = (_fold_statics(links[:n_source]), _fold_statics(links[n_source:]))
    if kern is not None:
        return _run_kernel(kern, sides, tf)
    n = tf.shape[0]
    out = np.empty((7, n))
    for lo in range(0, n, _CHUNK):
        part = tf[lo:lo + _CHUNK]
        s_acc, t_acc = (_accumulate(side, part) for side in sides)
        if s_acc is None:
            s_acc = _identity_acc(part.shape[0])
        if t_acc is not None:
            _compose(s_acc, _inverse_acc(t_acc))      # inv(target) ∘ source
        out[:, lo:lo + _CHUNK] = s_acc[_OUT_ROWS]
    return out


def _accumulate(side: list[tuple], tf: np.ndarray) -> Optional[np.ndarray]:
    """One side's links composed at times tf (accumulator rows), None if it has none."""
    acc: Optional[np.ndarray] = None
    for entry in side:
        if entry[0] == "const":
            v, unit = entry[1], entry[2]
        else:
            v, unit = entry[1].rows(tf), entry[1].unit
        if acc is None:
            acc = _identity_acc(tf.shape[0])
            _set_acc(acc, v)
        else:
            _compose(acc, v, unit)
    return acc


def _run_kernel(kern: Any, sides: tuple[list[tuple], list[tuple]], tf: np.ndarray) -> np.ndarray:
    """The compiled kernel over both sides' links: one row of 16 interval constants per interval
    (two cache lines), links one after another; constant links by value."""
    entries = sides[0] + sides[1]
    n_links = len(entries)
    n_src = len(sides[0])
    off = np.zeros(n_links, np.int64)
    cnt = np.zeros(n_links, np.int64)
    kt = np.ones(n_links, np.int64)
    unit = np.zeros(n_links, np.bool_)
    cval = np.zeros((max(n_links, 1), 7))
    parts = []
    total = 0
    for li, entry in enumerate(entries):
        if entry[0] == "const":
            cval[li] = entry[1][0:7, 0]      # px, py, pz, qw, qx, qy, qz
            unit[li] = entry[2]
            continue
        link = entry[1]
        m = link.k.shape[1]
        parts.append(link.k)
        off[li] = total
        cnt[li] = m
        total += m
        kt[li] = _terms(link.theta_max)
        unit[li] = link.unit
    k = np.concatenate([p.T for p in parts]) if parts else np.zeros((1, 16))
    mode = 1 if n_src == n_links else (2 if n_src == 0 else 0)
    out = np.empty((7, tf.shape[0]))
    kern.chain_kernel(tf, k, off, cnt, kt, unit, cval, n_src, mode, kern._SIN, kern._COS, out)
    return out


def _set_acc(acc: np.ndarray, v: np.ndarray) -> None:
    """acc = v (link rows to accumulator rows)."""
    acc[0:3] = v[0:3]
    acc[3:5] = v[0:2]
    acc[5:11] = v[3:9]


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
