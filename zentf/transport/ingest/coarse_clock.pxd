# cython: language_level=3
"""The kernel's tick-resolution monotonic clock, for windows of 0.1 s and more on the listener's path."""
from libc.stdint cimport int64_t
from posix.time cimport clock_gettime, timespec

cdef extern from *:
    """
    /* Linux: a memory read in the vDSO, ~1/6 of CLOCK_MONOTONIC's cost in a VM (perf: ~2.5 % of the
       listener thread in a flood); elsewhere the plain one. A tick (<= 4 ms) late at most. */
    #include <time.h>
    #ifdef CLOCK_MONOTONIC_COARSE
    #define ZENTF_MONO_COARSE CLOCK_MONOTONIC_COARSE
    #else
    #define ZENTF_MONO_COARSE CLOCK_MONOTONIC
    #endif
    """
    int CLOCK_MONO_COARSE "ZENTF_MONO_COARSE"


cdef inline int64_t coarse_ns() noexcept nogil:
    """The coarse monotonic clock, in ns."""
    cdef timespec ts
    clock_gettime(CLOCK_MONO_COARSE, &ts)
    return ts.tv_sec * 1_000_000_000 + ts.tv_nsec
