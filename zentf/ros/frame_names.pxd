# cython: language_level=3
"""Frame names from wire bytes, interned once for every compiled decoder (listener ingest, bag loader)."""
from libc.stdint cimport uint8_t


cdef object frame_name(const uint8_t* p, Py_ssize_t n)
