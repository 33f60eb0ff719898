# cython: language_level=3
"""The listener's per-topic ingest (handler.pyx), for its thread (thread.pyx)."""
from libc.stdint cimport int64_t

from .decoders cimport Batch


cdef object payload_of(object sample)
cdef object attachment_of(object sample)


cdef class SenderTail:
    cdef readonly Py_ssize_t size, marker_at
    cdef readonly int marker
    cdef bytes last  # the key given last: a flood's sender gets it again without a slice
    cdef object key(self, bytes raw)


cdef class Senders:
    """How a wire names the sender of a sample (shared by a listener's topics)."""
    cdef readonly object authority_of
    cdef readonly object fixed
    cdef readonly object sender_of
    cdef SenderTail tail
    cdef readonly dict cache
    cdef readonly Py_ssize_t max_key
    cdef object queue_key(self, object raw)


cdef class TfIngest:
    cdef readonly bint cdr
    cdef bint is_static
    cdef object slow
    cdef object target
    cdef object core
    cdef object now_ns
    cdef object tolerance_ns
    cdef Batch batch
    cdef int64_t limit
    cdef int64_t limit_until
    cdef bint _too_new(self, int64_t newest) except -1
    cdef object _direct(self, object payload, object authority, bint fast_only=*)
    cdef object fast_c(self, object payload, object authority)
    cdef object slow_c(self, object payload, object authority)


cdef class TfHandler:
    cdef object ingest
    cdef readonly TfIngest cingest
    cdef readonly Senders senders
    cdef readonly object events
    cdef object tf_encoding
    cdef object check_encoding
    cdef object last_raw, last_authority
    cdef public Py_ssize_t messages, transforms, rejected, malformed, wildcard
    cdef public Py_ssize_t payload_bytes
    cdef public object topic
    cdef object concrete  # the subscriber's key as a zenoh.KeyExpr when it has no wildcard, else None
    cdef object authority(self, object sample, object raw)
    cdef object queued(self, object sample, object raw)
    cdef bint handle(self, object sample, object raw, bint have_raw) except -1
    cdef bint handle_payload(self, object payload, object authority) except -1
    cdef bint _ingest(self, object sample, object payload, object authority) except -1
    cdef int _bad(self, object sample, object authority, object error) except -1
