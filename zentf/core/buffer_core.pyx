# cython: language_level=3, annotation_typing=False
"""BufferCore: tf2's transform tree with the exact semantics of ROS 1 tf2 (geometry2 0.7.x), compiled.

The differential tests hold this module to Debian's python3-tf2 (the "oracle"), op by op. Where
the behaviour follows ROS 1 and ROS 2 differs, the ROS 1 choice is kept and said so in a comment:
the first cache type of a frame is kept on a static/dynamic switch, a repeated stamp is refused
(TF_REPEATED_DATA, the first sample wins), old samples are pruned right after an insert, and
messages use ROS 1 wording (times with 9 decimals, "Ds into the future").

Each frame is an integer id with one cache object (zentf.core.cache: TimeCache for dynamic
frames, StaticCache for static ones), as tf2 keeps one TimeCacheInterface per frame. One lock
guards everything so a listener thread may insert while user threads look up.

This is a Cython module (built by ``pip install``; see docs/architecture.md): the walk, the
latest common time, inserts and the caches run in C over plain arrays, and only the answer
becomes Python objects. Errors, logging and the rarely used tools stay ordinary Python code in
this same file. A direct-mapped table remembers recent answers by (target, source, time) while a
version counter (bumped by every stored change) is unchanged.
"""
from libc.stdint cimport int32_t, int64_t, uint64_t
from libc.stdlib cimport free, malloc, realloc
from cpython.dict cimport PyDict_GetItem
from cpython.unicode cimport PyUnicode_Check, PyUnicode_GET_LENGTH, PyUnicode_READ_CHAR
from cpython.long cimport PyLong_AsLongLongAndOverflow
from cpython.object cimport PyObject
from cpython.tuple cimport PyTuple_GET_ITEM, PyTuple_GET_SIZE
from cpython.list cimport PyList_GET_ITEM
from cpython.object cimport PyTypeObject
from cpython.pythread cimport (NOWAIT_LOCK, WAIT_LOCK, PyThread_acquire_lock, PyThread_allocate_lock,
                               PyThread_free_lock, PyThread_release_lock, PyThread_type_lock)
from cpython.ref cimport Py_INCREF


cdef extern from "Python.h":
    object PyType_GenericAlloc(object tp, Py_ssize_t nitems)
    ctypedef struct PyMemberDef:
        Py_ssize_t offset
    ctypedef struct PyMemberDescrObject:
        PyMemberDef* d_member
    PyTypeObject PyMemberDescr_Type
    int PyThread_acquire_lock_timed(PyThread_type_lock lock, long long microseconds, int intr_flag) nogil
    enum: PY_LOCK_ACQUIRED

from .cache cimport CacheBase, StaticCache, TimeCache
from .time cimport Duration, Time

import logging
import math
from enum import IntEnum
from typing import Any, Callable, Iterable, Optional, Sequence, Union

from .constants import (DEFAULT_CACHE_TIME, DEFAULT_MAX_FRAME_ID_LENGTH, DEFAULT_MAX_FRAMES, MAX_GRAPH_DEPTH,
                        MAX_STAMP_NS)
from .constants import INSERT_OK as _OK
from .constants import INSERT_OLD as _OLD
from .exceptions import (ConnectivityException, ExtrapolationException, InvalidArgumentException,
                         LookupException, TransformException)
from .messages import Header, Quaternion, Transform, TransformStamped, Vector3
from .ratelimit import RateLimitedLogger
from .time import NSEC_PER_SEC, ns_from_sec

__all__ = ["BufferCore", "TransformableResult", "NEVER_TRANSFORMABLE", "DEFAULT_CACHE_TIME",
           "MAX_GRAPH_DEPTH"]

logger = logging.getLogger("zentf.core.buffer_core")
_ERROR, _WARNING = logging.ERROR, logging.WARNING
_INFINITIES = (math.inf, -math.inf)

#: Handle returned by add_transformable_request when the request can never succeed (tf2 value).
NEVER_TRANSFORMABLE = 0xFFFFFFFFFFFFFFFF

cdef enum:
    _MAX_DEPTH = 1000       # MAX_GRAPH_DEPTH (checked at import below)
    _MEMO_SLOTS = 256       # direct-mapped answer table (a power of two)
    # what a walk found when it did not return an answer
    _W_OK = 0
    _W_EXTRAP = 1           # a cache had no data at the time (frame in *bad)
    _W_EXTRAP_TARGET = 2    # same, on the target side (tf2 raises at once, frame in *bad)
    _W_CONNECT = 3          # not part of the same tree
    _W_LOOP = 4             # longer than MAX_GRAPH_DEPTH
    _W_SPLIT = 5            # over a range of times: some time would walk otherwise (plan.split)

assert MAX_GRAPH_DEPTH == _MAX_DEPTH

cdef int64_t _MAX_STAMP = 9223372036854775807
cdef uint64_t _GOLDEN = 11400714819323198485u   # 2^64 / golden ratio: spreads times over the memo table

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
        return (<Time>t)._ns
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


cdef Py_ssize_t _slot_offset(object cls, str name) except? -2:
    """Byte offset of a __slots__ field (the messages are slotted dataclasses); -1 if not a slot."""
    for klass in cls.__mro__:
        d = klass.__dict__.get(name)
        if d is not None:
            td = type(d)
            if <PyObject*>td != <PyObject*>&PyMemberDescr_Type:
                return -1
            return (<PyMemberDescrObject*><PyObject*>d).d_member.offset
    return -1


