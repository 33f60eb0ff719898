# cython: language_level=3
"""A msgpack writer into a buffer the caller sized, in C: the pieces both compiled encoders use
(tf_encoder.pyx's TransformStamped, joint_state_encoder.pyx's JointState). Each writes at ``o`` and
returns where the next byte goes."""
from libc.stdint cimport uint32_t, uint64_t
from libc.string cimport memcpy
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_GET_SIZE


cdef inline char* _w_put(char* o, bytes b) noexcept:
    memcpy(o, PyBytes_AS_STRING(b), PyBytes_GET_SIZE(b))
    return o + PyBytes_GET_SIZE(b)


cdef inline char* _w_be32(char* o, uint32_t v) noexcept:
    o[0] = <char>(v >> 24)
    o[1] = <char>(v >> 16)
    o[2] = <char>(v >> 8)
    o[3] = <char>v
    return o + 4


cdef inline char* _w_key(char* o, const char* name, int n) noexcept:
    """A short msgpack str (a field name)."""
    o[0] = <char>(0xa0 | n)
    memcpy(o + 1, name, n)
    return o + 1 + n


cdef inline char* _w_f64(char* o, double d) noexcept:
    """A msgpack float64 (marker and big-endian bytes)."""
    cdef uint64_t u
    cdef int i
    memcpy(&u, &d, 8)
    o[0] = <char>0xcb
    for i in range(8):
        o[1 + i] = <char>(u >> (56 - 8 * i))
    return o + 9


cdef inline char* _w_uint(char* o, uint64_t v) noexcept:
    """A msgpack unsigned integer, in the smallest form (as msgpack-python writes it)."""
    cdef int n, i
    if v < 128:
        o[0] = <char>v
        return o + 1
    if v < 0x100:
        o[0] = <char>0xcc
        n = 1
    elif v < 0x10000:
        o[0] = <char>0xcd
        n = 2
    elif v < 0x100000000:
        o[0] = <char>0xce
        n = 4
    else:
        o[0] = <char>0xcf
        n = 8
    for i in range(n):
        o[1 + i] = <char>(v >> (8 * (n - 1 - i)))
    return o + 1 + n


cdef inline char* _w_array(char* o, Py_ssize_t n) noexcept:
    """A msgpack array header."""
    if n < 16:
        o[0] = <char>(0x90 | n)
        return o + 1
    if n < 0x10000:
        o[0] = <char>0xdc
        o[1] = <char>(n >> 8)
        o[2] = <char>n
        return o + 3
    o[0] = <char>0xdd
    return _w_be32(o + 1, <uint32_t>n)

