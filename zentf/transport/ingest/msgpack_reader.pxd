# cython: language_level=3
"""A msgpack reader over a byte range, in C: the pieces both compiled decoders use (the listener's
TFMessage decoder, zentf/transport/ingest/decoders.pyx, and robot_state_publisher's JointState reader,
zentf/tools/jointtf.pyx).
Each returns False, without a Python exception, for anything unlike what it reads (or cut short)."""
from libc.stdint cimport int64_t, uint8_t, uint32_t, uint64_t
from libc.string cimport memcmp, memcpy

cdef enum:
    _MAX_DEPTH = 16  # nesting skipped inside unknown fields


cdef extern from *:
    """
    /* a big-endian 64-bit word: one load and a byte swap (gcc leaves _be's loop as 8 loads and shifts) */
    static inline uint64_t zentf_be64(const uint8_t* p) {
        uint64_t u;
        memcpy(&u, p, 8);
    #if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
        u = __builtin_bswap64(u);
    #endif
        return u;
    }
    """
    uint64_t _be64 "zentf_be64"(const uint8_t* p) noexcept nogil


cdef inline uint64_t _be(const uint8_t* p, int n) noexcept nogil:
    cdef uint64_t u = 0
    cdef int i
    for i in range(n):
        u = (u << 8) | p[i]
    return u


cdef struct Cur:
    const uint8_t* p
    const uint8_t* end


cdef inline bint _take(Cur* c, Py_ssize_t n) noexcept nogil:
    """Advance by n bytes if they are there."""
    if c.end - c.p < n:
        return False
    c.p += n
    return True


cdef inline bint _container(Cur* c, uint8_t fix, uint8_t op16, Py_ssize_t* n) noexcept nogil:
    """Length of a map (fix=0x80, op16=0xde) or array (fix=0x90, op16=0xdc); False if not one."""
    if c.p >= c.end:
        return False
    cdef uint8_t t = c.p[0]
    if (t & 0xf0) == fix:
        n[0] = t & 0x0f
        c.p += 1
        return True
    if t == op16 and c.end - c.p >= 3:
        n[0] = <Py_ssize_t>_be(c.p + 1, 2)
        c.p += 3
        return True
    if t == op16 + 1 and c.end - c.p >= 5:
        n[0] = <Py_ssize_t>_be(c.p + 1, 4)
        c.p += 5
        return True
    return False


cdef inline bint _str(Cur* c, const uint8_t** s, Py_ssize_t* n) noexcept nogil:
    """A msgpack str (not bin: the Python fast path wants str) -> its bytes."""
    if c.p >= c.end:
        return False
    cdef uint8_t t = c.p[0]
    cdef Py_ssize_t ln, head
    if (t & 0xe0) == 0xa0:
        ln = t & 0x1f
        head = 1
    elif t == 0xd9 and c.end - c.p >= 2:
        ln = c.p[1]
        head = 2
    elif t == 0xda and c.end - c.p >= 3:
        ln = <Py_ssize_t>_be(c.p + 1, 2)
        head = 3
    elif t == 0xdb and c.end - c.p >= 5:
        ln = <Py_ssize_t>_be(c.p + 1, 4)
        head = 5
    else:
        return False
    if c.end - c.p - head < ln:
        return False
    s[0] = c.p + head
    n[0] = ln
    c.p += head + ln
    return True


cdef inline bint _int(Cur* c, int64_t* v) noexcept nogil:
    """A msgpack integer that fits int64 (not a bool, not a float)."""
    if c.p >= c.end:
        return False
    cdef uint8_t t = c.p[0]
    cdef uint64_t u
    if t <= 0x7f:
        v[0] = t
        c.p += 1
        return True
    if t >= 0xe0:
        v[0] = <int64_t>t - 256
        c.p += 1
        return True
    cdef int size
    if 0xcc <= t <= 0xcf:
        size = 1 << (t - 0xcc)
        if c.end - c.p < 1 + size:
            return False
        u = _be(c.p + 1, size)
        if u > 9223372036854775807ULL:
            return False
        v[0] = <int64_t>u
    elif 0xd0 <= t <= 0xd3:
        size = 1 << (t - 0xd0)
        if c.end - c.p < 1 + size:
            return False
        u = _be(c.p + 1, size)
        if size < 8 and (u >> (8 * size - 1)) & 1:  # sign-extend
            u |= ~((<uint64_t>1 << (8 * size)) - 1)
        v[0] = <int64_t>u
    else:
        return False
    c.p += 1 + size
    return True


