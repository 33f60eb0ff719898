# Declarations of the per-frame caches (cache.pyx), cimported by buffer_core.pyx for the C-level walk.
cimport cython
from libc.stdint cimport int32_t, int64_t, uint32_t


cdef class CacheBase:
    """tf2's TimeCacheInterface: what the walk asks of a frame's cache, in C."""
    # no Python object field: the caches are not tracked by the garbage collector (16 B each less);
    # the authority of a frame's last sample is BufferCore's (_auths)
    cdef readonly int64_t newest        # newest stamp; -1 empty; 0 for statics (ignored by the LCT)
    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1
    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept
    cdef int32_t parent_at_c(self, int64_t t) noexcept
    cdef int32_t latest_parent_c(self) noexcept
    cdef int span_c(self, int64_t lo, int64_t hi, int32_t* parent, Py_ssize_t* first, Py_ssize_t* last,
                    int64_t* split) noexcept
    cdef object link_columns(self, Py_ssize_t first, Py_ssize_t last)
    cdef void clear_c(self) noexcept


cdef struct _Run:
    int64_t hi                          # (stamp - epoch) >> 32 of every sample in the run
    int64_t start                       # virtual index (see TimeCache._base) of its first sample


cdef struct _Interp:
    # the last interpolated query (time and answer) and the constants of the last interval asked
    int64_t memo_t
    int32_t memo_p
    double memo[7]
    int64_t sp_t0, sp_t1
    int32_t sp_p
    bint sp_same                        # False: parents differ, the older sample applies as is
    double sp[16]                       # inv_dt, p0 (3), dp (3), q0 (4), a (4), theta


cdef struct _Konst:
    # the columns that have held one value (bit for bit) since the frame's first sample, and the order
    # of the columns in a slot; allocated by the first sample, freed once every column varies
    double k[7]                         # the constant columns' values (the others' entries unused)
    unsigned char vc[7]                 # the varying columns, then (from vc[_nv] on) the constant ones


@cython.final
cdef class TimeCache(CacheBase):
    # the ring is one allocation (_d): _cap slots of _w doubles, then _cap uint32 low words (_lo)
    cdef double* _d                     # per slot, the _nv varying values of tx, ty, tz, qx, qy, qz, qw (stride _w)
    cdef uint32_t* _lo                  # low 32 bits of the stamps (ns) = _d + _cap * _w; logical 0 = oldest
    cdef int32_t* _par                  # parent per slot; NULL while every sample has parent _par0
    cdef _Run* _runs                    # the high 32 bits: one entry per run of samples sharing them (&_run0
                                        # while there is room for one run only)
    cdef _Interp* _ip                   # allocated by the first interpolated lookup
    cdef _Konst* _kc                    # NULL while _cm is 0 (every column varies)
    cdef int32_t _par0
    cdef int32_t _nruns, _runs_cap
    # bit per array held in its own mapping: 2 the ring, 4 _par; and 1: pruning has begun (the cache
    # holds about as many samples as it will)
    cdef unsigned char _mm
    # columns that have held one value (bit for bit) since the frame's first sample are kept once, in
    # _kc, not per slot: _cm has a bit per such column; the _nv others are stored, in the column order
    # _kc.vc, _w = max(_nv, 1) doubles a slot (a fixed joint's translation, a planar base's z, roll, pitch)
    cdef unsigned char _cm, _nv, _w
    cdef Py_ssize_t _cap, _head, _n
    cdef int64_t _base                  # virtual index of the oldest sample (samples pruned so far)
    cdef int64_t _epoch                 # stamps are stored as stamp - _epoch (the first sample's stamp)
    cdef public int64_t max_ns
    cdef int64_t oldest
    cdef _Run _run0                     # the run table's room while it has one entry (no allocation)
    cdef inline Py_ssize_t _slot(self, Py_ssize_t i) noexcept
    cdef inline int32_t _parent(self, Py_ssize_t j) noexcept
    cdef inline int64_t _stamp(self, Py_ssize_t i) noexcept
    cdef void _reset(self) noexcept
    cdef void _release(self) noexcept
    cdef int _own_parents(self) except -1
    cdef Py_ssize_t _grown(self) noexcept
    cdef int _set_cap(self, Py_ssize_t cap) noexcept
    cdef int _unroll(self) noexcept
    cdef int _add_run(self, Py_ssize_t k, int64_t hi, int64_t start) noexcept
    cdef void _prune(self) noexcept
    cdef void _span(self, _Interp* ip, Py_ssize_t i, Py_ssize_t run) noexcept
    cdef Py_ssize_t _bound(self, int64_t t, bint right) noexcept
    cdef inline Py_ssize_t _floor(self, int64_t t, Py_ssize_t* run) noexcept
    cdef Py_ssize_t _floor_runs(self, int64_t t, Py_ssize_t* run) noexcept
    cdef inline void _copy(self, Py_ssize_t i, int32_t* parent, double* out) noexcept
    cdef inline void _unpack(self, Py_ssize_t j, double* out) noexcept
    cdef inline void _pack(self, double* slot, const double* v) noexcept
    cdef inline void _unpack2(self, Py_ssize_t j0, Py_ssize_t j1, double* a, double* b) noexcept
    cdef int _widen(self, unsigned char cm) noexcept
    cdef inline void _place(self, void* blk, Py_ssize_t cap, size_t w) noexcept


@cython.final
cdef class StaticCache(CacheBase):
    cdef int32_t _parent
    cdef double _v[7]
