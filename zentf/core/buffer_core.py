"""BufferCore: tf2's transform tree with the exact semantics of ROS 1 tf2 (geometry2 0.7.x).

The differential tests hold this module to Debian's python3-tf2 (the "oracle"), op by op. Where
the behaviour follows ROS 1 and ROS 2 differs, the ROS 1 choice is kept and said so in a comment:
the first cache type of a frame is kept on a static/dynamic switch, a repeated stamp is refused
(TF_REPEATED_DATA, the first sample wins), old samples are pruned right after an insert, and
messages use ROS 1 wording (times with 9 decimals, "Ds into the future").

Each frame is an integer id with one cache object (zentf.core.cache: TimeCache for dynamic
frames, StaticCache for static ones), as tf2 keeps one TimeCacheInterface per frame. One lock
guards everything so a listener thread may insert while user threads look up.

Speed in pure Python comes from three caches, all exact under inserts: ``lookup_transform``
remembers results by (target, source, time) while a version counter (bumped by every stored
change) is unchanged; each frame remembers its last interpolated query; and each frame keeps the
slerp constants of recently queried sample intervals. A lookup at a time never asked before
still walks the tree at roughly 3 µs per link (tf2's C++ needs ~0.2 µs): see bench/lookup.py.
"""
from __future__ import annotations

import logging
import math
import threading
from enum import IntEnum
from typing import Any, Callable, Iterable, Optional, Sequence, Union

from .cache import StaticCache, TimeCache
from .constants import (DEFAULT_CACHE_TIME, DEFAULT_MAX_FRAME_ID_LENGTH, DEFAULT_MAX_FRAMES, MAX_GRAPH_DEPTH,
                        MAX_STAMP_NS)
from .constants import INSERT_OK as _OK
from .constants import INSERT_OLD as _OLD
from .exceptions import (ConnectivityException, ExtrapolationException, InvalidArgumentException,
                         LookupException, TransformException)
from .messages import Header, Quaternion, Transform, TransformStamped, Vector3
from .ratelimit import RateLimitedLogger
from .time import NSEC_PER_SEC, Duration, Time, ns_from_sec

__all__ = ["BufferCore", "TransformableResult", "NEVER_TRANSFORMABLE", "DEFAULT_CACHE_TIME",
           "MAX_GRAPH_DEPTH"]

logger = logging.getLogger("zentf.core.buffer_core")
_ERROR, _WARNING = logging.ERROR, logging.WARNING
_INFINITIES = (math.inf, -math.inf)

#: Handle returned by add_transformable_request when the request can never succeed (tf2 value).
NEVER_TRANSFORMABLE = 0xFFFFFFFFFFFFFFFF


TimeArg = Union[Time, int, float]


class TransformableResult(IntEnum):
    """Outcome passed to a transformable-request callback (tf2 ``TransformableResult``)."""

    TransformAvailable = 0
    TransformFailure = 1


def _ns(t: Any) -> int:
    """Time or seconds -> integer ns (0 = latest).

    Times stay exact integer nanoseconds, as in ROS 2. (ROS 1's tf2_py squeezes every time
    through float seconds, which can move a stamp by a nanosecond; the differential tests replay
    that conversion on their inputs instead of copying it here.)
    """
    if type(t) is Time:
        return t._ns
    if isinstance(t, Time):
        return t.nanoseconds
    if hasattr(t, "item") and not isinstance(t, (int, float)):
        t = t.item()  # numpy scalars
    if isinstance(t, bool) or not isinstance(t, (int, float)):
        raise TypeError(f"time must be a Time or seconds, got {type(t).__name__}")
    if isinstance(t, int):
        ns = t * NSEC_PER_SEC
    else:
        if not math.isfinite(t):
            raise ValueError(f"time must be finite, got {t!r}")
        ns = ns_from_sec(t, "time")  # ROS's whole seconds + rounded fraction
    if ns < 0:
        raise ValueError(f"time cannot be negative ({t!r})")
    if ns > MAX_STAMP_NS:
        raise ValueError(f"time {t!r} s is beyond the latest a buffer holds ({MAX_STAMP_NS} ns, int64)")
    return ns


def _make_ts(target: str, source: str, stamp: int, tx: float, ty: float, tz: float,
             qx: float, qy: float, qz: float, qw: float) -> TransformStamped:
    """Build a TransformStamped without dataclass __init__ overhead (hot path)."""
    tm = object.__new__(Time)
    tm._ns = stamp
    h = object.__new__(Header)
    h.stamp = tm
    h.frame_id = target
    v = object.__new__(Vector3)
    v.x, v.y, v.z = tx, ty, tz
    q = object.__new__(Quaternion)
    q.x, q.y, q.z, q.w = qx, qy, qz, qw
    tr = object.__new__(Transform)
    tr.translation = v
    tr.rotation = q
    ts = object.__new__(TransformStamped)
    ts.header = h
    ts.child_frame_id = source
    ts.transform = tr
    return ts


class _Request:
    __slots__ = ("handle", "cb", "target", "source", "time")

    def __init__(self, handle: int, cb: Callable, target: str, source: str, time: int) -> None:
        self.handle, self.cb, self.target, self.source, self.time = handle, cb, target, source, time


# --------------------------------------------------------------------------- BufferCore