cdef inline bint _float(Cur* c, double* v) noexcept nogil:
    """A msgpack float64/float32, or an integer as a float (as the Python path takes it)."""
    if c.p >= c.end:
        return False
    cdef uint8_t t = c.p[0]
    cdef uint64_t u
    cdef uint32_t u32
    cdef float f
    cdef int64_t i
    if t == 0xcb:
        if c.end - c.p < 9:
            return False
        u = _be64(c.p + 1)
        memcpy(v, &u, 8)
        c.p += 9
        return True
    if t == 0xca:
        if c.end - c.p < 5:
            return False
        u32 = <uint32_t>_be(c.p + 1, 4)
        memcpy(&f, &u32, 4)
        v[0] = f
        c.p += 5
        return True
    if t == 0xcf:  # uint64 beyond int64
        if c.end - c.p < 9:
            return False
        v[0] = <double>_be64(c.p + 1)
        c.p += 9
        return True
    if not _int(c, &i):
        return False
    v[0] = <double>i
    return True


cdef inline bint _skip(Cur* c, int depth) noexcept nogil:
    """Step over one value of an unknown field; False for anything the Python paths might read
    differently (ext types, container map keys, deep nesting, truncation)."""
    if c.p >= c.end or depth > _MAX_DEPTH:
        return False
    cdef uint8_t t = c.p[0]
    cdef Py_ssize_t n, i
    cdef const uint8_t* s
    if t <= 0x7f or t >= 0xe0 or t == 0xc0 or t == 0xc2 or t == 0xc3:
        c.p += 1
        return True
    if (t & 0xe0) == 0xa0 or 0xd9 <= t <= 0xdb:
        return _str(c, &s, &n)
    if 0xc4 <= t <= 0xc6:  # bin 8/16/32
        n = 1 << (t - 0xc4)
        if c.end - c.p < 1 + n:
            return False
        i = <Py_ssize_t>_be(c.p + 1, <int>n)
        return _take(c, 1 + n + i)
    if t == 0xca:
        return _take(c, 5)
    if t == 0xcb:
        return _take(c, 9)
    if 0xcc <= t <= 0xcf:
        return _take(c, 1 + (1 << (t - 0xcc)))
    if 0xd0 <= t <= 0xd3:
        return _take(c, 1 + (1 << (t - 0xd0)))
    if (t & 0xf0) == 0x90 or t == 0xdc or t == 0xdd:
        if not _container(c, 0x90, 0xdc, &n):
            return False
        for i in range(n):
            if not _skip(c, depth + 1):
                return False
        return True
    if (t & 0xf0) == 0x80 or t == 0xde or t == 0xdf:
        if not _container(c, 0x80, 0xde, &n):
            return False
        for i in range(n):
            if c.p >= c.end:
                return False
            t = c.p[0]
            if (t & 0xf0) == 0x90 or (t & 0xf0) == 0x80 or 0xdc <= t <= 0xdf:
                return False  # unhashable as a dict key: msgpack fails the whole payload
            if not _skip(c, depth + 1) or not _skip(c, depth + 1):
                return False
        return True
    return False  # ext types and 0xc1: leave them to msgpack


cdef inline bint _is(const uint8_t* k, Py_ssize_t n, const char* name, Py_ssize_t m) noexcept nogil:
    """The n bytes at k are the m-byte name (a key read by _str)."""
    return n == m and memcmp(k, name, m) == 0
