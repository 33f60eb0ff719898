# cython: language_level=3
"""A CDR TFMessage (DDS, rmw_zenoh) straight to the msgpack payload zentf's broadcasters send, in C: the
DDS bridge's hot path (one pass to check the layout and size the output, one to write it; no Python
objects per transform). Anything doubtful (a negative stamp, a name that is not UTF-8, a truncated
payload) gives None and the caller takes the Python path, which says what is wrong."""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from libc.stdint cimport int32_t, uint8_t, uint32_t, uint64_t
from libc.string cimport memcpy

from zentf.transport.ingest.decoders cimport cdr_le

cdef bytes _STAMP = b"\x83\xa6header\x82\xa5stamp\x82\xa3sec\xce"
cdef bytes _NSEC = b"\xa7nanosec\xce"
cdef bytes _FRAME = b"\xa8frame_id"
cdef bytes _CHILD = b"\xaechild_frame_id"
cdef bytes _TRANS = b"\xa9transform\x82\xabtranslation\x83\xa1x"
cdef bytes _ROT = b"\xa8rotation\x84\xa1x"
cdef Py_ssize_t _MAX_PAYLOAD = 64 * 1024 * 1024
cdef uint32_t _NS = 1000000000


cdef inline uint32_t _u32le(const uint8_t* p) noexcept nogil:
    return <uint32_t>p[0] | (<uint32_t>p[1] << 8) | (<uint32_t>p[2] << 16) | (<uint32_t>p[3] << 24)


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


cdef inline Py_ssize_t _str_head(Py_ssize_t n) noexcept nogil:
    return 1 if n < 32 else 2 if n < 256 else 3 if n < 65536 else 5


cdef inline char* _put(char* o, bytes b) noexcept:
    memcpy(o, PyBytes_AS_STRING(b), PyBytes_GET_SIZE(b))
    return o + PyBytes_GET_SIZE(b)


cdef inline char* _be32(char* o, uint32_t v) noexcept nogil:
    o[0] = <char>(v >> 24)
    o[1] = <char>(v >> 16)
    o[2] = <char>(v >> 8)
    o[3] = <char>v
    return o + 4


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
        o = _be32(o + 1, <uint32_t>n)
    memcpy(o, s, n)
    return o + n


cdef inline char* _f64(char* o, const uint8_t* le) noexcept nogil:
    """A msgpack float64 from 8 little-endian bytes (the marker, then big-endian)."""
    cdef int i
    o[0] = <char>0xcb
    for i in range(8):
        o[1 + i] = <char>le[7 - i]
    return o + 9


cdef inline char* _key_f64(char* o, char name, const uint8_t* le) noexcept nogil:
    o[0] = <char>0xa1
    o[1] = name
    return _f64(o + 2, le)


def tf_cdr_to_msgpack(payload):
    """zentf's msgpack TFMessage for a well-formed little-endian CDR TFMessage; None if anything is doubtful."""
    if type(payload) is not bytes:
        return None
    cdef Py_ssize_t end = PyBytes_GET_SIZE(payload)
    if end > _MAX_PAYLOAD or end < 8:
        return None
    cdef const uint8_t* p = <const uint8_t*>PyBytes_AS_STRING(payload)
    if not cdr_le(p, end):
        return None
    cdef uint32_t n = _u32le(p + 4)
    if <uint64_t>n * 72 > <uint64_t>(end - 8):
        return None
    cdef Py_ssize_t off = 8, ln, i, size
    cdef Py_ssize_t fixed = (PyBytes_GET_SIZE(_STAMP) + 4 + PyBytes_GET_SIZE(_NSEC) + 4 + PyBytes_GET_SIZE(_FRAME)
                             + PyBytes_GET_SIZE(_CHILD) + PyBytes_GET_SIZE(_TRANS) + 9 + 2 * 11
                             + PyBytes_GET_SIZE(_ROT) + 9 + 3 * 11)
    size = 12 + (1 if n < 16 else 3 if n < 65536 else 5)
    # pass 1: check the layout, size the output
    for i in range(n):
        if end - off < 12:
            return None
        if <int32_t>_u32le(p + off) < 0 or _u32le(p + off + 4) >= _NS:
            return None
        ln = _u32le(p + off + 8)
        off += 12
        if ln < 1 or end - off < ln or p[off + ln - 1] != 0 or not _utf8(p + off, ln - 1):
            return None
        size += _str_head(ln - 1) + ln - 1
        off = (off + ln + 3) & ~(<Py_ssize_t>3)
        if end - off < 4:
            return None
        ln = _u32le(p + off)
        off += 4
        if ln < 1 or end - off < ln or p[off + ln - 1] != 0 or not _utf8(p + off, ln - 1):
            return None
        size += _str_head(ln - 1) + ln - 1
        off += ln
        off += (4 - off) & 7
        if end - off < 56:
            return None
        off += 56
        size += fixed
    # pass 2: write
    out = PyBytes_FromStringAndSize(NULL, size)
    cdef char* o = PyBytes_AS_STRING(out)
    cdef char* start = o
    memcpy(o, b"\x81\xaatransforms", 12)
    o += 12
    if n < 16:
        o[0] = <char>(0x90 | n)
        o += 1
    elif n < 65536:
        o[0] = <char>0xdc
        o[1] = <char>(n >> 8)
        o[2] = <char>n
        o += 3
    else:
        o[0] = <char>0xdd
        o = _be32(o + 1, n)
    off = 8
    cdef const uint8_t* parent
    cdef Py_ssize_t parent_len
    for i in range(n):
        o = _put(o, _STAMP)
        o = _be32(o, _u32le(p + off))
        o = _put(o, _NSEC)
        o = _be32(o, _u32le(p + off + 4))
        ln = _u32le(p + off + 8)
        off += 12
        o = _put(o, _FRAME)
        o = _str(o, p + off, ln - 1)
        off = (off + ln + 3) & ~(<Py_ssize_t>3)
        ln = _u32le(p + off)
        off += 4
        o = _put(o, _CHILD)
        o = _str(o, p + off, ln - 1)
        off += ln
        off += (4 - off) & 7
        o = _put(o, _TRANS)
        o = _f64(o, p + off)
        o = _key_f64(o, 121, p + off + 8)
        o = _key_f64(o, 122, p + off + 16)
        o = _put(o, _ROT)
        o = _f64(o, p + off + 24)
        o = _key_f64(o, 121, p + off + 32)
        o = _key_f64(o, 122, p + off + 40)
        o = _key_f64(o, 119, p + off + 48)
        off += 56
    if o - start != size:
        raise AssertionError("tf_cdr_to_msgpack: size")
    return out