cdef Py_ssize_t _O_STAMP = _slot_offset(Header, "stamp")
cdef Py_ssize_t _O_FRAME = _slot_offset(Header, "frame_id")
cdef Py_ssize_t _O_X = _slot_offset(Vector3, "x")
cdef Py_ssize_t _O_Y = _slot_offset(Vector3, "y")
cdef Py_ssize_t _O_Z = _slot_offset(Vector3, "z")
cdef Py_ssize_t _O_QX = _slot_offset(Quaternion, "x")
cdef Py_ssize_t _O_QY = _slot_offset(Quaternion, "y")
cdef Py_ssize_t _O_QZ = _slot_offset(Quaternion, "z")
cdef Py_ssize_t _O_QW = _slot_offset(Quaternion, "w")
cdef Py_ssize_t _O_TRANS = _slot_offset(Transform, "translation")
cdef Py_ssize_t _O_ROT = _slot_offset(Transform, "rotation")
cdef Py_ssize_t _O_HEADER = _slot_offset(TransformStamped, "header")
cdef Py_ssize_t _O_CHILD = _slot_offset(TransformStamped, "child_frame_id")
cdef Py_ssize_t _O_TF = _slot_offset(TransformStamped, "transform")
#: every field a slot: answers are built by filling slots of freshly allocated objects directly
cdef bint _SLOTS = min(_O_STAMP, _O_FRAME, _O_X, _O_Y, _O_Z, _O_QX, _O_QY, _O_QZ, _O_QW, _O_TRANS,
                       _O_ROT, _O_HEADER, _O_CHILD, _O_TF) >= 0
cdef object _HeaderT = Header, _Vector3T = Vector3, _QuaternionT = Quaternion
cdef object _TransformT = Transform, _TransformStampedT = TransformStamped


cdef inline void _put(object o, Py_ssize_t offset, object v) noexcept:
    """Store v in the (empty) slot at offset of a freshly allocated object."""
    Py_INCREF(v)
    (<PyObject**>((<char*><PyObject*>o) + offset))[0] = <PyObject*>v


cdef object _make_ts_c(object target, object source, int64_t stamp, const double* v):
    """A TransformStamped built without dataclass __init__ (the hot path of every lookup).

    Same objects as TransformStamped(header=Header(stamp=Time(...), ...), ...) would give:
    allocated as object.__new__ does, each slot filled once (tf2_ros users get plain messages).
    """
    cdef Time tm = Time.__new__(Time)  # (an extension type: its tp_new, no __init__)
    tm._ns = stamp
    if not _SLOTS:  # (messages without __slots__: the generic way)
        ts = TransformStamped(header=Header(stamp=tm, frame_id=target), child_frame_id=source,
                              transform=Transform(translation=Vector3(x=v[0], y=v[1], z=v[2]),
                                                  rotation=Quaternion(x=v[3], y=v[4], z=v[5], w=v[6])))
        return ts
    h = PyType_GenericAlloc(_HeaderT, 0)
    _put(h, _O_STAMP, tm)
    _put(h, _O_FRAME, target)
    vec = PyType_GenericAlloc(_Vector3T, 0)
    _put(vec, _O_X, v[0])
    _put(vec, _O_Y, v[1])
    _put(vec, _O_Z, v[2])
    q = PyType_GenericAlloc(_QuaternionT, 0)
    _put(q, _O_QX, v[3])
    _put(q, _O_QY, v[4])
    _put(q, _O_QZ, v[5])
    _put(q, _O_QW, v[6])
    tr = PyType_GenericAlloc(_TransformT, 0)
    _put(tr, _O_TRANS, vec)
    _put(tr, _O_ROT, q)
    ts = PyType_GenericAlloc(_TransformStampedT, 0)
    _put(ts, _O_HEADER, h)
    _put(ts, _O_CHILD, source)
    _put(ts, _O_TF, tr)
    return ts


def _make_ts(target: str, source: str, stamp: int, tx: float, ty: float, tz: float,
             qx: float, qy: float, qz: float, qw: float) -> TransformStamped:
    """Build a TransformStamped without dataclass __init__ overhead."""
    cdef double v[7]
    v[0], v[1], v[2], v[3], v[4], v[5], v[6] = tx, ty, tz, qx, qy, qz, qw
    return _make_ts_c(target, source, stamp, v)


cdef inline void _compose(double* acc, const double* s) noexcept nogil:
    """acc = s ∘ acc: v = quatRotate(q, v) + p ; q_acc = q * q_acc (tf2's accumulation order)."""
    cdef double x = s[3], y = s[4], z = s[5], w = s[6]
    cdef double sx = acc[0], sy = acc[1], sz = acc[2]
    cdef double qx = acc[3], qy = acc[4], qz = acc[5], qw = acc[6]
    cdef double ax = w * sx + y * sz - z * sy
    cdef double ay = w * sy + z * sx - x * sz
    cdef double az = w * sz + x * sy - y * sx
    cdef double aw = -x * sx - y * sy - z * sz
    acc[0] = -aw * x + ax * w - ay * z + az * y + s[0]
    acc[1] = -aw * y + ay * w - az * x + ax * z + s[1]
    acc[2] = -aw * z + az * w - ax * y + ay * x + s[2]
    acc[3] = w * qx + x * qw + y * qz - z * qy
    acc[4] = w * qy + y * qw + z * qx - x * qz
    acc[5] = w * qz + z * qw + x * qy - y * qx
    acc[6] = w * qw - x * qx - y * qy - z * qz


cdef inline int _step(PyObject* cache, int64_t t, int64_t t_hi, int32_t* parent, double* s, bint values,
                      _Link* link, int64_t* split) noexcept:
    """One link of a walk. values: the frame's sample at t. link NULL: only its parent at t (a
    parent of 0: no data, as tf2's getParent). Otherwise the link's data over [t, t_hi], recorded
    in link. 1: data (parent set); 0: no data; -1: that changes at *split (a range only)."""
    if values:
        return (<CacheBase>cache).get_c(t, parent, s)
    if link == NULL:
        parent[0] = (<CacheBase>cache).parent_at_c(t)
        return parent[0] != 0
    return (<CacheBase>cache).span_c(t, t_hi, parent, &link.first, &link.last, split)


