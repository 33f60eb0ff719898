# Declarations of BufferCore (buffer_core.pyx) for compiled callers: the listener's decoder
# (zentf/transport/ingest/handler.pyx) inserts decoded samples through ingest_*_c without building tuples.
cimport cython
from cpython.pythread cimport PyThread_type_lock
from libc.stdint cimport int32_t, int64_t


cdef struct _Memo:
    int64_t version
    int64_t t
    int64_t stamp
    int32_t target
    int32_t source
    double v[7]


cdef struct _Link:
    # one link of a walk planned over a range of times: the frame and the samples it reads
    int32_t frame
    Py_ssize_t first, last


cdef struct _Plan:
    # what a walk over a range of times found (BufferCore.chain_plan): links[0:n_source] lead up
    # from the source, links[target_at:target_at + n_target] up from the target
    _Link* links
    int n_source, target_at, n_target
    int64_t split                       # where the walk changes, when it does


@cython.final
cdef class _Lock:
    cdef PyThread_type_lock _lk
    cdef bint _held
    cdef int acquire_c(self) except -1
    cdef void release_c(self) noexcept


cdef class BufferCore:
    cdef dict __dict__          # attributes beyond these (the bounds, the rate-limited logger, subclasses' own)
    cdef object __weakref__
    cdef readonly _Lock _lock
    cdef public dict _ids
    cdef public list _names, _caches, _auths, _requests, _insert_callbacks
    cdef public int64_t _cache_ns
    cdef public int64_t _version
    # waking waiters (zentf.transport.buffer.Buffer): every successful insert bumps _generation in C; only while
    # _wake_wanted (waiters, pending async waits) is non-zero does it call the Python ``_wake()``
    cdef public int64_t _generation
    cdef public Py_ssize_t _wake_wanted
    cdef _Memo* _memo
    cdef int64_t* _marks       # per frame id: the LCT walk that last saw it (membership test)
    cdef Py_ssize_t _marks_len
    cdef int64_t _mark_epoch

    cdef int _append_fast(self, object parent, object child, object stamp, object tx, object ty,
                          object tz, object qx, object qy, object qz, object qw, object authority) except -1
    cdef int _append_c(self, object parent, object child, int64_t st, const double* v,
                       object authority) except -1
    cdef int ingest_begin_c(self) except -1
    cdef int ingest_one_c(self, object parent, object child, int64_t stamp, const double* v,
                          object authority, bint is_static) except -1
    cdef int ingest_end_c(self, Py_ssize_t accepted) except -1
    cdef int _after_insert(self) except -1
    cdef object _store(self, object parent, object child, object stamp, object tx, object ty, object tz,
                       object qx, object qy, object qz, object qw, object authority, bint is_static)
    cdef int32_t _clean_id(self, object frame) except -1
    cdef int64_t _lookup_ids(self, int32_t target_id, int32_t source_id, int64_t t, double* out,
                             object target, object source) except -1
    cdef int _walk(self, int32_t target_id, int32_t source_id, int64_t t, int64_t t_hi, double* out,
                   int32_t* bad, _Plan* plan) noexcept
    cdef int _raise_walk(self, int res, int32_t bad, int32_t target_id, int32_t source_id, int64_t t,
                         object target, object source) except -1
    cdef int _mark_room(self) except -1
    cdef int64_t _lct(self, int32_t target_id, int32_t source_id) except -1


cdef Py_ssize_t _slot_offset(object cls, str name) except? -2
