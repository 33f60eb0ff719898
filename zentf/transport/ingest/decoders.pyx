# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""The compiled TFMessage decoders, one per wire: payload bytes straight to samples.

``msgpack_tf`` (zentf wire) and ``cdr_tf`` (ROS 2 wire) turn a well-formed TFMessage payload into the
list of ``(parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw)`` tuples ``BufferCore.set_transforms_raw``
takes (or, for the listener, into a ``Batch`` it inserts from C), without building any intermediate
object. They are strict on purpose: anything doubtful (a bad shape, a duplicate or missing field, a stamp
out of range, a name that is not UTF-8 or without its NUL, a truncated payload) returns None, and the
caller reads the payload with the one Python path of its wire, which names each problem
(zentf.transport.wire.codec ``tf_samples``, zentf.ros.tf ``tf_samples``). So a payload either decodes here
to the samples the Python path would give, or is malformed; nothing is learnt or kept from a payload but
frame names (a bounded cache).
"""
cimport cython
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from libc.stdint cimport int32_t, int64_t, uint8_t, uint32_t, uint64_t
from libc.stdlib cimport free, malloc, realloc
from libc.string cimport memcmp, memcpy

from ...ros.frame_names cimport frame_name
from .msgpack_reader cimport Cur, _be64, _container, _float, _int, _is, _skip, _str

__all__ = ["msgpack_tf", "cdr_tf", "ros1_tf", "canonical_hits", "MAX_PAYLOAD", "FRAME_CACHE_SIZE"]

from ...ros.tf import MAX_PAYLOAD  # larger payloads are not decoded here (the Python paths refuse them)
cdef Py_ssize_t _MAX_PAYLOAD = MAX_PAYLOAD
cdef int64_t _NS = 1000000000
cdef int64_t _MAX_SEC = 9223372036  # (2**63 - 1) // 1e9: stamps are int64 nanoseconds

cdef extern from "Python.h":
    void PyObject_GC_UnTrack(object)

#: frame names are interned by zentf.ros.frame_names (bounded in names and bytes, shared with the bag loader)
from ...ros.tf import FRAME_CACHE_SIZE

cdef inline uint32_t _u32le(const uint8_t* p) noexcept nogil:
    return p[0] | (<uint32_t>p[1] << 8) | (<uint32_t>p[2] << 16) | (<uint32_t>p[3] << 24)


cdef Py_ssize_t _KEEP_NAMES = 512  # names a batch keeps between messages (256 samples' worth)

cdef class Batch:
    """Decoded samples kept in C (stamps, values) with their frame names, for BufferCore.ingest_one_c:
    no tuple and no float object per transform."""

    def __cinit__(self):
        self.names = []
        self.stamps = NULL
        self.v = NULL
        self.n = 0
        self.cap = 0

    def __dealloc__(self):
        free(self.stamps)
        free(self.v)

    cdef int reset(self) except -1:
        """Empty; the names of a small batch stay until overwritten (no list resize per message)."""
        self.n = 0
        if len(self.names) > _KEEP_NAMES:
            del self.names[:]
        return 0

    cdef int push(self, Sample* s) except -1:
        """Add a decoded sample; 0 if a frame name is not UTF-8 (the payload is then doubtful)."""
        cdef void* p
        parent = frame_name(s.parent, s.parent_len)
        child = frame_name(s.child, s.child_len)
        if parent is None or child is None:
            return 0
        if self.n == self.cap:
            p = realloc(self.stamps, (self.cap * 2 + 16) * sizeof(int64_t))
            if p == NULL:
                raise MemoryError()
            self.stamps = <int64_t*>p
            p = realloc(self.v, (self.cap * 2 + 16) * 7 * sizeof(double))
            if p == NULL:
                raise MemoryError()
            self.v = <double*>p
            self.cap = self.cap * 2 + 16
        if 2 * self.n < len(self.names):  # (always an even length: names go in pairs)
            self.names[2 * self.n] = parent
            self.names[2 * self.n + 1] = child
        else:
            self.names.append(parent)
            self.names.append(child)
        self.stamps[self.n] = s.sec * _NS + s.nsec
        memcpy(&self.v[7 * self.n], s.v, 7 * sizeof(double))
        self.n += 1
        return 1


cdef bint _key(Cur* c, const uint8_t** k, Py_ssize_t* n) noexcept nogil:
    """A field name: str keys only (a bin key is malformed here; the Python path reads it)."""
    return _str(c, k, n)


cdef bint _vec(Cur* c, double* v, int count) noexcept nogil:
    """Map {x, y, z[, w]} of numbers into v[0..count-1], each once, unknown fields skipped."""
    cdef Py_ssize_t n, i, kn
    cdef const uint8_t* k
    cdef int seen = 0, bit
    if not _container(c, 0x80, 0xde, &n):
        return False
    for i in range(n):
        if not _key(c, &k, &kn):
            return False
        bit = -1
        if kn == 1:
            if k[0] == b'x':
                bit = 0
            elif k[0] == b'y':
                bit = 1
            elif k[0] == b'z':
                bit = 2
            elif k[0] == b'w' and count == 4:
                bit = 3
        if bit < 0:
            if not _skip(c, 0):
                return False
            continue
        if seen & (1 << bit) or not _float(c, &v[bit]):
            return False
        seen |= 1 << bit
    return seen == (1 << count) - 1


cdef bint _stamp(Cur* c, Sample* s) noexcept nogil:
    cdef Py_ssize_t n, i, kn
    cdef const uint8_t* k
    cdef int seen = 0
    if not _container(c, 0x80, 0xde, &n):
        return False
    for i in range(n):
        if not _key(c, &k, &kn):
            return False
        if _is(k, kn, b"sec", 3):
            if seen & 1 or not _int(c, &s.sec):
                return False
            seen |= 1
        elif _is(k, kn, b"nanosec", 7):
            if seen & 2 or not _int(c, &s.nsec):
                return False
            seen |= 2
        elif not _skip(c, 0):
            return False
    return seen == 3 and 0 <= s.sec < _MAX_SEC and 0 <= s.nsec < _NS


cdef bint _header(Cur* c, Sample* s) noexcept nogil:
    cdef Py_ssize_t n, i, kn
    cdef const uint8_t* k
    cdef int seen = 0
    if not _container(c, 0x80, 0xde, &n):
        return False
    for i in range(n):
        if not _key(c, &k, &kn):
            return False
        if _is(k, kn, b"stamp", 5):
            if seen & 1 or not _stamp(c, s):
                return False
            seen |= 1
        elif _is(k, kn, b"frame_id", 8):
            if seen & 2 or not _str(c, &s.parent, &s.parent_len):
                return False
            seen |= 2
        elif not _skip(c, 0):
            return False
    return seen == 3


cdef bint _transform(Cur* c, Sample* s) noexcept nogil:
    cdef Py_ssize_t n, i, kn
    cdef const uint8_t* k
    cdef int seen = 0
    if not _container(c, 0x80, 0xde, &n):
        return False
    for i in range(n):
        if not _key(c, &k, &kn):
            return False
        if _is(k, kn, b"translation", 11):
            if seen & 1 or not _vec(c, &s.v[0], 3):
                return False
            seen |= 1
        elif _is(k, kn, b"rotation", 8):
            if seen & 2 or not _vec(c, &s.v[3], 4):
                return False
            seen |= 2
        elif not _skip(c, 0):
            return False
    return seen == 3


cdef bint _stamped(Cur* c, Sample* s) noexcept nogil:
    """One TransformStamped map into s; False on any doubt."""
    cdef Py_ssize_t n, i, kn
    cdef const uint8_t* k
    cdef int seen = 0
    if not _container(c, 0x80, 0xde, &n):
        return False
    for i in range(n):
        if not _key(c, &k, &kn):
            return False
        if _is(k, kn, b"header", 6):
            if seen & 1 or not _header(c, s):
                return False
            seen |= 1
        elif _is(k, kn, b"child_frame_id", 14):
            if seen & 2 or not _str(c, &s.child, &s.child_len):
                return False
            seen |= 2
        elif _is(k, kn, b"transform", 9):
            if seen & 4 or not _transform(c, s):
                return False
            seen |= 4
        elif not _skip(c, 0):
            return False
    return seen == 7


# The layout zentf writes (wire.encode_tf's template, robot_state_publisher's, msgpack.packb of
# wire.tf_to_plain's dict): every key once, in this order, fixstr-encoded. An element in it is read by
# comparing the key runs as a whole (~5x fewer instructions than key by key); on any difference the
# element is read again by the general path above, so the samples are the same either way.
cdef const char* _K_HEAD = b"\x83\xa6header\x82\xa5stamp\x82\xa3sec"
cdef const char* _K_NSEC = b"\xa7nanosec"
cdef const char* _K_FRAME = b"\xa8frame_id"
cdef const char* _K_CHILD = b"\xaechild_frame_id"
cdef const char* _K_TRANS = b"\xa9transform\x82\xabtranslation\x83\xa1x"
cdef const char* _K_ROT = b"\xa8rotation\x84\xa1x"
cdef int64_t _canonical_hits = 0    # elements read by _stamped_canonical (tests prove the path is taken)


cdef inline bint _lit(Cur* c, const char* lit, Py_ssize_t n) noexcept nogil:
    """The next n bytes are lit: step over them."""
    if c.end - c.p < n or memcmp(c.p, lit, n) != 0:
        return False
    c.p += n
    return True


cdef inline bint _f(Cur* c, double* v) noexcept nogil:
    """A float64 (what zentf writes) inline; any other number through _float."""
    cdef uint64_t u
    if c.end - c.p >= 9 and c.p[0] == 0xcb:
        u = _be64(c.p + 1)
        memcpy(v, &u, 8)
        c.p += 9
        return True
    return _float(c, v)


cdef inline bint _key1(Cur* c, uint8_t name) noexcept nogil:
    """The fixstr key of one letter name (x, y, z, w)."""
    if c.end - c.p < 2 or c.p[0] != 0xa1 or c.p[1] != name:
        return False
    c.p += 2
    return True


cdef bint _stamped_canonical(Cur* c, Sample* s) noexcept nogil:
    """One TransformStamped in zentf's own layout into s; False (c.p anywhere) if it is laid out otherwise."""
    global _canonical_hits
    if not (_lit(c, _K_HEAD, 20) and _int(c, &s.sec) and _lit(c, _K_NSEC, 8) and _int(c, &s.nsec)
            and _lit(c, _K_FRAME, 9) and _str(c, &s.parent, &s.parent_len)
            and _lit(c, _K_CHILD, 15) and _str(c, &s.child, &s.child_len)
            and _lit(c, _K_TRANS, 26) and _f(c, &s.v[0]) and _key1(c, b'y') and _f(c, &s.v[1])
            and _key1(c, b'z') and _f(c, &s.v[2]) and _lit(c, _K_ROT, 12) and _f(c, &s.v[3])
            and _key1(c, b'y') and _f(c, &s.v[4]) and _key1(c, b'z') and _f(c, &s.v[5])
            and _key1(c, b'w') and _f(c, &s.v[6])):
        return False
    if not (0 <= s.sec < _MAX_SEC and 0 <= s.nsec < _NS):
        return False
    _canonical_hits += 1
    return True


