# cython: language_level=3
"""The compiled TFMessage decoders (decoders.pyx), for the listener's ingest (handler.pyx)."""
from libc.stdint cimport int64_t, uint8_t


cdef struct Sample:
    int64_t sec
    int64_t nsec
    const uint8_t* parent
    Py_ssize_t parent_len
    const uint8_t* child
    Py_ssize_t child_len
    double v[7]


cdef class Batch:
    """Decoded samples kept in C (stamps, values) with their frame names."""
    cdef list names             # parent, child per sample
    cdef int64_t* stamps
    cdef double* v              # 7 per sample
    cdef Py_ssize_t n, cap
    cdef int reset(self) except -1
    cdef int push(self, Sample* s) except -1


cdef inline bint cdr_le(const uint8_t* p, Py_ssize_t n) noexcept nogil:
    """A little-endian XCDR1 encapsulation header (what ROS 2 sends) at the start of n bytes."""
    return n >= 8 and p[0] == 0 and p[1] == 1


# The TFMessage walkers: one per serialization, shared by every compiled reader of it (the listener's
# decoders here, the bag loader tools/bag/tfload.pyx, the msgpack writers of tf_transcode.pyx). Each fills
# buf[0][0..count) with samples whose names point into p and returns count, -1 if anything is doubtful,
# -2 if memory ran out (a larger message gets a malloc'd buffer: owned[0] set, the caller frees it).
cdef Py_ssize_t cdr_walk(const uint8_t* p, Py_ssize_t size, Sample** buf, Py_ssize_t* cap,
                         bint* owned) noexcept nogil
cdef Py_ssize_t ros1_walk(const uint8_t* p, Py_ssize_t size, Sample** buf, Py_ssize_t* cap,
                          bint* owned) noexcept nogil
cdef Py_ssize_t msgpack_walk(const uint8_t* p, Py_ssize_t size, Sample** buf, Py_ssize_t* cap, bint* owned,
                             bint canonical) noexcept nogil

cdef enum:
    WALK_MSGPACK = 0
    WALK_CDR = 1
    WALK_ROS1 = 2


cdef struct Walk:
    # one walk's samples: buf is stack (a small message, the listener's common case: 13 KiB on the C stack)
    # or a malloc'd buffer (owned) that walk_done frees
    Sample* buf
    Py_ssize_t cap
    bint owned
    Sample stack[128]


cdef Py_ssize_t walk(Walk* w, int fmt, object payload, bint canonical=*) except -2
cdef void walk_done(Walk* w) noexcept nogil
cdef object decode_msgpack(object payload, int64_t* newest, Batch batch, bint canonical=*)
cdef object decode_cdr(object payload, int64_t* newest, Batch batch)
