# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""A ROS TFMessage (ROS 2 CDR, ROS 1 serialization) straight to zentf's msgpack TFMessage, in C: the DDS
bridge's /tf and ``bag convert`` / ``bag play`` of ROS bags; and zentf's msgpack TFMessage to ROS 2 CDR
(``tf_msgpack_to_cdr``: ``bag play`` of zentf and ROS 1 bags onto ROS 2's wire). The message is read by the shared walkers
(decoders.pxd: the listener's and the bag loader's bounds and refusals), its names checked for UTF-8,
then written in one allocation; no Python object per transform. Anything doubtful gives None and the
caller takes its Python path, which says what is wrong.

``packb=True`` writes the bytes ``msgpack.packb`` writes for the plain dict (ints in their smallest
form): what ``bag convert`` wrote through rosbags' decoder and ``to_plain``. ``packb=False`` writes
sec/nanosec as uint32, as zentf's broadcasters do (the DDS bridge).
"""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize
from libc.stdint cimport int64_t, uint8_t, uint32_t, uint64_t
from libc.string cimport memcpy

from .decoders cimport WALK_CDR, WALK_MSGPACK, WALK_ROS1, Sample, Walk, walk, walk_done
from .msgpack_writer cimport _w_array, _w_be32, _w_f64, _w_uint

__all__ = ["tf_cdr_to_msgpack", "tf_cdr_transcodes", "tf_ros1_to_msgpack", "tf_msgpack_to_cdr"]

cdef const char* _HEAD = b"\x81\xaatransforms"                          # 12 bytes, then the array header
cdef const char* _STAMP = b"\x83\xa6header\x82\xa5stamp\x82\xa3sec"     # 20 bytes, then sec
cdef const char* _NSEC = b"\xa7nanosec"                                 # 8, then nanosec
cdef const char* _FRAME = b"\xa8frame_id"                               # 9, then the name
cdef const char* _CHILD = b"\xaechild_frame_id"                         # 15, then the name
cdef const char* _TRANS = b"\xa9transform\x82\xabtranslation\x83\xa1x"  # 26, then x
cdef const char* _ROT = b"\xa8rotation\x84\xa1x"                        # 12, then x
#: the constant bytes of one element: keys, float markers (7 x 9 bytes), the y/z/w keys (5 x 2)
cdef Py_ssize_t _FIXED = 20 + 8 + 9 + 15 + 26 + 12 + 7 * 9 + 5 * 2

cdef bint _utf8(const uint8_t* p, Py_ssize_t n) noexcept nogil:
    """Well-formed UTF-8 (no overlongs, surrogates or code points past U+10FFFF), no NUL."""
    cdef Py_ssize_t i = 0
    cdef uint8_t c
    cdef int k, j
    cdef uint32_t cp
    while i < n:
        c = p[i]
        if c < 0x80:
            if c == 0:
                return False
            i += 1
            continue
        if c >= 0xc2 and c <= 0xdf:
            k = 1
            cp = c & 0x1f
        elif c >= 0xe0 and c <= 0xef:
            k = 2
            cp = c & 0x0f
        elif c >= 0xf0 and c <= 0xf4:
            k = 3
            cp = c & 0x07
        else:
            return False
        for j in range(1, k + 1):
            if i + j >= n or (p[i + j] & 0xc0) != 0x80:
                return False
            cp = (cp << 6) | (p[i + j] & 0x3f)
        if (k == 2 and (cp < 0x800 or (cp >= 0xd800 and cp <= 0xdfff))) or (k == 3 and (cp < 0x10000 or cp > 0x10ffff)):
            return False
        i += k + 1
    return True


cdef inline Py_ssize_t _str_size(Py_ssize_t n) noexcept nogil:
    return n + (1 if n < 32 else 2 if n < 256 else 3 if n < 65536 else 5)


cdef inline Py_ssize_t _uint_size(uint64_t v, bint packb) noexcept nogil:
    if not packb:
        return 5
    return 1 if v < 128 else 2 if v < 0x100 else 3 if v < 0x10000 else 5 if v < <uint64_t>0x100000000 else 9


cdef inline char* _lit(char* o, const char* s, Py_ssize_t n) noexcept nogil:
    memcpy(o, s, n)
    return o + n


cdef inline char* _uint(char* o, uint64_t v, bint packb) noexcept:
    if packb:
        return _w_uint(o, v)
    o[0] = <char>0xce
    return _w_be32(o + 1, <uint32_t>v)


cdef inline char* _str(char* o, const uint8_t* s, Py_ssize_t n) noexcept nogil:
    if n < 32:
        o[0] = <char>(0xa0 | n)
        o += 1
    elif n < 256:
        o[0] = <char>0xd9
        o[1] = <char>n
        o += 2
    elif n < 65536:
        o[0] = <char>0xda
        o[1] = <char>(n >> 8)
        o[2] = <char>n
        o += 3
    else:
        o[0] = <char>0xdb
        o[1] = <char>(n >> 24)
        o[2] = <char>(n >> 16)
        o[3] = <char>(n >> 8)
        o[4] = <char>n
        o += 5
    memcpy(o, s, n)
    return o + n


cdef inline char* _key_f64(char* o, char name, double v) noexcept:
    o[0] = <char>0xa1
    o[1] = name
    return _w_f64(o + 2, v)


cdef Py_ssize_t _size(Sample* s, Py_ssize_t n, bint packb) noexcept nogil:
    """The bytes of the msgpack TFMessage of n walked samples; -1 if a name is not UTF-8 (or has a NUL), or a
    stamp does not fit the uint32 the broadcasters write."""
    cdef Py_ssize_t i, size = 12 + (1 if n < 16 else 3 if n < 65536 else 5)
    for i in range(n):
        if not (_utf8(s[i].parent, s[i].parent_len) and _utf8(s[i].child, s[i].child_len)):
            return -1
        if s[i].sec > <int64_t>0xFFFFFFFF or s[i].nsec > <int64_t>0xFFFFFFFF:
            return -1
        size += (_FIXED + _str_size(s[i].parent_len) + _str_size(s[i].child_len) + _uint_size(s[i].sec, packb)
                 + _uint_size(s[i].nsec, packb))
    return size


cdef object _write(Sample* s, Py_ssize_t n, bint packb):
    """The msgpack TFMessage of n walked samples; None where _size says -1."""
    cdef Py_ssize_t i, size = _size(s, n, packb)
    if size < 0:
        return None
    out = PyBytes_FromStringAndSize(NULL, size)
    cdef char* o = PyBytes_AS_STRING(out)
    cdef char* start = o
    o = _w_array(_lit(o, _HEAD, 12), n)
    for i in range(n):
        o = _uint(_lit(o, _STAMP, 20), <uint64_t>s[i].sec, packb)
        o = _uint(_lit(o, _NSEC, 8), <uint64_t>s[i].nsec, packb)
        o = _str(_lit(o, _FRAME, 9), s[i].parent, s[i].parent_len)
        o = _str(_lit(o, _CHILD, 15), s[i].child, s[i].child_len)
        o = _w_f64(_lit(o, _TRANS, 26), s[i].v[0])
        o = _key_f64(o, b'y', s[i].v[1])
        o = _key_f64(o, b'z', s[i].v[2])
        o = _w_f64(_lit(o, _ROT, 12), s[i].v[3])
        o = _key_f64(o, b'y', s[i].v[4])
        o = _key_f64(o, b'z', s[i].v[5])
        o = _key_f64(o, b'w', s[i].v[6])
    if o - start != size:
        raise AssertionError("tf_transcode: size")
    return out


cdef inline void _put_u32le(char* o, uint32_t v) noexcept nogil:
    o[0] = <char>v
    o[1] = <char>(v >> 8)
    o[2] = <char>(v >> 16)
    o[3] = <char>(v >> 24)


cdef inline Py_ssize_t _put_string(char* o, Py_ssize_t at, const uint8_t* p, Py_ssize_t n,
                                   Py_ssize_t align) noexcept nogil:
    """A CDR string at o + at (length with its NUL, bytes, NUL), zeros until at & align is 0: the new at."""
    _put_u32le(o + at, <uint32_t>(n + 1))
    memcpy(o + at + 4, p, n)
    at += 4 + n
    o[at] = 0
    at += 1
    while at & align:
        o[at] = 0
        at += 1
    return at


cdef object _write_cdr(Sample* s, Py_ssize_t n):
    """The CDR TFMessage (XCDR1 little-endian) of n walked samples, laid out as zentf.ros.tf.encode_tf lays it
    out (zero padding); None if a name is not UTF-8 (or has a NUL) or a sec does not fit CDR's int32."""
    cdef Py_ssize_t i, at, size = 8
    for i in range(n):  # ``at``: bytes after the 4-byte encapsulation header, as CDR aligns
        if not (_utf8(s[i].parent, s[i].parent_len) and _utf8(s[i].child, s[i].child_len)):
            return None
        if s[i].sec > 0x7FFFFFFF or s[i].parent_len > 0xFFFFFFF0 or s[i].child_len > 0xFFFFFFF0:
            return None
        at = size - 4 + 8 + 4 + s[i].parent_len + 1
        at += (-at) & 3
        at += 4 + s[i].child_len + 1
        at += (-at) & 7
        size = at + 4 + 56
    out = PyBytes_FromStringAndSize(NULL, size)
    cdef char* o = PyBytes_AS_STRING(out)
    memcpy(o, b"\x00\x01\x00\x00", 4)
    _put_u32le(o + 4, <uint32_t>n)
    at = 4
    for i in range(n):
        _put_u32le(o + 4 + at, <uint32_t>s[i].sec)
        _put_u32le(o + 4 + at + 4, <uint32_t>s[i].nsec)
        at += 8
        at = _put_string(o + 4, at, s[i].parent, s[i].parent_len, 3)
        at = _put_string(o + 4, at, s[i].child, s[i].child_len, 7)
        memcpy(o + 4 + at, s[i].v, 56)  # little-endian hosts only (setup.py builds for x86-64 and arm64)
        at += 56
    if at + 4 != size:
        raise AssertionError("tf_transcode: cdr size")
    return out


def tf_msgpack_to_cdr(payload):
    """The ROS 2 CDR TFMessage (zentf.ros.tf.encode_tf's bytes) of a zentf msgpack TFMessage laid out as zentf writes
    it, read by the listener's walker; None if anything is doubtful or laid out otherwise (the caller's Python
    path reads it and says what is wrong)."""
    cdef Walk w
    cdef Py_ssize_t n = walk(&w, WALK_MSGPACK, payload)
    try:
        if n < 0:
            return None
        # only zentf's own layouts (its broadcasters' uint32 stamps, or msgpack.packb's): the walker skips unknown
        # fields and reads keys in any order, which the Python path's TFMessage.from_dict refuses or reads otherwise
        if _write(w.buf, n, False) != payload and _write(w.buf, n, True) != payload:
            return None
        return _write_cdr(w.buf, n)
    finally:
        walk_done(&w)


cdef object _transcode(object payload, bint ros1, bint packb):
    cdef Walk w
    cdef Py_ssize_t n = walk(&w, WALK_ROS1 if ros1 else WALK_CDR, payload)
    try:
        return _write(w.buf, n, packb) if n >= 0 else None
    finally:
        walk_done(&w)


def tf_cdr_transcodes(payload):
    """tf_cdr_to_msgpack would write this CDR TFMessage (well-formed, names UTF-8, stamps uint32), without
    writing it: a recorded one that may go out as it is."""
    cdef Walk w
    cdef Py_ssize_t n = walk(&w, WALK_CDR, payload)
    try:
        return n >= 0 and _size(w.buf, n, True) >= 0
    finally:
        walk_done(&w)


def tf_cdr_to_msgpack(payload, bint packb=False):
    """zentf's msgpack TFMessage of a well-formed little-endian CDR TFMessage; None if anything is doubtful."""
    return _transcode(payload, False, packb)


def tf_ros1_to_msgpack(payload):
    """zentf's msgpack TFMessage (msgpack.packb's bytes) of a well-formed ROS 1 tf2_msgs/TFMessage, the
    header's seq left out (as rosbag2's ROS 1 converter does) and time read unsigned, as ROS 1 has it;
    None if anything is doubtful."""
    return _transcode(payload, True, True)