cdef inline bint _element(Cur* c, Sample* s, bint canonical) noexcept nogil:
    """One TransformStamped: zentf's own layout first, else (or if it is not) the general path."""
    cdef const uint8_t* start = c.p
    if canonical and _stamped_canonical(c, s):
        return True
    c.p = start
    return _stamped(c, s)


def canonical_hits():
    """How many elements the canonical-layout path has read (tests)."""
    return _canonical_hits


cdef inline object _tuple(Sample* s):
    """The sample tuple; None if a frame name is not UTF-8."""
    parent = frame_name(s.parent, s.parent_len)
    child = frame_name(s.child, s.child_len)
    if parent is None or child is None:
        return None
    t = (parent, child, s.sec * _NS + s.nsec, s.v[0], s.v[1], s.v[2], s.v[3], s.v[4], s.v[5], s.v[6])
    PyObject_GC_UnTrack(t)  # str, int and floats only: it can hold no cycle (CPython's gc would untrack it too)
    return t


cdef int _emit(Sample* s, list out, Batch batch, int64_t* newest) except -1:
    """A decoded sample into the batch, or as a tuple into out; 0 if a frame name is not UTF-8."""
    if batch is not None:
        if not batch.push(s):
            return 0
    else:
        t = _tuple(s)
        if t is None:
            return 0
        out.append(t)
    if s.sec * _NS + s.nsec > newest[0]:
        newest[0] = s.sec * _NS + s.nsec
    return 1


