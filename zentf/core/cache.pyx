# cython: language_level=3, annotation_typing=False
"""tf2's per-frame caches, compiled: TimeCache (samples over time) and StaticCache (one sample, any time).

As in tf2 (cache.cpp, static_cache.cpp), BufferCore keeps one cache object per frame and asks it
for the sample at a time; the walk over the tree is in buffer_core.pyx, which calls these caches
through their C methods (``get_c``, ``parent_at_c``, ...) without touching Python objects.

Storage is a ring of plain C arrays per frame: one int64 stamp (ns) and seven float64 values
(tx, ty, tz, qx, qy, qz, qw) per sample, 64 bytes, oldest first, searched by bisection. The parent
id is kept once per frame while it never changes (tf2 stores it in every sample); a frame whose
parent does change gets a per-sample int32 column from then on. Callers hold BufferCore's lock.
"""
from libc.math cimport acos, cos, sin, sqrt
from libc.stdint cimport int32_t, int64_t
from libc.stdlib cimport free, malloc
from libc.string cimport memcpy

from .constants import INSERT_OK, INSERT_OLD, INSERT_REPEATED
from .time import fmt_stamp

__all__ = ["CacheBase", "TimeCache", "StaticCache"]

cdef enum:
    _OK = 0
    _OLD = 1
    _REPEATED = 2

assert (INSERT_OK, INSERT_OLD, INSERT_REPEATED) == (_OK, _OLD, _REPEATED)


cdef class CacheBase:
    """What BufferCore asks of a frame's cache (tf2 TimeCacheInterface)."""

    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1:
        return _OK

    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept:
        return False

    cdef int32_t parent_at_c(self, int64_t t) noexcept:
        return 0

    cdef int32_t latest_parent_c(self) noexcept:
        return 0

    cdef void clear_c(self) noexcept:
        pass

    # ---------------------------------------------------------------- Python face (tools, tests)

    def insert(self, int64_t stamp, int32_t parent, values) -> int:
        """Store one sample: INSERT_OK, INSERT_OLD (older than the cache keeps) or INSERT_REPEATED."""
        cdef double v[7]
        cdef int k
        if len(values) != 7:
            raise ValueError("a sample has 7 values: tx, ty, tz, qx, qy, qz, qw")
        for k in range(7):
            v[k] = values[k]
        return self.insert_c(stamp, parent, v)

    def get(self, int64_t t):
        """(parent, tx, ty, tz, qx, qy, qz, qw) at t, interpolated as tf2 does; None if not available."""
        cdef int32_t p = 0
        cdef double o[7]
        if not self.get_c(t, &p, o):
            return None
        return (p, o[0], o[1], o[2], o[3], o[4], o[5], o[6])

    def parent_at(self, int64_t t) -> int:
        """Parent id of the sample that applies at t, 0 if none (tf2 getParent)."""
        return self.parent_at_c(t)

    def clear(self) -> None:
        self.clear_c()