cdef inline void _invert(const double* a, double* out) noexcept nogil:
    """Inverse of (t, q) as tf2 computes it: q⁻¹ = conjugate, t' = quatRotate(q⁻¹, −t)."""
    cdef double x = -a[3], y = -a[4], z = -a[5], w = a[6]
    cdef double vx = -a[0], vy = -a[1], vz = -a[2]
    cdef double ax = w * vx + y * vz - z * vy
    cdef double ay = w * vy + z * vx - x * vz
    cdef double az = w * vz + x * vy - y * vx
    cdef double aw = -x * vx - y * vy - z * vz
    out[0] = -aw * x + ax * w - ay * z + az * y
    out[1] = -aw * y + ay * w - az * x + ax * z
    out[2] = -aw * z + az * w - ax * y + ay * x
    out[3] = x
    out[4] = y
    out[5] = z
    out[6] = w



class _Request:
    __slots__ = ("handle", "cb", "target", "source", "time")

    def __init__(self, handle: int, cb: Callable, target: str, source: str, time: int) -> None:
        self.handle, self.cb, self.target, self.source, self.time = handle, cb, target, source, time


cdef inline bint _valid_fast(double tx, double ty, double tz, double qx, double qy, double qz,
                             double qw) noexcept nogil:
    """The common case of tf2's checks: a finite translation and a unit-ish quaternion (no NaN)."""
    cdef double n = qx * qx + qy * qy + qz * qz + qw * qw - 1.0
    return -0.01 < n < 0.01 and (tx + ty + tz) * 0.0 == 0.0


_NO_AUTHORITY = "no recorded authority"  # a frame's authority before its first sample (tf2's text)


cdef inline int32_t _usable_id(dict ids, object frame) noexcept:
    """Id of a frame name usable as given: a known name, not empty, no leading '/' (tf2 refuses
    those in lookups; "NO_PARENT" has id 0); 0 otherwise (the caller takes tf2's full path).
    One dict for every name: no second dict of the clean ones (~26 B a frame)."""
    cdef PyObject* p = PyDict_GetItem(ids, frame)
    if p == NULL or not PyUnicode_Check(frame) or PyUnicode_GET_LENGTH(frame) == 0 or PyUnicode_READ_CHAR(frame, 0) == 47:
        return 0
    return <int32_t><object>p


cdef class _Lock:
    """A plain (non-reentrant) lock like threading.Lock, which the compiled paths take without a
    Python call; Python code uses it as usual (``with core._lock:``, acquire/release)."""

    def __cinit__(self):
        self._lk = PyThread_allocate_lock()
        if self._lk == NULL:
            raise MemoryError()
        self._held = False

    def __dealloc__(self):
        if self._lk != NULL:
            PyThread_free_lock(self._lk)

    cdef int acquire_c(self) except -1:
        if not PyThread_acquire_lock(self._lk, NOWAIT_LOCK):
            with nogil:  # held by another thread: wait without the GIL
                PyThread_acquire_lock(self._lk, WAIT_LOCK)
        self._held = True
        return 0

    cdef void release_c(self) noexcept:
        self._held = False
        PyThread_release_lock(self._lk)

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        cdef long long us
        cdef int r
        if not blocking:
            if timeout != -1:
                raise ValueError("can't specify a timeout for a non-blocking call")
            if not PyThread_acquire_lock(self._lk, NOWAIT_LOCK):
                return False
        elif timeout is None or timeout < 0:
            if timeout is not None and timeout != -1:
                raise ValueError("timeout value must be a non-negative number")
            self.acquire_c()
            return True
        else:
            us = <long long>(timeout * 1e6)
            if not PyThread_acquire_lock(self._lk, NOWAIT_LOCK):
                with nogil:
                    r = PyThread_acquire_lock_timed(self._lk, us, 0)
                if r != PY_LOCK_ACQUIRED:
                    return False
        self._held = True
        return True

    def release(self) -> None:
        if not self._held:
            raise RuntimeError("release unlocked lock")
        self.release_c()

    def locked(self) -> bool:
        return self._held

    def __enter__(self) -> bool:
        self.acquire_c()
        return True

    def __exit__(self, *exc) -> None:
        self.release_c()


# --------------------------------------------------------------------------- BufferCore