def msgpack_tf(payload, bint canonical=True):
    """Samples of a well-formed zentf (msgpack) TFMessage payload; None if anything is doubtful.
    ``canonical=False`` reads every element key by key (tests compare the two paths)."""
    cdef int64_t newest
    return decode_msgpack(payload, &newest, None, canonical)


cdef Py_ssize_t walk(Walk* w, int fmt, object payload, bint canonical=True) except -2:
    """The samples of a TFMessage payload in fmt (WALK_*) into w.buf[0..n): n, -1 if anything is doubtful (a
    payload that is not bytes too); MemoryError if memory ran out. walk_done(w) after, however it ends."""
    w.buf = w.stack
    w.cap = sizeof(w.stack) // sizeof(Sample)
    w.owned = False
    if type(payload) is not bytes:
        return -1
    cdef const uint8_t* p = <const uint8_t*>PyBytes_AS_STRING(payload)
    cdef Py_ssize_t size = PyBytes_GET_SIZE(payload), n
    if fmt == WALK_MSGPACK:
        n = msgpack_walk(p, size, &w.buf, &w.cap, &w.owned, canonical)
    elif fmt == WALK_CDR:
        n = cdr_walk(p, size, &w.buf, &w.cap, &w.owned)
    else:
        n = ros1_walk(p, size, &w.buf, &w.cap, &w.owned)
    if n == -2:
        walk_done(w)
        raise MemoryError()
    return n