cdef class TimeCache(CacheBase):
    """Samples of one dynamic frame, oldest first (tf2 TimeCache)."""

    is_static = False

    def __cinit__(self, int64_t max_ns):
        self.max_ns = max_ns
        self.authority = "no recorded authority"  # of the last accepted sample (tf2 keeps it too)
        self._st = NULL
        self._d = NULL
        self._par = NULL
        self._cap = 0
        self._reset()

    def __dealloc__(self):
        free(self._st)
        free(self._d)
        free(self._par)

    cdef void _reset(self) noexcept:
        self._head = 0
        self._n = 0
        self._steady = False
        self._par0 = 0
        self.newest = -1
        self.oldest = -1
        self._memo_t = -1
        self._sp_t0 = 0
        self._sp_t1 = 0  # empty interval: never matches

    cdef void clear_c(self) noexcept:
        free(self._st)
        free(self._d)
        free(self._par)
        self._st = NULL
        self._d = NULL
        self._par = NULL
        self._cap = 0
        self._reset()

    def __len__(self) -> int:
        return self._n

    cdef inline Py_ssize_t _slot(self, Py_ssize_t i) noexcept:
        cdef Py_ssize_t j = self._head + i
        if j >= self._cap:
            j -= self._cap
        return j

    cdef int _resize(self, Py_ssize_t cap) noexcept:
        """Reallocate to cap slots (>= n), unrolling the ring so the oldest sample is slot 0."""
        cdef int64_t* st = <int64_t*>malloc(cap * sizeof(int64_t))
        cdef double* d = <double*>malloc(cap * 7 * sizeof(double))
        cdef int32_t* par = NULL
        cdef Py_ssize_t i, j
        if self._par != NULL:
            par = <int32_t*>malloc(cap * sizeof(int32_t))
        if st == NULL or d == NULL or (self._par != NULL and par == NULL):
            free(st)
            free(d)
            free(par)
            return -1
        for i in range(self._n):
            j = self._slot(i)
            st[i] = self._st[j]
            memcpy(&d[7 * i], &self._d[7 * j], 7 * sizeof(double))
            if par != NULL:
                par[i] = self._par[j]
        free(self._st)
        free(self._d)
        free(self._par)
        self._st, self._d, self._par = st, d, par
        self._cap = cap
        self._head = 0
        return 0

    cdef int _own_parents(self) except -1:
        """Switch to a parent per sample (the frame's parent changed): every stored one is _par0."""
        cdef int32_t* par = <int32_t*>malloc(self._cap * sizeof(int32_t))
        cdef Py_ssize_t i
        if par == NULL:
            raise MemoryError()
        for i in range(self._cap):
            par[i] = self._par0
        self._par = par
        return 0

    cdef inline int32_t _parent(self, Py_ssize_t j) noexcept:
        return self._par0 if self._par == NULL else self._par[j]

    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1:
        cdef int64_t newest = self.newest
        cdef Py_ssize_t i, j, k, lo
        if self._n == self._cap:  # grow: by half while filling up, by 1/64 once pruning holds it steady
            if self._resize(self._cap + ((self._cap >> 6) if self._steady else (self._cap >> 1)) + 4) < 0:
                raise MemoryError()
        if self._n == 0:
            self._par0 = parent
        elif self._par == NULL and parent != self._par0:
            self._own_parents()
        if stamp > newest:
            j = self._slot(self._n)
            self._st[j] = stamp
            memcpy(&self._d[7 * j], v, 7 * sizeof(double))
            if self._par != NULL:
                self._par[j] = parent
            self._n += 1
            self.newest = stamp
            if newest < 0:
                self.oldest = stamp
                return _OK
            newest = stamp
        else:
            if newest - stamp > self.max_ns:
                return _OLD
            lo = self._lower(stamp)
            if self._st[self._slot(lo)] == stamp:
                return _REPEATED
            k = self._n                  # shift lo..n-1 up one slot
            while k > lo:
                j = self._slot(k)
                i = self._slot(k - 1)
                self._st[j] = self._st[i]
                memcpy(&self._d[7 * j], &self._d[7 * i], 7 * sizeof(double))
                if self._par != NULL:
                    self._par[j] = self._par[i]
                k -= 1
            j = self._slot(lo)
            self._st[j] = stamp
            memcpy(&self._d[7 * j], v, 7 * sizeof(double))
            if self._par != NULL:
                self._par[j] = parent
            self._n += 1
            self._memo_t = -1
            self._sp_t1 = self._sp_t0    # an interval was split
            if lo == 0:
                self.oldest = stamp
        if self.oldest < newest - self.max_ns:
            self._prune()
        return _OK

    cdef void _prune(self) noexcept:
        """Drop samples older than newest - cache time, right after an insert (ROS 1 order; ROS 2
        prunes before inserting): pop while oldest + max < newest."""
        cdef int64_t limit = self.newest - self.max_ns
        cdef Py_ssize_t lo = self._lower(limit), n
        self._head = self._slot(lo)
        self._n -= lo
        self.oldest = self._st[self._head]
        self._memo_t = -1            # the memoized time may have fallen out
        n = self._n
        if not self._steady:  # the cache is full: from now on it holds about n samples, keep no slack
            self._steady = True
            if self._cap > n + 1:
                self._resize(n + 1)
        elif self._cap > n + (n >> 3) + 16:  # fewer samples than before (a slower rate): give room back
            self._resize(n + (n >> 6) + 4)

    cdef Py_ssize_t _lower(self, int64_t stamp) noexcept:
        """Logical index of the first sample at or after stamp (bisect_left), n if none."""
        cdef Py_ssize_t lo = 0, hi = self._n, mid
        while lo < hi:
            mid = (lo + hi) >> 1
            if self._st[self._slot(mid)] < stamp:
                lo = mid + 1
            else:
                hi = mid
        return lo

    cdef inline void _copy(self, Py_ssize_t i, int32_t* parent, double* out) noexcept:
        cdef Py_ssize_t j = self._slot(i)
        parent[0] = self._parent(j)
        memcpy(out, &self._d[7 * j], 7 * sizeof(double))

    cdef Py_ssize_t _floor(self, int64_t t) noexcept:
        """Logical index of the newest sample at or before t (bisect_right - 1), t inside the range."""
        cdef Py_ssize_t head = self._head, n = self._n, lo, hi, mid, seg, base
        cdef int64_t* st = self._st
        # the ring is at most two contiguous runs: [head, cap) then [0, head + n - cap)
        if head + n > self._cap and t >= st[0]:
            seg = self._cap - head
            lo = 0
            hi = n - seg
            base = seg                 # logical = physical + seg
        else:
            lo = head
            hi = head + n if head + n <= self._cap else self._cap
            base = -head
        while lo < hi:
            mid = (lo + hi) >> 1
            if t < st[mid]:
                hi = mid
            else:
                lo = mid + 1
        return lo - 1 + base

    cdef void _span(self, Py_ssize_t i) noexcept:
        """Constants to interpolate between samples i and i+1 exactly like tf2.

        tf2's slerp is (q0·sin((1-r)θ) + ±q1·sin(rθ)) / sin θ, with θ from the normalized dot
        product and the sign picking the short way; rewritten as q0·cos(rθ) + a·sin(rθ) with
        a = (±q1 - q0·cos θ) / sin θ (an identity, no normalization assumed), so each query costs
        one cos and one sin. Translation: p0 + r·(p1 - p0).
        """
        cdef Py_ssize_t j0 = self._slot(i), j1 = self._slot(i + 1)
        cdef double* a = &self._d[7 * j0]
        cdef double* b = &self._d[7 * j1]
        cdef double* sp = self._sp
        cdef double x1, y1, z1, w1, dot, c, theta, inv
        cdef int k
        self._sp_t0 = self._st[j0]
        self._sp_t1 = self._st[j1]
        self._sp_p = self._parent(j0)
        self._sp_same = self._parent(j1) == self._sp_p
        if not self._sp_same:
            memcpy(&sp[1], a, 7 * sizeof(double))  # different parents: the older sample applies
            return
        sp[0] = 1.0 / <double>(self._sp_t1 - self._sp_t0)
        for k in range(3):
            sp[1 + k] = a[k]
            sp[4 + k] = b[k] - a[k]
        x1, y1, z1, w1 = b[3], b[4], b[5], b[6]
        dot = a[3] * x1 + a[4] * y1 + a[5] * z1 + a[6] * w1
        c = (-dot if dot < 0 else dot) / sqrt(
            (a[3] * a[3] + a[4] * a[4] + a[5] * a[5] + a[6] * a[6]) * (x1 * x1 + y1 * y1 + z1 * z1 + w1 * w1))
        theta = acos(1.0 if c > 1.0 else c)
        for k in range(4):
            sp[7 + k] = a[3 + k]
        if theta != 0.0:
            if dot < 0:
                x1, y1, z1, w1 = -x1, -y1, -z1, -w1
            if c > 1.0:
                c = 1.0
            inv = 1.0 / sqrt((1.0 - c) * (1.0 + c))  # 1 / sin θ; cos θ is c itself
            sp[11] = (x1 - a[3] * c) * inv
            sp[12] = (y1 - a[4] * c) * inv
            sp[13] = (z1 - a[5] * c) * inv
            sp[14] = (w1 - a[6] * c) * inv
        else:
            sp[11] = sp[12] = sp[13] = sp[14] = 0.0
        sp[15] = theta

    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept:
        cdef int64_t newest = self.newest
        cdef double r, c, s
        cdef double* sp
        cdef int k
        if t == newest or t == 0:
            if newest < 0:
                return False
            self._copy(self._n - 1, parent, out)
            return True
        if t == self._memo_t:
            parent[0] = self._memo_p
            memcpy(out, self._memo, 7 * sizeof(double))
            return True
        if t > newest or t < self.oldest or self._n == 1:
            return False
        if t == self.oldest:
            self._copy(0, parent, out)
            return True
        if not (self._sp_t0 <= t < self._sp_t1):
            self._span(self._floor(t))
        sp = self._sp
        parent[0] = self._sp_p
        if not self._sp_same:
            memcpy(out, &sp[1], 7 * sizeof(double))
            return True
        r = <double>(t - self._sp_t0) * sp[0]
        out[0] = sp[1] + r * sp[4]
        out[1] = sp[2] + r * sp[5]
        out[2] = sp[3] + r * sp[6]
        if sp[15] != 0.0:
            c = cos(r * sp[15])
            s = sin(r * sp[15])
            for k in range(4):
                out[3 + k] = sp[7 + k] * c + sp[11 + k] * s
        else:
            for k in range(4):
                out[3 + k] = sp[7 + k]
        self._memo_t = t
        self._memo_p = parent[0]
        memcpy(self._memo, out, 7 * sizeof(double))
        return True

    cdef int32_t parent_at_c(self, int64_t t) noexcept:
        cdef int64_t newest = self.newest
        if newest < 0:
            return 0
        if t == 0 or t == newest:
            return self._parent(self._slot(self._n - 1))
        if t > newest or t < self.oldest or self._n == 1:
            return 0
        return self._parent(self._slot(self._floor(t)))

    cdef int32_t latest_parent_c(self) noexcept:
        if self._n == 0:
            return 0
        return self._parent(self._slot(self._n - 1))

    # ---------------------------------------------------------------- Python face

    def error(self, int64_t t) -> str:
        """The text tf2's findClosest gives for a failed query at t (empty cache: no text)."""
        cdef Py_ssize_t n = self._n
        if n == 0:
            return ""
        newest, oldest = self.newest, self.oldest
        if n == 1:
            return (f"Lookup would require extrapolation at time {fmt_stamp(t)}, "
                    f"but only time {fmt_stamp(newest)} is in the buffer")
        if t > newest:
            return (f"Lookup would require extrapolation {fmt_stamp(t - newest)}s into the future.  "
                    f"Requested time {fmt_stamp(t)} but the latest data is at time {fmt_stamp(newest)}")
        return (f"Lookup would require extrapolation {fmt_stamp(oldest - t)}s into the past.  "
                f"Requested time {fmt_stamp(t)} but the earliest data is at time {fmt_stamp(oldest)}")

    def latest_stamp_parent(self) -> tuple:
        if self._n == 0:
            return 0, 0
        return self.newest, self.latest_parent_c()

    def newest_stamp(self) -> int:
        return 0 if self._n == 0 else self.newest

    def oldest_stamp(self) -> int:
        return 0 if self._n == 0 else self.oldest

    def nbytes(self) -> int:
        """Bytes allocated for samples (capacity, not only the samples held)."""
        return self._cap * (64 + (4 if self._par != NULL else 0))

    def columns(self):
        """Copies of the samples, oldest first: (stamps int64[n], parents int32[n], values float64[n, 7])."""
        import numpy as np
        cdef Py_ssize_t n = self._n, i, j
        st = np.empty(n, dtype=np.int64)
        par = np.empty(n, dtype=np.int32)
        d = np.empty((n, 7), dtype=np.float64)
        cdef int64_t[::1] stv = st
        cdef int32_t[::1] pv = par
        cdef double[:, ::1] dv = d
        for i in range(n):
            j = self._slot(i)
            stv[i] = self._st[j]
            pv[i] = self._parent(j)
            memcpy(&dv[i, 0], &self._d[7 * j], 7 * sizeof(double))
        return st, par, d