cdef class BufferCore:
    """tf2's BufferCore: stores the tree over time and answers lookups (thread-safe).

    Times are ``Time`` or float seconds everywhere (0 = latest). Beyond tf2_py's API:
    ``set_transform_raw``/``set_transforms_raw`` (insert without messages),
    ``add_insert_callback`` (wake waiters), ``add_transformable_request`` (MessageFilter),
    ``frame_info``/``chain_as_vector``/``get_parent``/``frame_exists`` (tools), and the numpy
    batches ``lookup_transforms``/``transform_points`` (zentf.core.batch, over ``chain_plan``).

    Bounds tf2 does not have (deliberate, for memory under hostile input): at most ``max_frames``
    distinct frame names (default 10,000) and frame ids of at most ``max_frame_id_length`` UTF-8
    bytes (default 256); a sample that would pass either is refused with a logged line
    (TF_TOO_MANY_FRAMES, TF_FRAME_ID_TOO_LONG). None lifts a bound; both are plain attributes.
    """


    def __cinit__(self, *args, **kwargs):
        self._memo = <_Memo*>malloc(_MEMO_SLOTS * sizeof(_Memo))
        if self._memo == NULL:
            raise MemoryError()
        for i in range(_MEMO_SLOTS):
            self._memo[i].version = -1
        self._marks = NULL
        self._marks_len = 0
        self._mark_epoch = 0

    def __dealloc__(self):
        free(self._memo)
        free(self._marks)

    def __init__(self, cache_time: Union[Duration, float, int] = DEFAULT_CACHE_TIME, *,
                 max_frames: Optional[int] = DEFAULT_MAX_FRAMES,
                 max_frame_id_length: Optional[int] = DEFAULT_MAX_FRAME_ID_LENGTH) -> None:
        self.max_frames = max_frames
        self.max_frame_id_length = max_frame_id_length
        if isinstance(cache_time, Duration):
            self._cache_ns = cache_time.nanoseconds
        else:
            self._cache_ns = _ns(cache_time)
        self._lock = _Lock()
        # frame id 0 is tf2's "NO_PARENT" sentinel; it never has a cache
        self._ids = {"NO_PARENT": 0}
        self._names = ["NO_PARENT"]
        self._caches = [None]
        # per frame id, the authority of its last accepted sample (tf2 keeps it in the cache; here the
        # caches hold no Python object, so the garbage collector does not track them)
        self._auths = [_NO_AUTHORITY]
        self._requests = []
        self._request_counter = 0
        self._insert_callbacks = []
        self._generation = 0
        self._wake_wanted = 0
        # answers by (target, source, time), valid while _version (bumped by every change of
        # stored data or frame set) is unchanged; errors are never remembered
        self._version = 0
        # refusals log one line per (reason, authority) per 5 s, then how many were suppressed
        # (tf2 logs every one: a flood of bad samples would write megabytes a second)
        self._warn = RateLimitedLogger(logger)

    @property
    def cache_time(self) -> Duration:
        return Duration(nanoseconds=self._cache_ns)

    def set_cache_time(self, cache_time: Union[Duration, float, int]) -> None:
        """Change how much history every dynamic frame keeps (applies to stored frames too)."""
        ns = cache_time.nanoseconds if isinstance(cache_time, Duration) else _ns(cache_time)
        with self._lock:
            self._cache_ns = ns
            for cache in self._caches:
                if type(cache) is TimeCache:
                    (<TimeCache>cache).max_ns = ns
            self._version += 1

    # ------------------------------------------------------------------------ insert

    def set_transform(self, transform: TransformStamped, authority: str, bint is_static=False) -> bool:
        """Insert one sample (tf2 setTransform); False, with a logged reason, if it was refused."""
        h = transform.header
        tr = transform.transform
        v = tr.translation
        q = tr.rotation
        stamp = h.stamp
        stamp = (<Time>stamp)._ns if type(stamp) is Time else stamp.nanoseconds
        ok = self._store(h.frame_id, transform.child_frame_id, stamp, v.x, v.y, v.z, q.x, q.y, q.z, q.w,
                         authority, is_static)
        if ok:
            self._after_insert()
        return ok

    def set_transform_static(self, transform: TransformStamped, authority: str) -> bool:
        """tf2_py spelling of set_transform(..., is_static=True)."""
        return self.set_transform(transform, authority, True)

    def set_transform_raw(self, parent: str, child: str, stamp_ns: int, tx: float, ty: float, tz: float,
                          qx: float, qy: float, qz: float, qw: float, authority: str,
                          bint is_static=False) -> bool:
        """set_transform without building a message (listener fast path); same semantics."""
        ok = self._store(parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw, authority, is_static)
        if ok:
            self._after_insert()
        return ok

    cdef int _append_fast(self, object parent, object child, object stamp, object tx, object ty,
                          object tz, object qx, object qy, object qz, object qw, object authority) except -1:
        """The common case from Python objects: floats and an int stamp go to _append_c; 0 otherwise."""
        cdef double v[7]
        cdef int64_t st
        cdef int overflow = 0
        if not (type(tx) is float and type(ty) is float and type(tz) is float and type(qx) is float
                and type(qy) is float and type(qz) is float and type(qw) is float and type(stamp) is int):
            return 0
        st = PyLong_AsLongLongAndOverflow(stamp, &overflow)
        if overflow or st < 0:
            return 0
        v[0] = tx
        v[1] = ty
        v[2] = tz
        v[3] = qx
        v[4] = qy
        v[5] = qz
        v[6] = qw
        return self._append_c(parent, child, st, v, authority)

    cdef int _append_c(self, object parent, object child, int64_t st, const double* v,
                       object authority) except -1:
        """The common case, in C: a valid sample newer than everything stored, for an edge whose
        frames are known by clean names. 1 if stored, 0 if it needs tf2's full path. Lock held."""
        cdef int32_t cid, pid
        if st < 0 or not _valid_fast(v[0], v[1], v[2], v[3], v[4], v[5], v[6]):
            return 0
        cid = _usable_id(self._ids, child)
        pid = _usable_id(self._ids, parent)
        if not cid or not pid or cid == pid:
            return 0
        cache = self._caches[cid]
        if type(cache) is not TimeCache or not st > (<TimeCache>cache).newest >= 0:
            return 0
        (<TimeCache>cache).insert_c(st, pid, v)
        if PyList_GET_ITEM(self._auths, cid) != <PyObject*>authority:  # most often the same object
            self._auths[cid] = authority
        self._version += 1
        return 1

    # decoded samples straight from a payload (zentf/transport/ingest/handler.pyx): set_transforms_raw without tuples
    cdef int ingest_begin_c(self) except -1:
        """Take the lock for a run of ingest_one_c calls."""
        self._lock.acquire_c()
        return 0

    cdef int ingest_one_c(self, object parent, object child, int64_t stamp, const double* v,
                          object authority, bint is_static) except -1:
        """One sample, as set_transforms_raw takes it (lock held on entry and on exit): 1 if stored."""
        if self._append_c(parent, child, stamp, v, authority):
            return 1
        self._lock.release_c()  # tf2's full path logs: unlocked
        try:
            ok = self._store_checked(parent, child, stamp, v[0], v[1], v[2], v[3], v[4], v[5], v[6],
                                     authority, is_static)
        finally:
            self._lock.acquire_c()
        return 1 if ok else 0

    cdef int ingest_end_c(self, Py_ssize_t accepted) except -1:
        """Release the lock; then, if anything was stored, what set_transforms_raw does after a batch."""
        self._lock.release_c()
        if accepted:
            self._after_insert()
        return 0

    def set_transforms_raw(self, samples: Iterable[Sequence[Any]], authority: str, bint is_static=False) -> int:
        """Insert many (parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw) tuples; returns how many
        were accepted. Callbacks and transformable requests run once at the end.

        Same semantics as set_transform per sample, in order; the lock is taken once for the run of
        common-case samples (the C fast path) and released only around tf2's full path.
        """
        cdef Py_ssize_t accepted = 0
        lock = self._lock
        lock.acquire_c()
        try:
            for s in samples:
                if type(s) is tuple and PyTuple_GET_SIZE(s) == 10:
                    if self._append_fast(<object>PyTuple_GET_ITEM(s, 0), <object>PyTuple_GET_ITEM(s, 1),
                                         <object>PyTuple_GET_ITEM(s, 2), <object>PyTuple_GET_ITEM(s, 3),
                                         <object>PyTuple_GET_ITEM(s, 4), <object>PyTuple_GET_ITEM(s, 5),
                                         <object>PyTuple_GET_ITEM(s, 6), <object>PyTuple_GET_ITEM(s, 7),
                                         <object>PyTuple_GET_ITEM(s, 8), <object>PyTuple_GET_ITEM(s, 9),
                                         authority):
                        accepted += 1
                        continue
                parent, child, stamp, tx, ty, tz, qx, qy, qz, qw = s
                # tf2's full path (new frames, statics, out of order, bad input): it logs, so unlocked
                lock.release_c()
                try:
                    ok = self._store_checked(parent, child, stamp, tx, ty, tz, qx, qy, qz, qw, authority, is_static)
                finally:
                    lock.acquire_c()
                if ok:
                    accepted += 1
        finally:
            lock.release_c()
        if accepted:
            self._after_insert()
        return accepted

    cdef object _store(self, object parent, object child, object stamp, object tx, object ty, object tz,
                       object qx, object qy, object qz, object qw, object authority, bint is_static):
        # The common case first (_append_fast); anything else - new frames, statics, out-of-order
        # stamps, bad input - takes _store_checked, tf2's full path.
        cdef int done
        self._lock.acquire_c()
        try:
            done = self._append_fast(parent, child, stamp, tx, ty, tz, qx, qy, qz, qw, authority)
        finally:
            self._lock.release_c()
        if done:
            return True
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
        # a tuple display, not tuple(generator): CPython builds the latter at the length hint (10) and
        # shrinks it, so each one ends in the 7-tuple free list instead of coming from it (96 B kept
        # per new frame, up to 2000 of them, until a full collection)
        values = (float(tx), float(ty), float(tz), float(qx), float(qy), float(qz), float(qw))
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
                    self._auths[cid] = authority
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
        cdef object fid = len(self._names)   # one int object for the frame (an untyped local would be a C int)
        self._version += 1
        self._ids[name] = fid
        self._names.append(name)
        self._caches.append(None)
        self._auths.append(_NO_AUTHORITY)
        return fid

    cdef int _after_insert(self) except -1:
        """After stored data changed (called unlocked): the generation, waiters' wake-up (only when some
        wait: no Python call per insert otherwise), transformable requests, then insert callbacks."""
        self._generation += 1
        if self._wake_wanted:
            try:
                self._wake()
            except Exception:  # a broken waiter must not break inserts
                logger.exception("waking waiters failed")
        if self._requests:
            self._test_transformable_requests()
        if self._insert_callbacks:
            for cb in tuple(self._insert_callbacks):
                try:
                    cb()
                except Exception:  # a broken callback must not break inserts
                    logger.exception("insert callback %r failed", cb)
        return 0

    def _wake(self) -> None:
        """Called after an insert while ``_wake_wanted`` is non-zero (a subclass's waiters)."""

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

    cdef int32_t _clean_id(self, object frame) except -1:
        """Id of a frame usable as given (known, non-empty, no leading '/'); 0 otherwise."""
        return _usable_id(self._ids, frame)

    def lookup_transform(self, target_frame: str, source_frame: str, time: TimeArg) -> TransformStamped:
        """Transform mapping data in source_frame into target_frame at time (0 = latest common)."""
        cdef int64_t t = (<Time>time)._ns if type(time) is Time else _ns(time)
        cdef int64_t stamp
        cdef double out[7]
        cdef int32_t tid, sid
        self._lock.acquire_c()
        try:
            tid = self._clean_id(target_frame)
            sid = self._clean_id(source_frame)
            if tid and sid and tid != sid:
                stamp = self._lookup_ids(tid, sid, t, out, target_frame, source_frame)
            else:
                r = self._lookup(target_frame, source_frame, t)
                stamp = r[0]
                for i in range(7):
                    out[i] = r[1 + i]
        finally:
            self._lock.release_c()
        return _make_ts_c(target_frame, source_frame, stamp, out)

    def lookup_transform_core(self, target_frame: str, source_frame: str, time: TimeArg) -> TransformStamped:
        """tf2_py spelling (BufferCore's own lookup: never waits, also on a Buffer)."""
        return BufferCore.lookup_transform(self, target_frame, source_frame, time)

    def _lookup(self, target: str, source: str, t: int) -> tuple:
        """(stamp, tx, ty, tz, qx, qy, qz, qw) or a tf2 exception; call with the lock held."""
        cdef double out[7]
        cdef int64_t stamp
        if target == source:
            if t == 0:
                cid = self._ids.get(target)
                cache = self._caches[cid] if cid is not None else None
                if cache is not None:
                    t = cache.newest_stamp()
            return (t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        target_id = self._validate("lookupTransform argument target_frame", target)
        source_id = self._validate("lookupTransform argument source_frame", source)
        stamp = self._lookup_ids(target_id, source_id, t, out, target, source)
        return (stamp, out[0], out[1], out[2], out[3], out[4], out[5], out[6])

    cdef int64_t _lookup_ids(self, int32_t target_id, int32_t source_id, int64_t t, double* out,
                             object target, object source) except -1:
        """The answer for two distinct valid ids into out; its stamp. Lock held."""
        cdef _Memo* m
        cdef int32_t bad = 0
        cdef int res, i
        cdef uint64_t h
        if t == 0:
            t = self._lct(target_id, source_id)
        h = <uint64_t>t * _GOLDEN + <uint64_t>target_id * 40503u + <uint64_t>source_id * 2654435761u
        m = &self._memo[h >> 56]
        if m.version == self._version and m.t == t and m.target == target_id and m.source == source_id:
            for i in range(7):
                out[i] = m.v[i]
            return m.stamp
        res = self._walk(target_id, source_id, t, t, out, &bad, NULL)
        if res != _W_OK:
            self._raise_walk(res, bad, target_id, source_id, t, target, source)
        m.version = self._version
        m.t = t
        m.stamp = t
        m.target = target_id
        m.source = source_id
        for i in range(7):
            m.v[i] = out[i]
        return t

    cdef int _walk(self, int32_t target_id, int32_t source_id, int64_t t, int64_t t_hi, double* out,
                   int32_t* bad, _Plan* plan) noexcept:
        """tf2's walk (BufferCore::walkToTopParent), in C: the single lookup, can_transform and the
        batches all take this one.

        Source side up to the top, then target side up to the same top; the answer is
        inverse(target -> top) ∘ (source -> top). _W_OK with out set, or what went wrong. With out
        NULL only the parents are followed at t (tf2's CanTransformAccum: canTransform's walk), and
        a frame counts as having data at t when it has a parent there. With a plan, the walk is
        taken for every time of [t, t_hi] at once (BufferCore.chain_plan): the links it would
        compose are recorded instead, or _W_SPLIT where some time would walk otherwise.
        """
        cdef list caches = self._caches
        cdef PyObject* o
        cdef int32_t frame = source_id, top = source_id, p = 0, extrap_frame = 0
        cdef int depth = 0, source_links, k, r
        cdef bint values = out != NULL
        cdef _Link* link = NULL
        cdef int64_t* split = &plan.split if plan != NULL else NULL
        cdef double s[7]
        cdef double sacc[7]
        cdef double tacc[7]
        cdef double inv[7]
        sacc[0] = sacc[1] = sacc[2] = sacc[3] = sacc[4] = sacc[5] = 0.0
        sacc[6] = 1.0
        while frame:
            o = PyList_GET_ITEM(caches, frame)    # borrowed: the list holds it, the lock is held
            if o == <PyObject*>None:
                top = frame
                break
            if plan != NULL:
                link = &plan.links[depth]
            r = _step(o, t, t_hi, &p, s, values, link, split)
            if r <= 0:
                if r < 0:
                    return _W_SPLIT
                top = frame
                extrap_frame = frame
                break
            if frame == target_id:
                if values:
                    for k in range(7):
                        out[k] = sacc[k]
                elif plan != NULL:
                    plan.n_source, plan.target_at, plan.n_target = depth, depth, 0
                return _W_OK
            if values:
                if depth:
                    _compose(sacc, s)
                else:
                    for k in range(7):
                        sacc[k] = s[k]
            elif plan != NULL:
                link.frame = frame
            top = frame
            frame = p
            depth += 1
            if depth > _MAX_DEPTH:
                return _W_LOOP
        source_links = depth
        frame = target_id
        depth = 0
        tacc[0] = tacc[1] = tacc[2] = tacc[3] = tacc[4] = tacc[5] = 0.0
        tacc[6] = 1.0
        while frame != top:
            o = PyList_GET_ITEM(caches, frame)
            if o == <PyObject*>None:
                break
            if plan != NULL:
                link = &plan.links[source_links + depth]
            r = _step(o, t, t_hi, &p, s, values, link, split)
            if r <= 0:
                if r < 0:
                    return _W_SPLIT
                bad[0] = frame
                return _W_EXTRAP_TARGET
            if frame == source_id:
                if values:
                    _invert(tacc, out)   # source is an ancestor of target: inverse(target -> source)
                elif plan != NULL:
                    plan.n_source, plan.target_at, plan.n_target = 0, source_links, depth
                return _W_OK
            if values:
                if depth:
                    _compose(tacc, s)
                else:
                    for k in range(7):
                        tacc[k] = s[k]
            elif plan != NULL:
                link.frame = frame
            frame = p
            depth += 1
            if depth > _MAX_DEPTH:
                return _W_LOOP
        if frame != top:
            if extrap_frame:
                bad[0] = extrap_frame
                return _W_EXTRAP
            return _W_CONNECT
        if not values:
            if plan != NULL:
                plan.n_source, plan.target_at, plan.n_target = source_links, source_links, depth
            return _W_OK
        # full path: inverse(target -> top) ∘ (source -> top); when one side is empty this is
        # exactly the other side (identity terms add zeros), so skip the arithmetic
        if not depth:
            for k in range(7):
                out[k] = sacc[k]
            return _W_OK
        _invert(tacc, inv)
        if not source_links:
            for k in range(7):
                out[k] = inv[k]
            return _W_OK
        _compose(sacc, inv)
        for k in range(7):
            out[k] = sacc[k]
        return _W_OK

    def chain_plan(self, target_frame: str, source_frame: str, t_lo: int, t_hi: int) -> Any:
        """The walk lookup_transform takes, for every time of [t_lo, t_hi] (ns, 0 < t_lo <= t_hi) at
        once: what the batch engine (zentf.core.batch) composes, read under the lock in one call.

        Returns one of
        - ``(links, n_source)`` when every time of the range walks the same links, each with data:
          the answer at t is inverse(T) ∘ S, S the composition of ``links[:n_source]`` (from the
          source frame up) and T that of ``links[n_source:]`` (from the target frame up). A link is
          ``(stamps, values)``: the frame's samples that the range reads, oldest first (int64[k] ns,
          float64[k, 7] tx, ty, tz, qx, qy, qz, qw), interpolated between neighbours as tf2 does,
          the last one applying as is from its stamp on; stamps is None for a static frame.
        - an int b, t_lo < b <= t_hi, where some link's data or parent changes: plan [t_lo, b) and
          [b, t_hi] apart.
        - None: the lookup fails at every time of the range (lookup_transform at one raises why).
        Frame names are checked as lookup_transform checks them.
        """
        cdef _Plan plan
        cdef int32_t tid, sid, bad = 0
        cdef int res, k
        cdef int64_t lo = t_lo, hi = t_hi
        if not 0 < lo <= hi:
            raise ValueError(f"chain_plan needs 0 < t_lo <= t_hi, got {t_lo}, {t_hi}")
        if target_frame == source_frame:
            return [], 0
        plan.links = <_Link*>malloc(2 * (_MAX_DEPTH + 1) * sizeof(_Link))
        if plan.links == NULL:
            raise MemoryError()
        try:
            with self._lock:
                tid = self._validate("lookupTransform argument target_frame", target_frame)
                sid = self._validate("lookupTransform argument source_frame", source_frame)
                res = self._walk(tid, sid, lo, hi, NULL, &bad, &plan)
                if res == _W_SPLIT:
                    return plan.split
                if res != _W_OK:
                    return None
                caches = self._caches
                links = []
                for k in range(plan.n_source):
                    links.append((<CacheBase>caches[plan.links[k].frame]).link_columns(
                        plan.links[k].first, plan.links[k].last))
                for k in range(plan.target_at, plan.target_at + plan.n_target):
                    links.append((<CacheBase>caches[plan.links[k].frame]).link_columns(
                        plan.links[k].first, plan.links[k].last))
                return links, plan.n_source
        finally:
            free(plan.links)

    cdef int _raise_walk(self, int res, int32_t bad, int32_t target_id, int32_t source_id, int64_t t,
                         object target, object source) except -1:
        if res == _W_LOOP:
            raise LookupException(self._loop_message())
        if res == _W_CONNECT:
            raise ConnectivityException(self._connectivity_message(source_id, target_id))
        raise ExtrapolationException(
            f"{self._caches[bad].error(t)}, when looking up transform from frame [{source}] to frame [{target}]")

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
        from .rotation import matrix_from_quaternion, quaternion_from_matrix
        ma = matrix_from_quaternion(a[4:8])
        mb = matrix_from_quaternion(b[4:8])
        m = [[mb[i][0] * ma[0][j] + mb[i][1] * ma[1][j] + mb[i][2] * ma[2][j] for j in range(3)]
             for i in range(3)]
        o = [mb[i][0] * a[1] + mb[i][1] * a[2] + mb[i][2] * a[3] + b[1 + i] for i in range(3)]
        q = quaternion_from_matrix(m)
        return _make_ts(target_frame, source_frame, b[0], o[0], o[1], o[2], *q)

    def lookup_transform_full_core(self, target_frame: str, target_time: TimeArg, source_frame: str,
                                   source_time: TimeArg, fixed_frame: str) -> TransformStamped:
        """tf2_py spelling (BufferCore's own lookup: never waits, also on a Buffer)."""
        return BufferCore.lookup_transform_full(self, target_frame, target_time, source_frame, source_time,
                                                fixed_frame)

    def can_transform(self, target_frame: str, source_frame: str, time: TimeArg,
                      return_debug_tuple: bool = False) -> Union[bool, tuple[bool, str]]:
        """Whether lookup_transform would succeed; (bool, reason) if return_debug_tuple."""
        t = _ns(time)
        with self._lock:
            ok, msg = self._can(target_frame, source_frame, t, "canTransform")
        return (ok, msg) if return_debug_tuple else ok

    def can_transform_core(self, target_frame: str, source_frame: str, time: TimeArg) -> tuple[bool, str]:
        """tf2_py spelling: always (bool, reason), at once (a Buffer's can_transform would wait)."""
        return BufferCore.can_transform(self, target_frame, source_frame, time, True)  # type: ignore[return-value]

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
        """tf2_py spelling: always (bool, reason), at once (a Buffer's can_transform_full would wait)."""
        return BufferCore.can_transform_full(self, target_frame, target_time, source_frame,  # type: ignore[return-value]
                                             source_time, fixed_frame, True)

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

    def _can_ids(self, target_id: int, source_id: int, t: int) -> tuple:
        """tf2 canTransformNoLock: the lookup walk on parents only."""
        cdef int res
        cdef int32_t bad = 0
        if not target_id or not source_id:
            return False, ""
        if target_id == source_id:
            return True, ""
        try:
            if t == 0:
                t = self._lct(target_id, source_id)
        except TransformException as e:
            return False, str(e)
        res = self._walk(target_id, source_id, t, t, NULL, &bad, NULL)
        if res == _W_OK:
            return True, ""
        if res == _W_LOOP:
            return False, self._loop_message()
        if res == _W_CONNECT:
            return False, self._connectivity_message(source_id, target_id)
        return False, (f"{self._caches[bad].error(t)}, when looking up transform from frame "
                       f"[{self._names[source_id]}] to frame [{self._names[target_id]}]")

    # ------------------------------------------------------------------------ latest common time

    def get_latest_common_time(self, target_frame: str, source_frame: str) -> Time:
        """Newest time at which the whole chain has data (0 if every link is static)."""
        with self._lock:
            tid = self._validate("get_latest_common_time", target_frame)
            sid = self._validate("get_latest_common_time", source_frame)
            return Time(nanoseconds=self._lct(tid, sid))

    cdef int _mark_room(self) except -1:
        cdef Py_ssize_t n = len(self._caches)
        cdef int64_t* m
        if n > self._marks_len:
            m = <int64_t*>realloc(self._marks, n * 2 * sizeof(int64_t))
            if m == NULL:
                raise MemoryError()
            for i in range(self._marks_len, n * 2):
                m[i] = 0
            self._marks = m
            self._marks_len = n * 2
        return 0

    cdef int64_t _lct(self, int32_t target_id, int32_t source_id) except -1:
        """tf2 getLatestCommonTime: the oldest of the newest stamps along the chain (statics ignored)."""
        cdef list caches = self._caches
        cdef CacheBase cache
        cdef int64_t big = _MAX_STAMP, common, stamp   # 'no dynamic link yet' (stamps < big... see below)
        cdef int64_t stamps[_MAX_DEPTH + 2]
        cdef int32_t parents[_MAX_DEPTH + 2]
        cdef int32_t frame, parent, common_parent
        cdef int depth, n, k
        cdef bint found
        cdef int64_t epoch
        if source_id == target_id:
            obj = <object>PyList_GET_ITEM(caches, source_id)
            return 0 if obj is None else obj.newest_stamp()
        self._mark_room()
        self._mark_epoch += 1
        epoch = self._mark_epoch
        # walk up from the source, recording (newest stamp, parent) per link; a cache's newest
        # stamp is -1 when empty (no parent: stop), 0 for statics (ignored in the minimum).
        # 'big' stands for no dynamic link yet: stamps equal to it are valid, so a flag keeps it apart
        found = False
        frame = source_id
        depth = 0
        n = 0
        common = big
        while frame:
            obj = <object>PyList_GET_ITEM(caches, frame)
            if obj is None:
                break
            cache = <CacheBase>obj
            stamp = cache.newest
            if stamp < 0:
                break
            parent = cache.latest_parent_c()
            if stamp and (not found or stamp < common):
                common = stamp
                found = True
            stamps[n] = stamp
            parents[n] = parent
            n += 1
            self._marks[parent] = epoch
            frame = parent
            if frame == target_id:
                return common if found else 0
            depth += 1
            if depth > _MAX_DEPTH:
                raise LookupException(self._loop_message())
        # walk up from the target until a parent is common with the source's chain
        frame = target_id
        depth = 0
        found = False
        common = big
        common_parent = 0
        while True:
            obj = <object>PyList_GET_ITEM(caches, frame)
            if obj is None:
                break
            cache = <CacheBase>obj
            stamp = cache.newest
            if stamp < 0:
                break
            parent = cache.latest_parent_c()
            if stamp and (not found or stamp < common):
                common = stamp
                found = True
            if self._marks[parent] == epoch:
                common_parent = parent
                break
            frame = parent
            if frame == source_id:
                return common if found else 0
            depth += 1
            if depth > _MAX_DEPTH:
                raise LookupException(self._loop_message())
        if not common_parent:
            raise ConnectivityException(self._connectivity_message(source_id, target_id))
        for k in range(n):
            stamp = stamps[k]
            if stamp and (not found or stamp < common):
                common = stamp
                found = True
            if parents[k] == common_parent:
                break
        return common if found else 0

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
            named = len(self._names) > 1
        if not infos:
            # ROS 1 prints {} while no frame was ever named (ROS 2 prints []), and nothing once
            # frames are known but none has data (every dynamic edge cleared)
            return "" if named else "{}"
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
                "broadcaster": self._auths[fid],
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

    def _frameExists(self, frame_id: str) -> bool:
        return self.frame_exists(frame_id)

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

    def _chainAsVector(self, target_frame: str, target_time: TimeArg, source_frame: str,
                       source_time: TimeArg, fixed_frame: str) -> list[str]:
        return self.chain_as_vector(target_frame, target_time, source_frame, source_time, fixed_frame)

    def _path(self, target_id: int, source_id: int, t: int) -> list[str]:
        """Frame names from source up to the common ancestor and down to target, at time t."""
        if target_id == source_id:
            return []
        if t == 0:
            t = self._lct(target_id, source_id)
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
                    latest = self._lct(tid, sid)
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
                        latest = self._lct(tid, sid)
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
        from .batch import transform_points as _tp
        return _tp(self, points, target_frame, source_frame, time)

    def lookup_transforms(self, target_frame: str, source_frame: str, times: Any) -> Any:
        """Vectorized lookup_transform over times[N]: (translations[N,3], quaternions[N,4])."""
        from .batch import lookup_transforms as _lt
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