cdef void walk_done(Walk* w) noexcept nogil:
    """Free what walk malloc'd (once)."""
    if w.owned:
        free(w.buf)
        w.owned = False
        w.buf = w.stack


cdef object decode_msgpack(object payload, int64_t* newest, Batch batch, bint canonical=True):
    """msgpack_tf, also giving the newest stamp (-1 if none); with a batch, the samples go into it
    (True returned) instead of a list of tuples."""
    newest[0] = -1
    cdef Walk w
    cdef Py_ssize_t n = walk(&w, WALK_MSGPACK, payload, canonical)
    try:
        return _emit_all(w.buf, n, batch, newest)
    finally:
        walk_done(&w)


cdef inline object _emit_all(Sample* buf, Py_ssize_t n, Batch batch, int64_t* newest):
    """A walk's n samples as decode_* returns them: None if n says doubtful."""
    cdef Py_ssize_t i
    if n < 0:
        return None
    out = [] if batch is None else None
    for i in range(n):
        if not _emit(&buf[i], out, batch, newest):
            return None
    return True if batch is not None else out


cdef Py_ssize_t msgpack_walk(const uint8_t* p, Py_ssize_t size, Sample** buf, Py_ssize_t* cap, bint* owned,
                             bint canonical) noexcept nogil:
    """The samples of a zentf (msgpack) TFMessage into buf[0][0..count), names pointing into p: count, -1 if
    anything is doubtful, -2 if memory ran out. buf[0] holds cap[0] samples; a larger message gets a larger
    one (realloc'd if owned[0], else malloc'd and owned[0] set: the caller frees an owned buffer). Frame
    names are not checked for UTF-8 here (callers do, as frame_name interns them)."""
    if size > _MAX_PAYLOAD:
        return -1
    cdef Cur c
    c.p = p
    c.end = p + size
    cdef Py_ssize_t n, i, j, kn, count = -1, m
    cdef const uint8_t* k
    cdef void* q
    if not _container(&c, 0x80, 0xde, &n):
        return -1
    for i in range(n):  # top level: "transforms" once, other fields skipped
        if not _key(&c, &k, &kn):
            return -1
        if _is(k, kn, b"transforms", 10):
            if count >= 0 or not _container(&c, 0x90, 0xdc, &count):
                return -1
            if count > cap[0]:
                # an element takes 24 bytes at the least: a count beyond that is a lie, not an allocation
                if count > (c.end - c.p) // 24 + 1:
                    return -1
                m = max(count, 16)
                q = realloc(buf[0], m * sizeof(Sample)) if owned[0] else malloc(m * sizeof(Sample))
                if q == NULL:
                    return -2
                buf[0] = <Sample*>q
                cap[0] = m
                owned[0] = True
            for j in range(count):
                if not _element(&c, &buf[0][j], canonical):
                    return -1
        elif not _skip(&c, 0):
            return -1
    if count < 0 or c.p != c.end:
        return -1
    return count