cdef class StaticCache(CacheBase):
    """The single sample of a static frame, valid at every time (tf2 StaticCache)."""

    is_static = True

    def __cinit__(self):
        self.authority = "no recorded authority"
        self.newest = 0   # statics report stamp 0 (ignored by the latest-common-time minimum)
        self._parent = 0
        self._v[:] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]

    def __len__(self) -> int:
        return 1

    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1:
        self._parent = parent
        memcpy(self._v, v, 7 * sizeof(double))
        return _OK

    cdef void clear_c(self) noexcept:
        """Static frames survive clear() in tf2."""

    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept:
        parent[0] = self._parent
        memcpy(out, self._v, 7 * sizeof(double))
        return True

    cdef int32_t parent_at_c(self, int64_t t) noexcept:
        return self._parent

    cdef int32_t latest_parent_c(self) noexcept:
        return self._parent

    @property
    def sample(self) -> tuple:
        """(parent, tx, ty, tz, qx, qy, qz, qw)."""
        cdef double* v = self._v
        return (self._parent, v[0], v[1], v[2], v[3], v[4], v[5], v[6])

    def error(self, int64_t t) -> str:
        return ""

    def latest_stamp_parent(self) -> tuple:
        return 0, self._parent

    def newest_stamp(self) -> int:
        return 0

    def oldest_stamp(self) -> int:
        return 0

    def nbytes(self) -> int:
        return 64