class BufferCore:
    """tf2's BufferCore: stores the tree over time and answers lookups (thread-safe).

    Times are ``Time`` or float seconds everywhere (0 = latest). Beyond tf2_py's API:
    ``set_transform_raw``/``set_transforms_raw`` (insert without messages),
    ``add_insert_callback`` (wake waiters), ``add_transformable_request`` (MessageFilter),
    ``frame_info``/``chain_as_vector``/``get_parent``/``frame_exists`` (tools), and the numpy
    batches ``lookup_transforms``/``transform_points`` (see zentf.core.geometry).

    Bounds tf2 does not have (deliberate, for memory under hostile input): at most ``max_frames``
    distinct frame names (default 10,000) and frame ids of at most ``max_frame_id_length`` UTF-8
    bytes (default 256); a sample that would pass either is refused with a logged line
    (TF_TOO_MANY_FRAMES, TF_FRAME_ID_TOO_LONG). None lifts a bound; both are plain attributes.
    """

    def __init__(self, cache_time: Union[Duration, float, int] = DEFAULT_CACHE_TIME, *,
                 max_frames: Optional[int] = DEFAULT_MAX_FRAMES,
                 max_frame_id_length: Optional[int] = DEFAULT_MAX_FRAME_ID_LENGTH) -> None:
        self.max_frames = max_frames
        self.max_frame_id_length = max_frame_id_length
        if isinstance(cache_time, Duration):
            self._cache_ns = cache_time.nanoseconds
        else:
            self._cache_ns = _ns(cache_time)
        self._lock = threading.Lock()
        # frame id 0 is tf2's "NO_PARENT" sentinel; it never has a cache
        self._ids: dict[str, int] = {"NO_PARENT": 0}
        self._clean: dict[str, int] = {}  # ids of names usable as given (no leading '/')
        self._names: list[str] = ["NO_PARENT"]
        self._caches: list[Any] = [None]
        self._requests: list[_Request] = []
        self._request_counter = 0
        self._insert_callbacks: list[Callable[[], None]] = []
        # lookup results by (target, source, time), valid while _version (bumped by every change
        # of stored data or frame set) is unchanged; errors are never memoized
        self._version = 0
        self._memo: dict[tuple[str, str, int], tuple[int, tuple]] = {}
        # refusals log one line per (reason, authority) per 5 s, then how many were suppressed
        # (tf2 logs every one: a flood of bad samples would write megabytes a second)
        self._warn = RateLimitedLogger(logger)

    @property
    def cache_time(self) -> Duration:
        return Duration(nanoseconds=self._cache_ns)

    # ------------------------------------------------------------------------ insert

    def set_transform(self, transform: TransformStamped, authority: str, is_static: bool = False) -> bool:
        """Insert one sample (tf2 setTransform); False, with a logged reason, if it was refused."""
        h = transform.header
        tr = transform.transform
        v = tr.translation
        q = tr.rotation
        stamp = h.stamp
        stamp = stamp._ns if type(stamp) is Time else stamp.nanoseconds
        parent, child = h.frame_id, transform.child_frame_id
        tx, ty, tz, qx, qy, qz, qw = v.x, v.y, v.z, q.x, q.y, q.z, q.w
        # hot path, the same as _store's (inlined: a call with 12 arguments costs ~7% of an insert)
        if (-0.01 < qx * qx + qy * qy + qz * qz + qw * qw - 1.0 < 0.01
                and (tx + ty + tz) * 0.0 == 0.0 and type(stamp) is int and stamp >= 0
                and stamp <= 9223372036854775807):
            self._lock.acquire()  # (not `with`: 0.12 µs less per call, measured)
            try:
                clean = self._clean
                cid = clean.get(child)
                pid = clean.get(parent)
                if cid is not None and pid is not None and cid != pid:
                    cache = self._caches[cid]
                    if type(cache) is TimeCache and stamp > cache.newest >= 0:
                        cache.stamps.append(stamp)
                        cache.parents.append(pid)
                        cache.data.extend((tx, ty, tz, qx, qy, qz, qw))
                        cache.newest = stamp
                        cache.latest = None
                        if cache.oldest < stamp - cache.max_ns:
                            cache.prune()
                        self._version += 1
                        cache.authority = authority
                        ok = True
                    else:
                        ok = None
                else:
                    ok = None
            finally:
                self._lock.release()
            if ok is None:
                ok = self._store_checked(parent, child, stamp, tx, ty, tz, qx, qy, qz, qw, authority, is_static)
        else:
            ok = self._store_checked(parent, child, stamp, tx, ty, tz, qx, qy, qz, qw, authority, is_static)
        if ok and (self._requests or self._insert_callbacks):
            self._after_insert()
        return ok

    def set_transform_static(self, transform: TransformStamped, authority: str) -> bool:
        """tf2_py spelling of set_transform(..., is_static=True)."""
        return self.set_transform(transform, authority, True)

    def set_transform_raw(self, parent: str, child: str, stamp_ns: int, tx: float, ty: float, tz: float,
                          qx: float, qy: float, qz: float, qw: float, authority: str,
                          is_static: bool = False) -> bool:
        """set_transform without building a message (listener fast path); same semantics."""
        ok = self._store(parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw, authority, is_static)
        if ok and (self._requests or self._insert_callbacks):
            self._after_insert()
        return ok

    def set_transforms_raw(self, samples: Iterable[Sequence[Any]], authority: str, is_static: bool = False) -> int:
        """Insert many (parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw) tuples; returns how many
        were accepted. Callbacks and transformable requests run once at the end.

        Same semantics as set_transform per sample, in order; the lock is taken once for the run of
        common-case samples (_store's fast path, inlined) and released only around _store_checked.
        """
        accepted = 0
        n_fast = 0  # fast inserts not yet counted in _version
        lock = self._lock
        clean = self._clean
        caches = self._caches
        lock.acquire()
        try:
            for parent, child, stamp, tx, ty, tz, qx, qy, qz, qw in samples:
                if (-0.01 < qx * qx + qy * qy + qz * qz + qw * qw - 1.0 < 0.01
                        and (tx + ty + tz) * 0.0 == 0.0 and type(stamp) is int and stamp >= 0
                        and stamp <= 9223372036854775807):
                    cid = clean.get(child)
                    pid = clean.get(parent)
                    if cid is not None and pid is not None and cid != pid:
                        cache = caches[cid]
                        if type(cache) is TimeCache and stamp > cache.newest >= 0:
                            cache.stamps.append(stamp)
                            cache.parents.append(pid)
                            cache.data.extend((tx, ty, tz, qx, qy, qz, qw))
                            cache.newest = stamp
                            cache.latest = None  # (memo and spans stay valid: no interval changed)
                            if cache.oldest < stamp - cache.max_ns:
                                cache.prune()
                            cache.authority = authority
                            n_fast += 1
                            continue
                # tf2's full path (new frames, statics, out of order, bad input): it logs, so unlocked
                self._version += n_fast
                accepted += n_fast
                n_fast = 0
                lock.release()
                try:
                    ok = self._store_checked(parent, child, stamp, tx, ty, tz, qx, qy, qz, qw, authority, is_static)
                finally:
                    lock.acquire()
                if ok:
                    accepted += 1
        finally:
            self._version += n_fast
            lock.release()
        accepted += n_fast
        if accepted:  # _after_insert, inlined (one frame less on the listener's latency path)
            if self._requests:
                self._test_transformable_requests()
            for cb in tuple(self._insert_callbacks):
                try:
                    cb()
                except Exception:  # a broken callback must not break inserts
                    logger.exception("insert callback %r failed", cb)
        return accepted

    def _store(self, parent: str, child: str, stamp: int, tx: float, ty: float, tz: float,
               qx: float, qy: float, qz: float, qw: float, authority: str, is_static: bool) -> bool:
        # The common case first: a valid sample, newer than everything stored, for an edge whose
        # frames are known by clean names (non-empty, no leading '/'). Anything else - new frames,
        # statics, out-of-order stamps, bad input - takes _store_checked, tf2's full path.
        # (tx + ty + tz) * 0.0 == 0.0: a finite translation (NaN or ±inf anywhere makes it NaN; a
        # finite sum that overflows only sends the sample down the full path, which accepts it);
        # 9223372036854775807 is MAX_STAMP_NS as a literal (a constant load, not a global one)
        if (-0.01 < qx * qx + qy * qy + qz * qz + qw * qw - 1.0 < 0.01
                and (tx + ty + tz) * 0.0 == 0.0 and type(stamp) is int and stamp >= 0
                and stamp <= 9223372036854775807):
            self._lock.acquire()  # (not `with`: 0.12 µs less per call, measured)
            try:
                clean = self._clean
                cid = clean.get(child)
                pid = clean.get(parent)
                if cid is not None and pid is not None and cid != pid:
                    cache = self._caches[cid]
                    if type(cache) is TimeCache and stamp > cache.newest >= 0:
                        cache.stamps.append(stamp)
                        cache.parents.append(pid)
                        cache.data.extend((tx, ty, tz, qx, qy, qz, qw))
                        cache.newest = stamp
                        cache.latest = None  # (memo and spans stay valid: no interval changed)
                        if cache.oldest < stamp - cache.max_ns:
                            cache.prune()
                        self._version += 1
                        cache.authority = authority
                        return True
            finally:
                self._lock.release()
        return self._store_checked(parent, child, stamp, tx, ty, tz, qx, qy, qz, qw, authority, is_static)

    def _store_checked(self, parent: str, child: str, stamp: Any, tx: float, ty: float, tz: float,
                       qx: float, qy: float, qz: float, qw: float, authority: str, is_static: bool) -> bool:
        """tf2's full validation, with its log lines; stores through _store if all is well."""
        if parent[:1] == "/":
            parent = parent[1:]
        if child[:1] == "/":
            child = child[1:]
        err = False
        warn = self._warn.log
        if child == parent:
            warn(_ERROR, ("TF_SELF_TRANSFORM", authority),
                 'TF_SELF_TRANSFORM: Ignoring transform from authority "%s" with frame_id and '
                 'child_frame_id  "%s" because they are the same', authority, child)
            err = True
        if not child:
            warn(_ERROR, ("TF_NO_CHILD_FRAME_ID", authority),
                 'TF_NO_CHILD_FRAME_ID: Ignoring transform from authority "%s" because '
                 'child_frame_id not set ', authority)
            err = True
        if not parent:
            warn(_ERROR, ("TF_NO_FRAME_ID", authority),
                 'TF_NO_FRAME_ID: Ignoring transform with child_frame_id "%s"  from authority '
                 '"%s" because frame_id not set', child, authority)
            err = True
        if tx != tx or ty != ty or tz != tz or qx != qx or qy != qy or qz != qz or qw != qw:
            warn(_ERROR, ("TF_NAN_INPUT", authority),
                 'TF_NAN_INPUT: Ignoring transform for child_frame_id "%s" from authority "%s" '
                 'because of a nan value in the transform (%f %f %f) (%f %f %f %f)',
                 child, authority, tx, ty, tz, qx, qy, qz, qw)
            err = True
        elif tx in _INFINITIES or ty in _INFINITIES or tz in _INFINITIES:
            # not in tf2 (it stores them, and an inverse lookup then returns NaN): refused like NaN
            warn(_ERROR, ("TF_NAN_INPUT", authority),
                 'TF_NAN_INPUT: Ignoring transform for child_frame_id "%s" from authority "%s" '
                 'because of an infinite value in the transform (%f %f %f) (%f %f %f %f)',
                 child, authority, tx, ty, tz, qx, qy, qz, qw)
            err = True
        if not abs(qx * qx + qy * qy + qz * qz + qw * qw - 1.0) < 0.01:
            warn(_ERROR, ("TF_DENORMALIZED_QUATERNION", authority),
                 'TF_DENORMALIZED_QUATERNION: Ignoring transform for child_frame_id "%s" from '
                 'authority "%s" because of an invalid quaternion in the transform '
                 '(%f %f %f %f)', child, authority, qx, qy, qz, qw)
            err = True
        if err:
            return False
        try:
            stamp = int(stamp)
        except (TypeError, ValueError):
            self._warn.log(_ERROR, ("TF_BAD_STAMP", authority),
                           'Ignoring transform for child_frame_id "%s" from authority "%s" because its '
                           'stamp %r is not a number of nanoseconds', child, authority, stamp)
            return False
        if stamp < 0:
            self._warn.log(_ERROR, ("TF_BAD_STAMP", authority),
                           'Ignoring transform for child_frame_id "%s" from authority "%s" because its '
                           'stamp is negative (%d ns)', child, authority, stamp)
            return False
        if stamp > MAX_STAMP_NS:
            self._warn.log(_ERROR, ("TF_BAD_STAMP", authority),
                           'Ignoring transform for child_frame_id "%s" from authority "%s" because its '
                           'stamp (%d ns) is beyond the largest the buffer holds (%d ns, int64)',
                           child, authority, stamp, MAX_STAMP_NS)
            return False
        values = tuple(float(x) for x in (tx, ty, tz, qx, qy, qz, qw))
        with self._lock:
            ids = self._ids
            cid = ids.get(child)
            pid = ids.get(parent)
            refused = None
            if cid is None or pid is None:
                refused = self._bound_new_frames(child if cid is None else None, parent if pid is None else None)
                if refused is None:
                    if cid is None:
                        cid = self._add_frame(child)
                    if pid is None:
                        pid = self._add_frame(parent)
            if refused is None:
                if not cid:
                    return True
                cache = self._caches[cid]
                if cache is None:
                    cache = StaticCache() if is_static else TimeCache(self._cache_ns)
                    self._caches[cid] = cache
                res = cache.insert(stamp, pid, values)
                if res == _OK:
                    self._version += 1
                    cache.authority = authority
                    return True
        if refused is not None:
            reason, name, size, limit = refused
            if reason == "TF_FRAME_ID_TOO_LONG":
                self._warn.log(_ERROR, (reason, authority),
                               'TF_FRAME_ID_TOO_LONG: Ignoring transform for child_frame_id "%s" from authority '
                               '"%s" because frame id "%s" is %d bytes long (max_frame_id_length %d)',
                               child, authority, name, size, limit)
            else:
                self._warn.log(_ERROR, (reason, authority),
                               'TF_TOO_MANY_FRAMES: Ignoring transform for child_frame_id "%s" from authority '
                               '"%s" because the buffer already holds %d frames (max_frames %d)',
                               child, authority, size, limit)
            return False
        self._log_refused(res, child, stamp, authority)
        return False

    def _log_refused(self, res: int, child: str, stamp: int, authority: str) -> None:
        if res == _OLD:
            self._warn.log(_WARNING, ("TF_OLD_DATA", authority),
                           "TF_OLD_DATA ignoring data from the past (Possible reasons are listed at "
                           "http://wiki.ros.org/tf/Errors%%20explained) for frame %s at time %.6f "
                           "according to authority %s", child, stamp / 1e9, authority)
        else:
            self._warn.log(_WARNING, ("TF_REPEATED_DATA", authority),
                           "TF_REPEATED_DATA ignoring data with redundant timestamp for frame %s at "
                           "time %.6f according to authority %s", child, stamp / 1e9, authority)

    def _bound_new_frames(self, child: Optional[str], parent: Optional[str]) -> Optional[tuple]:
        """(reason, name, size, limit) if adding these new names would pass a bound, else None."""
        longest = self.max_frame_id_length
        if longest is not None:
            for name in (child, parent):
                if name is not None and (len(name) > longest or (not name.isascii()
                                                                 and len(name.encode("utf-8", "replace")) > longest)):
                    return ("TF_FRAME_ID_TOO_LONG", name, len(name.encode("utf-8", "replace")), longest)
        most = self.max_frames
        if most is not None:
            held = len(self._names) - 1
            if held + (child is not None) + (parent is not None) > most:
                return ("TF_TOO_MANY_FRAMES", "", held, most)
        return None

    def _add_frame(self, name: str) -> int:
        fid = len(self._names)
        self._version += 1
        self._ids[name] = fid
        if name[:1] != "/":
            self._clean[name] = fid
        self._names.append(name)
        self._caches.append(None)
        return fid

    def _after_insert(self) -> None:
        if self._requests:
            self._test_transformable_requests()
        for cb in list(self._insert_callbacks):
            try:
                cb()
            except Exception:  # a broken callback must not break inserts
                logger.exception("insert callback %r failed", cb)

    def add_insert_callback(self, cb: Callable[[], None]) -> None:
        """Run ``cb()`` after every successful insert (outside the lock; used to wake waiters)."""
        self._insert_callbacks.append(cb)

    def remove_insert_callback(self, cb: Callable[[], None]) -> None:
        try:
            self._insert_callbacks.remove(cb)
        except ValueError:
            pass

    def clear(self) -> None:
        """Forget all dynamic data; static frames, frame names and pending requests stay (tf2)."""
        with self._lock:
            self._version += 1
            for cache in self._caches:
                if cache is not None:
                    cache.clear()

    # ------------------------------------------------------------------------ lookups

    def lookup_transform(self, target_frame: str, source_frame: str, time: TimeArg) -> TransformStamped:
        """Transform mapping data in source_frame into target_frame at time (0 = latest common)."""
        t = time._ns if type(time) is Time else _ns(time)
        key = (target_frame, source_frame, t)
        self._lock.acquire()  # (not `with`: 0.12 µs less per call, measured)
        try:
            hit = self._memo.get(key)
            if hit is not None and hit[0] == self._version:
                r = hit[1]
            else:
                r = self._lookup(target_frame, source_frame, t)
                memo = self._memo
                if len(memo) >= 4096:
                    memo.clear()
                memo[key] = (self._version, r)
        finally:
            self._lock.release()
        return _make_ts(target_frame, source_frame, *r)

    def lookup_transform_core(self, target_frame: str, source_frame: str, time: TimeArg) -> TransformStamped:
        """tf2_py spelling."""
        return self.lookup_transform(target_frame, source_frame, time)

    def _lookup(self, target: str, source: str, t: int) -> tuple:
        """(stamp, tx, ty, tz, qx, qy, qz, qw) or a tf2 exception; call with the lock held."""
        if target == source:
            if t == 0:
                cid = self._ids.get(target)
                cache = self._caches[cid] if cid is not None else None
                if cache is not None:
                    t = cache.newest_stamp()
            return (t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        target_id = self._validate("lookupTransform argument target_frame", target)
        source_id = self._validate("lookupTransform argument source_frame", source)
        if t == 0:
            t = self._latest_common_time(target_id, source_id)
        caches = self._caches

        # source walk: accumulate source -> top
        frame = source_id
        top = frame
        depth = 0
        sx = sy = sz = sqx = sqy = sqz = 0.0
        sqw = 1.0
        extrap_frame = 0
        while frame:
            cache = caches[frame]
            if cache is None:
                top = frame
                break
            s = cache.get(t)
            if s is None:
                top = frame
                extrap_frame = frame
                break
            if frame == target_id:
                return (t, sx, sy, sz, sqx, sqy, sqz, sqw)
            p, px, py, pz, x, y, z, w = s
            if depth:
                # v = quatRotate(q, v) + p ; q_acc = q * q_acc
                ax = w * sx + y * sz - z * sy
                ay = w * sy + z * sx - x * sz
                az = w * sz + x * sy - y * sx
                aw = -x * sx - y * sy - z * sz
                sx = -aw * x + ax * w - ay * z + az * y + px
                sy = -aw * y + ay * w - az * x + ax * z + py
                sz = -aw * z + az * w - ax * y + ay * x + pz
                sqx, sqy, sqz, sqw = (w * sqx + x * sqw + y * sqz - z * sqy,
                                      w * sqy + y * sqw + z * sqx - x * sqz,
                                      w * sqz + z * sqw + x * sqy - y * sqx,
                                      w * sqw - x * sqx - y * sqy - z * sqz)
            else:
                sx, sy, sz, sqx, sqy, sqz, sqw = px, py, pz, x, y, z, w
            top = frame
            frame = p
            depth += 1
            if depth > MAX_GRAPH_DEPTH:
                raise LookupException(self._loop_message())

        source_links = depth
        # target walk: accumulate target -> top
        frame = target_id
        depth = 0
        tx = ty = tz = tqx = tqy = tqz = 0.0
        tqw = 1.0
        while frame != top:
            cache = caches[frame]
            if cache is None:
                break
            s = cache.get(t)
            if s is None:
                raise ExtrapolationException(
                    f"{cache.error(t)}, when looking up transform from frame [{source}] to frame [{target}]")
            p, px, py, pz, x, y, z, w = s
            if frame == source_id:
                # source is an ancestor of target: result = inverse(target -> source)
                return (t, *_inverse(tx, ty, tz, tqx, tqy, tqz, tqw))
            if depth:
                ax = w * tx + y * tz - z * ty
                ay = w * ty + z * tx - x * tz
                az = w * tz + x * ty - y * tx
                aw = -x * tx - y * ty - z * tz
                tx = -aw * x + ax * w - ay * z + az * y + px
                ty = -aw * y + ay * w - az * x + ax * z + py
                tz = -aw * z + az * w - ax * y + ay * x + pz
                tqx, tqy, tqz, tqw = (w * tqx + x * tqw + y * tqz - z * tqy,
                                      w * tqy + y * tqw + z * tqx - x * tqz,
                                      w * tqz + z * tqw + x * tqy - y * tqx,
                                      w * tqw - x * tqx - y * tqy - z * tqz)
            else:
                tx, ty, tz, tqx, tqy, tqz, tqw = px, py, pz, x, y, z, w
            frame = p
            depth += 1
            if depth > MAX_GRAPH_DEPTH:
                raise LookupException(self._loop_message())
        if frame != top:
            if extrap_frame:
                raise ExtrapolationException(
                    f"{caches[extrap_frame].error(t)}, when looking up transform from frame [{source}] "
                    f"to frame [{target}]")
            raise ConnectivityException(self._connectivity_message(source_id, target_id))

        # full path: inverse(target -> top) * (source -> top); when one side is empty this is
        # exactly the other side (identity terms add zeros), so skip the arithmetic
        if not depth:
            return (t, sx, sy, sz, sqx, sqy, sqz, sqw)
        if not source_links:
            return (t, *_inverse(tx, ty, tz, tqx, tqy, tqz, tqw))
        ix, iy, iz, iqx, iqy, iqz, iqw = _inverse(tx, ty, tz, tqx, tqy, tqz, tqw)
        x, y, z, w = iqx, iqy, iqz, iqw
        ax = w * sx + y * sz - z * sy
        ay = w * sy + z * sx - x * sz
        az = w * sz + x * sy - y * sx
        aw = -x * sx - y * sy - z * sz
        return (t,
                -aw * x + ax * w - ay * z + az * y + ix,
                -aw * y + ay * w - az * x + ax * z + iy,
                -aw * z + az * w - ax * y + ay * x + iz,
                w * sqx + x * sqw + y * sqz - z * sqy,
                w * sqy + y * sqw + z * sqx - x * sqz,
                w * sqz + z * sqw + x * sqy - y * sqx,
                w * sqw - x * sqx - y * sqy - z * sqz)

    def lookup_transform_full(self, target_frame: str, target_time: TimeArg, source_frame: str,
                              source_time: TimeArg, fixed_frame: str) -> TransformStamped:
        """Source at source_time -> fixed frame -> target at target_time (tf2 advanced lookup)."""
        tt = _ns(target_time)
        st = _ns(source_time)
        with self._lock:
            self._validate("lookupTransform argument target_frame", target_frame)
            self._validate("lookupTransform argument source_frame", source_frame)
            self._validate("lookupTransform argument fixed_frame", fixed_frame)
            a = self._lookup(fixed_frame, source_frame, st)
            b = self._lookup(target_frame, fixed_frame, tt)
        # tf2 composes these as tf2::Transform (rotation matrices), then converts back to a quaternion
        from .math3d import matrix_from_quaternion, quaternion_from_matrix
        ma = matrix_from_quaternion(a[4:8])
        mb = matrix_from_quaternion(b[4:8])
        m = [[mb[i][0] * ma[0][j] + mb[i][1] * ma[1][j] + mb[i][2] * ma[2][j] for j in range(3)]
             for i in range(3)]
        o = [mb[i][0] * a[1] + mb[i][1] * a[2] + mb[i][2] * a[3] + b[1 + i] for i in range(3)]
        q = quaternion_from_matrix(m)
        return _make_ts(target_frame, source_frame, b[0], o[0], o[1], o[2], *q)

    def lookup_transform_full_core(self, target_frame: str, target_time: TimeArg, source_frame: str,
                                   source_time: TimeArg, fixed_frame: str) -> TransformStamped:
        """tf2_py spelling."""
        return self.lookup_transform_full(target_frame, target_time, source_frame, source_time, fixed_frame)

    def can_transform(self, target_frame: str, source_frame: str, time: TimeArg,
                      return_debug_tuple: bool = False) -> Union[bool, tuple[bool, str]]:
        """Whether lookup_transform would succeed; (bool, reason) if return_debug_tuple."""
        t = _ns(time)
        with self._lock:
            ok, msg = self._can(target_frame, source_frame, t, "canTransform")
        return (ok, msg) if return_debug_tuple else ok

    def can_transform_core(self, target_frame: str, source_frame: str, time: TimeArg) -> tuple[bool, str]:
        """tf2_py spelling: always (bool, reason)."""
        return self.can_transform(target_frame, source_frame, time, True)  # type: ignore[return-value]

    def can_transform_full(self, target_frame: str, target_time: TimeArg, source_frame: str,
                           source_time: TimeArg, fixed_frame: str,
                           return_debug_tuple: bool = False) -> Union[bool, tuple[bool, str]]:
        """Advanced can_transform: target<-fixed at target_time and fixed<-source at source_time."""
        tt = _ns(target_time)
        st = _ns(source_time)
        with self._lock:
            ok, msg = self._can_full(target_frame, tt, source_frame, st, fixed_frame)
        return (ok, msg) if return_debug_tuple else ok

    def can_transform_full_core(self, target_frame: str, target_time: TimeArg, source_frame: str,
                                source_time: TimeArg, fixed_frame: str) -> tuple[bool, str]:
        """tf2_py spelling: always (bool, reason)."""
        return self.can_transform_full(target_frame, target_time, source_frame, source_time,  # type: ignore[return-value]
                                       fixed_frame, True)

    def _can_full(self, target: str, tt: int, source: str, st: int, fixed: str) -> tuple[bool, str]:
        """tf2 0.7.6's advanced canTransform, including its message quirks (probed)."""
        if (self._warn_frame_id("canTransform argument target_frame", target)
                or self._warn_frame_id("canTransform argument source_frame", source)
                or self._warn_frame_id("canTransform argument fixed_frame", fixed)):
            return False, ""
        ids = self._ids
        tid, sid, fid = ids.get(target, 0), ids.get(source, 0), ids.get(fixed, 0)
        if not (tid and sid and fid):
            msg = ""
            if not tid:
                msg += f"canTransform: target_frame {target} does not exist."
            if not sid:
                msg += (" " if not tid else "") + f"canTransform: source_frame {source} does not exist."
                # tf2 tests source_id again here instead of fixed_id, so this line appears (with
                # no space before "does") exactly when the *source* is unknown
                msg += f" fixed_frame: {fixed}does not exist."
            return False, msg
        ok, msg = self._can_ids(tid, fid, tt)
        if not ok:
            return False, msg
        return self._can_ids(fid, sid, st)

    def _can(self, target: str, source: str, t: int, fn: str) -> tuple[bool, str]:
        if target == source:
            return True, ""
        if self._warn_frame_id(f"{fn} argument target_frame", target):
            return False, ""
        if self._warn_frame_id(f"{fn} argument source_frame", source):
            return False, ""
        target_id = self._ids.get(target, 0)
        source_id = self._ids.get(source, 0)
        if not target_id or not source_id:
            parts = []
            if not target_id:
                parts.append(f"{fn}: target_frame {target} does not exist.")
            if not source_id:
                parts.append(f"{fn}: source_frame {source} does not exist.")
            return False, " ".join(parts)
        return self._can_ids(target_id, source_id, t)

    def _can_ids(self, target_id: int, source_id: int, t: int) -> tuple[bool, str]:
        """tf2 canTransformNoLock: the lookup walk on parents only."""
        if not target_id or not source_id:
            return False, ""
        if target_id == source_id:
            return True, ""
        try:
            if t == 0:
                t = self._latest_common_time(target_id, source_id)
        except TransformException as e:
            return False, str(e)
        caches = self._caches
        frame = source_id
        top = frame
        depth = 0
        extrap_frame = 0
        while frame:
            cache = caches[frame]
            if cache is None:
                top = frame
                break
            p = cache.parent_at(t)
            if not p:
                top = frame
                extrap_frame = frame
                break
            if frame == target_id:
                return True, ""
            top = frame
            frame = p
            depth += 1
            if depth > MAX_GRAPH_DEPTH:
                return False, self._loop_message()
        frame = target_id
        depth = 0
        while frame != top:
            cache = caches[frame]
            if cache is None:
                break
            p = cache.parent_at(t)
            if not p:
                return False, (f"{cache.error(t)}, when looking up transform from frame "
                               f"[{self._names[source_id]}] to frame [{self._names[target_id]}]")
            if frame == source_id:
                return True, ""
            frame = p
            depth += 1
            if depth > MAX_GRAPH_DEPTH:
                return False, self._loop_message()
        if frame != top:
            if extrap_frame:
                return False, (f"{caches[extrap_frame].error(t)}, when looking up transform from frame "
                               f"[{self._names[source_id]}] to frame [{self._names[target_id]}]")
            return False, self._connectivity_message(source_id, target_id)
        return True, ""

    # ------------------------------------------------------------------------ latest common time

    def get_latest_common_time(self, target_frame: str, source_frame: str) -> Time:
        """Newest time at which the whole chain has data (0 if every link is static)."""
        with self._lock:
            tid = self._validate("get_latest_common_time", target_frame)
            sid = self._validate("get_latest_common_time", source_frame)
            return Time(nanoseconds=self._latest_common_time(tid, sid))

    def _latest_common_time(self, target_id: int, source_id: int) -> int:
        caches = self._caches
        if source_id == target_id:
            cache = caches[source_id]
            return cache.newest_stamp() if cache is not None else 0
        big = MAX_STAMP_NS + 1  # 'no dynamic link yet': above every stamp a cache can hold
        # walk up from the source, recording (newest stamp, parent) per link; a cache's newest
        # stamp is -1 when empty (no parent: stop), 0 for statics (ignored in the minimum)
        stamps: list[int] = []
        parents: list[int] = []
        frame = source_id
        depth = 0
        common = big
        while frame:
            cache = caches[frame]
            if cache is None:
                break
            stamp = cache.newest
            if stamp < 0:
                break
            parent = cache.parents[-1]
            if stamp and stamp < common:
                common = stamp
            stamps.append(stamp)
            parents.append(parent)
            frame = parent
            if frame == target_id:
                return 0 if common == big else common
            depth += 1
            if depth > MAX_GRAPH_DEPTH:
                raise LookupException(self._loop_message())
        # walk up from the target until a parent is common with the source's chain
        frame = target_id
        depth = 0
        common = big
        common_parent = 0
        source_parents = set(parents)
        while True:
            cache = caches[frame]
            if cache is None:
                break
            stamp = cache.newest
            if stamp < 0:
                break
            parent = cache.parents[-1]
            if stamp and stamp < common:
                common = stamp
            if parent in source_parents:
                common_parent = parent
                break
            frame = parent
            if frame == source_id:
                return 0 if common == big else common
            depth += 1
            if depth > MAX_GRAPH_DEPTH:
                raise LookupException(self._loop_message())
        if not common_parent:
            raise ConnectivityException(self._connectivity_message(source_id, target_id))
        for stamp, parent in zip(stamps, parents):
            if stamp and stamp < common:
                common = stamp
            if parent == common_parent:
                break
        return 0 if common == big else common

    # ------------------------------------------------------------------------ helpers

    def _validate(self, what: str, frame: str) -> int:
        if not frame:
            raise InvalidArgumentException(f"Invalid argument passed to {what} in tf2 frame_ids cannot be empty")
        if frame[0] == "/":
            raise InvalidArgumentException(
                f"Invalid argument \"{frame}\" passed to {what} in tf2 frame_ids cannot start with a '/' like: ")
        fid = self._ids.get(frame, 0)
        if not fid:
            raise LookupException(f"\"{frame}\" passed to {what} does not exist. ")
        return fid

    def _warn_frame_id(self, what: str, frame: str) -> bool:
        if not frame:
            self._warn.log(_WARNING, ("invalid_argument", what),
                           "Invalid argument passed to %s in tf2 frame_ids cannot be empty", what)
            return True
        if frame[0] == "/":
            self._warn.log(_WARNING, ("invalid_argument", what),
                           "Invalid argument \"%s\" passed to %s in tf2 frame_ids cannot start with a '/' like: ",
                           frame, what)
            return True
        return False

    def _connectivity_message(self, source_id: int, target_id: int) -> str:
        return (f"Could not find a connection between '{self._names[target_id]}' and "
                f"'{self._names[source_id]}' because they are not part of the same tree."
                "Tf has two or more unconnected trees.")

    def _loop_message(self) -> str:
        return f"The tf tree is invalid because it contains a loop.\n{self._frames_as_string()}\n"

    # ------------------------------------------------------------------------ introspection

    def all_frames_as_string(self) -> str:
        """'Frame CHILD exists with parent PARENT.' per frame with a cache, first-seen order."""
        with self._lock:
            return self._frames_as_string()

    def _frames_as_string(self) -> str:
        names = self._names
        out = []
        for fid in range(1, len(self._caches)):
            cache = self._caches[fid]
            if cache is None:
                continue
            s = cache.get(0)
            out.append(f"Frame {names[fid]} exists with parent {names[s[0] if s else 0]}.\n")
        return "".join(out)

    def all_frames_as_yaml(self, current_time: Optional[TimeArg] = None) -> str:
        """tf2's YAML frame report (parent, broadcaster, rate, most recent, oldest, buffer length)."""
        now = _ns(current_time) if current_time is not None else 0
        with self._lock:
            infos = self._frame_info()
        if not infos:
            return "{}"  # ROS 1 prints {} for an empty buffer (ROS 2 prints [])
        out = []
        for i in infos:
            newest = i["most_recent_transform"].to_sec()
            oldest = i["oldest_transform"].to_sec()
            out.append(f"{i['frame']}: \n  parent: '{i['parent']}'\n  broadcaster: '{i['broadcaster']}'\n"
                       f"  rate: {i['rate']:.3f}\n  most_recent_transform: {newest:.3f}\n"
                       f"  oldest_transform: {oldest:.3f}\n")
            if now:
                out.append(f"  transform_delay: {(now - i['most_recent_transform'].nanoseconds) / 1e9:.3f}\n")
            out.append(f"  buffer_length: {(i['most_recent_transform'] - i['oldest_transform']).to_sec():.3f}\n")
        return "".join(out)

    def frame_info(self) -> list[dict[str, Any]]:
        """Per child frame with data: frame, parent, broadcaster (authority), static, samples,
        most_recent_transform and oldest_transform (Time), rate (Hz, as tf2 computes it)."""
        with self._lock:
            return self._frame_info()

    def _frame_info(self) -> list[dict[str, Any]]:
        names = self._names
        out = []
        for fid in range(1, len(self._caches)):
            cache = self._caches[fid]
            if cache is None:
                continue
            s = cache.get(0)
            if s is None:
                continue
            newest, oldest, n = cache.newest_stamp(), cache.oldest_stamp(), len(cache)
            out.append({
                "frame": names[fid], "parent": names[s[0]],
                "broadcaster": cache.authority,
                "static": cache.is_static, "samples": n,
                "most_recent_transform": Time(nanoseconds=newest),
                "oldest_transform": Time(nanoseconds=oldest),
                "rate": n / max(newest / 1e9 - oldest / 1e9, 0.0001),
            })
        return out

    def get_frames(self) -> list[str]:
        """Every frame name ever seen, as child or parent (tf2 _getFrameStrings)."""
        with self._lock:
            return self._names[1:]

    def frame_exists(self, frame_id: str) -> bool:
        with self._lock:
            return self._ids.get(frame_id, 0) != 0

    _frameExists = frame_exists

    def get_parent(self, frame_id: str, time: TimeArg = 0) -> Optional[str]:
        """Parent of frame_id at time, or None (root, unknown frame or no data at that time)."""
        t = _ns(time)
        with self._lock:
            fid = self._ids.get(frame_id, 0)
            cache = self._caches[fid] if fid else None
            if cache is None:
                return None
            p = cache.parent_at(t)
            return self._names[p] if p else None

    def chain_as_vector(self, target_frame: str, target_time: TimeArg, source_frame: str,
                        source_time: TimeArg, fixed_frame: str) -> list[str]:
        """Frame names from source to target through fixed (tf2 _chainAsVector; used by monitors)."""
        st, tt = _ns(source_time), _ns(target_time)
        with self._lock:
            tid = self._validate("chainAsVector argument target_frame", target_frame)
            sid = self._validate("chainAsVector argument source_frame", source_frame)
            fid = self._validate("chainAsVector argument fixed_frame", fixed_frame)
            first = self._path(fid, sid, st)       # source ... fixed
            second = self._path(tid, fid, tt)      # fixed ... target
        if not first:
            return second
        if not second:
            return first
        # join at the fixed frame, dropping frames walked back and forth
        chain = first + second[1:]
        while True:
            for i in range(1, len(chain) - 1):
                if chain[i - 1] == chain[i + 1]:
                    del chain[i:i + 2]
                    break
            else:
                return chain

    _chainAsVector = chain_as_vector

    def _path(self, target_id: int, source_id: int, t: int) -> list[str]:
        """Frame names from source up to the common ancestor and down to target, at time t."""
        if target_id == source_id:
            return []
        if t == 0:
            t = self._latest_common_time(target_id, source_id)
        ok, msg = self._can_ids(target_id, source_id, t)
        if not ok:
            if "loop" in msg:
                raise LookupException(msg)
            if msg.startswith("Could not find a connection"):
                raise ConnectivityException(msg)
            raise ExtrapolationException(msg)
        up_s = self._ancestors(source_id, t)
        up_t = self._ancestors(target_id, t)
        in_t = {f: i for i, f in enumerate(up_t)}
        for i, f in enumerate(up_s):
            if f in in_t:
                ids = up_s[:i + 1] + list(reversed(up_t[:in_t[f]]))
                return [self._names[x] for x in ids]
        raise ConnectivityException(self._connectivity_message(source_id, target_id))

    def _ancestors(self, frame: int, t: int) -> list[int]:
        out = [frame]
        for _ in range(MAX_GRAPH_DEPTH + 1):
            cache = self._caches[frame]
            if cache is None:
                break
            p = cache.parent_at(t)
            if not p:
                break
            out.append(p)
            frame = p
        return out

    def _all_frames_as_dot(self, current_time: Optional[TimeArg] = None) -> str:
        """Graphviz text like tf2's _allFramesAsDot (view_frames)."""
        now = _ns(current_time) if current_time is not None else 0
        infos = self.frame_info()
        lines = ["digraph G {"]
        if not infos:
            lines.append('"no tf data recieved"')
        children = set()
        for i in infos:
            children.add(i["frame"])
            newest = i["most_recent_transform"]
            age = f"( {(now - newest.nanoseconds) / 1e9:.3f} sec old)" if now else ""
            lines.append(
                f'"{i["parent"]}" -> "{i["frame"]}"[label="Broadcaster: {i["broadcaster"]}\\n'
                f'Average rate: {i["rate"]:.3f} Hz\\nMost recent transform: {newest.to_sec():.3f} {age}\\n'
                f'Buffer length: {(newest - i["oldest_transform"]).to_sec():.3f} sec\\n"];')
        for root in sorted({i["parent"] for i in infos} - children):
            lines.append("edge [style=invis];")
            lines.append(' subgraph cluster_legend { style=bold; color=black; label ="view_frames Result";\n'
                         + (f'"Recorded at time: {now / 1e9:.3f}"[ shape=plaintext ] ;\n ' if now else "")
                         + f'}}->"{root}";')
        lines.append("}")
        return "\n".join(lines)

    def memory_bytes(self) -> int:
        """Bytes held in sample storage (arrays), for the memory benchmark."""
        with self._lock:
            return sum(c.nbytes() for c in self._caches if c is not None)

    # ------------------------------------------------------------------------ transformable requests

    def add_transformable_request(self, cb: Callable[[int, str, str, Time, TransformableResult], None],
                                  target_frame: str, source_frame: str, time: TimeArg) -> int:
        """Ask to be called back once target<-source is transformable at time (tf2 1.13).

        Returns 0 if it already is (or target == source; cb is NOT called), NEVER_TRANSFORMABLE
        if the time is older than the cache can ever hold, else a handle. Later, right after an
        insert, ``cb(handle, target, source, time, TransformableResult)`` runs once (outside the
        lock) with TransformAvailable, or TransformFailure once the time fell out of the cache.
        """
        t = _ns(time)
        if target_frame == source_frame:
            return 0
        with self._lock:
            tid = self._ids.get(target_frame, 0)
            sid = self._ids.get(source_frame, 0)
            if self._can_ids(tid, sid, t)[0]:
                return 0
            if tid and sid:
                try:
                    latest = self._latest_common_time(tid, sid)
                except TransformException:
                    latest = 0
                if latest and t + self._cache_ns < latest:
                    return NEVER_TRANSFORMABLE
            self._request_counter += 1
            if self._request_counter >= NEVER_TRANSFORMABLE:
                self._request_counter = 1
            handle = self._request_counter
            self._requests.append(_Request(handle, cb, target_frame, source_frame, t))
            return handle

    def cancel_transformable_request(self, handle: int) -> None:
        with self._lock:
            self._requests = [r for r in self._requests if r.handle != handle]

    def _test_transformable_requests(self) -> None:
        fire: list[tuple[_Request, TransformableResult]] = []
        with self._lock:
            keep = []
            for req in self._requests:
                tid = self._ids.get(req.target, 0)
                sid = self._ids.get(req.source, 0)
                latest = 0
                if tid and sid:
                    try:
                        latest = self._latest_common_time(tid, sid)
                    except TransformException:
                        latest = 0
                if latest and req.time + self._cache_ns < latest:
                    fire.append((req, TransformableResult.TransformFailure))
                elif self._can_ids(tid, sid, req.time)[0]:
                    fire.append((req, TransformableResult.TransformAvailable))
                else:
                    keep.append(req)
            self._requests = keep
        for req, result in fire:
            try:
                req.cb(req.handle, req.target, req.source, Time(nanoseconds=req.time), result)
            except Exception:
                logger.exception("transformable request callback failed")

    # ------------------------------------------------------------------------ data helpers

    def transform(self, obj: Any, target_frame: str, new_type: Any = None) -> Any:
        """Transform a stamped message into target_frame at its own stamp (see zentf.core.geometry)."""
        from .geometry import transform as _transform
        return _transform(self, obj, target_frame, new_type)

    def transform_points(self, points: Any, target_frame: str, source_frame: str, time: TimeArg) -> Any:
        """points[N,3] given in source_frame -> target_frame at time, one numpy pass."""
        from .geometry import transform_points as _tp
        return _tp(self, points, target_frame, source_frame, time)

    def lookup_transforms(self, target_frame: str, source_frame: str, times: Any) -> Any:
        """Vectorized lookup_transform over times[N]: (translations[N,3], quaternions[N,4])."""
        from .geometry import lookup_transforms as _lt
        return _lt(self, target_frame, source_frame, times)

    # ------------------------------------------------------------------------ velocity (ROS 2 tf2)

    def lookup_velocity(self, tracking_frame: str, observation_frame: str, time: TimeArg,
                        averaging_interval: Union[Duration, float, int]) -> Any:
        """ROS 2 tf2 ``lookupVelocity``: a VelocityStamped of tracking_frame seen from observation_frame."""
        from .velocity import lookup_velocity as _lv
        return _lv(self, tracking_frame, observation_frame, time, averaging_interval)

    def lookup_velocity_full(self, tracking_frame: str, observation_frame: str, reference_frame: str,
                             reference_point: Any, reference_point_frame: str, time: TimeArg,
                             averaging_interval: Union[Duration, float, int]) -> Any:
        """ROS 2 tf2 ``lookupVelocity`` with a reference frame and a reference point (zentf.core.velocity)."""
        from .velocity import lookup_velocity_full as _lvf
        return _lvf(self, tracking_frame, observation_frame, reference_frame, reference_point,
                    reference_point_frame, time, averaging_interval)


def _inverse(tx: float, ty: float, tz: float, x: float, y: float, z: float, w: float) -> tuple:
    """Inverse of (t, q) as tf2 computes it: q⁻¹ = conjugate, t' = quatRotate(q⁻¹, −t)."""
    x, y, z = -x, -y, -z
    vx, vy, vz = -tx, -ty, -tz
    ax = w * vx + y * vz - z * vy
    ay = w * vy + z * vx - x * vz
    az = w * vz + x * vy - y * vx
    aw = -x * vx - y * vy - z * vz
    return (-aw * x + ax * w - ay * z + az * y,
            -aw * y + ay * w - az * x + ax * z,
            -aw * z + az * w - ax * y + ay * x,
            x, y, z, w)