# ---------------------------------------------------------------- CDR (XCDR1 little-endian)

def cdr_tf(payload):
    """Samples of a well-formed ROS 2 CDR TFMessage payload; None if anything is doubtful.

    Layout per element: int32 sec, uint32 nanosec, frame_id and child_frame_id (uint32 length with the
    NUL, bytes, NUL; padding to 4 after frame_id), padding to 8 (counted after the 4-byte encapsulation
    header), 7 float64. Strings must end in their NUL here; bytes after the last element are ignored,
    as zentf.ros.tf.tf_samples ignores them.
    """
    cdef int64_t newest
    return decode_cdr(payload, &newest, None)


cdef object decode_cdr(object payload, int64_t* newest, Batch batch):
    """cdr_tf, also giving the newest stamp (-1 if none); with a batch, as decode_msgpack."""
    newest[0] = -1
    cdef Walk w
    cdef Py_ssize_t n = walk(&w, WALK_CDR, payload)
    try:
        return _emit_all(w.buf, n, batch, newest)
    finally:
        walk_done(&w)


cdef inline bint _room(Py_ssize_t count, Sample** buf, Py_ssize_t* cap, bint* owned) noexcept nogil:
    """buf[0] holds at least count samples (count already bounded by the payload's size); False if memory ran out."""
    cdef Py_ssize_t m
    cdef void* q
    if count <= cap[0]:
        return True
    m = max(count, 16)
    q = realloc(buf[0], m * sizeof(Sample)) if owned[0] else malloc(m * sizeof(Sample))
    if q == NULL:
        return False
    buf[0] = <Sample*>q
    cap[0] = m
    owned[0] = True
    return True


