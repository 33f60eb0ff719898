# Declarations of the per-frame caches (cache.pyx), cimported by buffer_core.pyx for the C-level walk.
cimport cython
from libc.stdint cimport int32_t, int64_t


cdef class CacheBase:
    """tf2's TimeCacheInterface: what the walk asks of a frame's cache, in C."""
    cdef public object authority
    cdef readonly int64_t newest        # newest stamp; -1 empty; 0 for statics (ignored by the LCT)
    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1
    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept
    cdef int32_t parent_at_c(self, int64_t t) noexcept
    cdef int32_t latest_parent_c(self) noexcept
    cdef void clear_c(self) noexcept


@cython.final
cdef class TimeCache(CacheBase):
    cdef int64_t* _st                   # stamps (ns), a ring of _cap slots, logical 0 = oldest
    cdef double* _d                     # tx, ty, tz, qx, qy, qz, qw per slot
    cdef int32_t* _par                  # parent per slot; NULL while every sample has parent _par0
    cdef int32_t _par0
    cdef Py_ssize_t _cap, _head, _n
    cdef bint _steady                   # pruning has begun: the cache holds about as many samples as it will
    cdef public int64_t max_ns
    cdef int64_t oldest
    # the last interpolated query (time and answer) and the constants of the last interval asked
    cdef int64_t _memo_t
    cdef int32_t _memo_p
    cdef double _memo[7]
    cdef int64_t _sp_t0, _sp_t1
    cdef int32_t _sp_p
    cdef bint _sp_same                  # False: parents differ, the older sample applies as is
    cdef double _sp[16]                 # inv_dt, p0 (3), dp (3), q0 (4), a (4), theta
    cdef inline Py_ssize_t _slot(self, Py_ssize_t i) noexcept
    cdef inline int32_t _parent(self, Py_ssize_t j) noexcept
    cdef void _reset(self) noexcept
    cdef int _own_parents(self) except -1
    cdef int _resize(self, Py_ssize_t cap) noexcept
    cdef void _prune(self) noexcept
    cdef void _span(self, Py_ssize_t i) noexcept
    cdef Py_ssize_t _floor(self, int64_t t) noexcept
    cdef Py_ssize_t _lower(self, int64_t stamp) noexcept
    cdef inline void _copy(self, Py_ssize_t i, int32_t* parent, double* out) noexcept


@cython.final
cdef class StaticCache(CacheBase):
    cdef int32_t _parent
    cdef double _v[7]
