# The stamp types as extension types: buffer_core and the ingest path read and build them without attribute lookups.

cdef class _Nanoseconds:
    cdef public object _ns


cdef class Duration(_Nanoseconds):
    pass


cdef class Time(_Nanoseconds):
    pass