cdef Py_ssize_t cdr_walk(const uint8_t* p, Py_ssize_t end, Sample** buf, Py_ssize_t* cap,
                         bint* owned) noexcept nogil:
    """The samples of a ROS 2 CDR TFMessage (XCDR1 little-endian) into buf[0][0..count), names pointing into
    p (without their NUL): count, -1 if anything is doubtful, -2 if memory ran out (buffers as msgpack_walk).

    Per element: int32 sec (>= 0), uint32 nanosec (< 1e9), frame_id and child_frame_id (uint32 length
    with the NUL, the bytes, the NUL; padding to 4 after frame_id), padding to 8 counted after the 4-byte
    encapsulation header, 7 float64. Every length is checked against the bytes left before it is used;
    bytes after the last element are ignored (as zentf.ros.tf.tf_samples ignores them). Names are not
    checked for UTF-8 here (callers do)."""
    if end > _MAX_PAYLOAD or not cdr_le(p, end):
        return -1
    cdef uint32_t n = _u32le(p + 4)
    if <uint64_t>n * 72 > <uint64_t>(end - 8):  # an element takes 72 bytes at the least
        return -1
    if not _room(n, buf, cap, owned):
        return -2
    cdef Py_ssize_t off = 8, ln, i
    cdef int32_t sec
    cdef uint32_t nsec, u32
    cdef Sample* s = buf[0]
    for i in range(n):
        if end - off < 12:
            return -1
        u32 = _u32le(p + off)
        memcpy(&sec, &u32, 4)
        nsec = _u32le(p + off + 4)
        ln = _u32le(p + off + 8)
        off += 12
        if sec < 0 or nsec >= _NS or ln < 1 or end - off < ln or p[off + ln - 1] != 0:
            return -1
        s.parent = p + off
        s.parent_len = ln - 1
        off = (off + ln + 3) & ~(<Py_ssize_t>3)
        if end - off < 4:
            return -1
        ln = _u32le(p + off)
        off += 4
        if ln < 1 or end - off < ln or p[off + ln - 1] != 0:
            return -1
        s.child = p + off
        s.child_len = ln - 1
        off += ln
        off += (4 - off) & 7
        if end - off < 56:
            return -1
        memcpy(s.v, p + off, 56)  # little-endian hosts only (setup.py builds for x86-64 and arm64)
        off += 56
        s.sec = sec
        s.nsec = nsec
        s += 1
    return n


# ---------------------------------------------------------------- ROS 1

def ros1_tf(payload):
    """Samples of a well-formed ROS 1 tf2_msgs/TFMessage payload; None if anything is doubtful (ros1_walk)."""
    cdef int64_t newest = -1
    cdef Walk w
    cdef Py_ssize_t n = walk(&w, WALK_ROS1, payload)
    try:
        return _emit_all(w.buf, n, None, &newest)
    finally:
        walk_done(&w)


cdef Py_ssize_t ros1_walk(const uint8_t* p, Py_ssize_t end, Sample** buf, Py_ssize_t* cap,
                          bint* owned) noexcept nogil:
    """The samples of a ROS 1 tf2_msgs/TFMessage into buf[0][0..count), as cdr_walk: count, -1, -2.

    Per element: uint32 seq, uint32 secs, uint32 nsecs (ROS 1 time is unsigned: sec and nsec are kept
    as they are, the stamp is sec * 1e9 + nsec), frame_id and child_frame_id (uint32 length, the bytes:
    no NUL, no padding), 7 float64. The message must end with its last element."""
    if end > _MAX_PAYLOAD or end < 4:
        return -1
    cdef uint32_t n = _u32le(p)
    if <uint64_t>n * 76 > <uint64_t>(end - 4):  # an element takes 76 bytes at the least
        return -1
    if not _room(n, buf, cap, owned):
        return -2
    cdef Py_ssize_t off = 4, ln, i
    cdef Sample* s = buf[0]
    for i in range(n):
        if end - off < 16:
            return -1
        s.sec = _u32le(p + off + 4)
        s.nsec = _u32le(p + off + 8)
        ln = _u32le(p + off + 12)
        off += 16
        if end - off < ln + 4:
            return -1
        s.parent = p + off
        s.parent_len = ln
        off += ln
        ln = _u32le(p + off)
        off += 4
        if end - off < ln + 56:
            return -1
        s.child = p + off
        s.child_len = ln
        off += ln
        memcpy(s.v, p + off, 56)
        off += 56
        s += 1
    if off != end:
        return -1
    return n
