# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""Compiled TFMessage decoders: the listener's hot path, payload bytes straight to samples.

``msgpack_tf`` (zentf wire) and ``cdr_tf`` (ROS 2 wire) turn a well-formed TFMessage payload into the
list of ``(parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw)`` tuples ``BufferCore.set_transforms_raw``
takes, without building any intermediate object. They are strict on purpose: anything doubtful (a bad
shape, a duplicate or missing field, a stamp out of range, a name that is not UTF-8, a truncated payload)
returns None, and the caller re-reads the payload with its pure-Python path, which finds, counts and
names each problem (zentf/transport/wire/codec.py ``ingest_tf``, zentf/ros/tf.py ``tf_samples``). So the compiled path
only ever gives the samples the Python path would give, never a message of its own.
"""
cimport cython
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from cpython.float cimport PyFloat_AsDouble
from cpython.list cimport PyList_GET_SIZE
from cpython.object cimport PyObject
from cpython.tuple cimport PyTuple_GET_ITEM
from cpython.unicode cimport PyUnicode_DecodeUTF8
from libc.stdint cimport int32_t, int64_t, uint8_t, uint32_t, uint64_t
from libc.stdlib cimport free, realloc
from libc.string cimport memcmp, memcpy
from posix.time cimport CLOCK_MONOTONIC, clock_gettime, timespec

cdef extern from *:
    """
    /* the kernel's tick-resolution monotonic clock (Linux: a memory read in the vDSO, ~1/6 of
       CLOCK_MONOTONIC's cost in a VM; perf: ~2.5 % of the listener thread in a flood); elsewhere the
       plain one. Good enough for the 0.1 s and 2 s windows it times here. */
    #ifdef CLOCK_MONOTONIC_COARSE
    #define ZENTF_MONO_COARSE CLOCK_MONOTONIC_COARSE
    #else
    #define ZENTF_MONO_COARSE CLOCK_MONOTONIC
    #endif
    """
    int CLOCK_MONO_COARSE "ZENTF_MONO_COARSE"


cdef inline int64_t _coarse_ns() noexcept nogil:
    """The coarse monotonic clock, in ns."""
    cdef timespec ts
    clock_gettime(CLOCK_MONO_COARSE, &ts)
    return ts.tv_sec * 1_000_000_000 + ts.tv_nsec

from ...core.buffer_core cimport BufferCore, _slot_offset
from .msgpack_reader cimport Cur, _be, _be64, _container, _float, _int, _is, _skip, _str, _take

cdef extern from *:
    """
    /* zenoh-python's getters and ZBytes.to_bytes called through their descriptors, found once: no
       attribute or method lookup by name per message (PyObject_GenericGetAttr, _PyObject_GetMethod) */
    static inline PyObject* zentf_descr_get(PyObject* d, PyObject* obj) {
        return Py_TYPE(d)->tp_descr_get(d, obj, (PyObject*)Py_TYPE(obj));
    }
    static inline PyObject* zentf_call1(PyObject* f, PyObject* a) {
        PyObject* args[1] = {a};
        return PyObject_Vectorcall(f, args, 1, NULL);
    }
    """
    object _descr_get "zentf_descr_get"(object d, object obj)
    object _call1 "zentf_call1"(object f, object a)

cdef object _SampleType = None, _get_payload = None, _get_attachment = None, _to_bytes = None


cdef int _zenoh_descriptors() except -1:
    """Find zenoh.Sample's payload and attachment getters and ZBytes.to_bytes (once; the tf thread and
    the handlers use them for zenoh.Sample objects, anything else is read by name)."""
    global _SampleType, _get_payload, _get_attachment, _to_bytes
    if _SampleType is not None:
        return 0
    import zenoh
    d = zenoh.Sample.__dict__
    _get_payload, _get_attachment = d["payload"], d["attachment"]
    _to_bytes = zenoh.ZBytes.__dict__["to_bytes"]
    _SampleType = zenoh.Sample
    return 0


cdef inline object _payload_of(object sample):
    """sample.payload.to_bytes()"""
    if type(sample) is _SampleType:
        return _call1(_to_bytes, _descr_get(_get_payload, sample))
    return sample.payload.to_bytes()


cdef inline object _attachment_of(object sample):
    """The attachment's bytes, None without one."""
    if type(sample) is _SampleType:
        att = _descr_get(_get_attachment, sample)
        return None if att is None else _call1(_to_bytes, att)
    att = sample.attachment
    return None if att is None else att.to_bytes()


__all__ = ["msgpack_tf", "cdr_tf", "TfIngest", "TfHandler", "serve", "ts_item", "ts_payload", "js_payload",
           "OneTransformSender",
           "MAX_PAYLOAD"]

from ...ros.tf import MAX_PAYLOAD  # larger payloads are not decoded here (the Python paths refuse them)
cdef Py_ssize_t _MAX_PAYLOAD = MAX_PAYLOAD
cdef int64_t _NS = 1000000000
cdef int64_t _MAX_SEC = 9223372036  # (2**63 - 1) // 1e9: stamps are int64 nanoseconds

cdef extern from "Python.h":
    void PyObject_GC_UnTrack(object)

# ---------------------------------------------------------------- frame names

#: Interned frame names, raw UTF-8 bytes -> str: zentf.ros.tf's cache, shared by every TFMessage decoder
#: (bounded at FRAME_CACHE_SIZE, started over when full, names longer than the buffer takes not kept).
from ...core.constants import DEFAULT_MAX_FRAME_ID_LENGTH
from ...ros.tf import FRAME_CACHE_SIZE
from ...ros.tf import _FRAMES as _NAMES
cdef dict _names = _NAMES
cdef Py_ssize_t _NAMES_MAX = FRAME_CACHE_SIZE
cdef Py_ssize_t _NAME_MAX_LEN = DEFAULT_MAX_FRAME_ID_LENGTH
# a direct-mapped memo in front of it, so a hit costs a hash and a memcmp (no bytes object)
cdef enum:
    SLOTS = 1024
cdef list _slot_raw = [None] * SLOTS
cdef list _slot_name = [None] * SLOTS


cdef object _name(const uint8_t* p, Py_ssize_t n):
    """UTF-8 bytes -> interned str; None if not valid UTF-8 (the Python path names that)."""
    cdef uint32_t h = 2166136261u
    cdef Py_ssize_t i
    cdef object raw
    for i in range(n):
        h = (h ^ p[i]) * 16777619u
    cdef Py_ssize_t slot = h & (SLOTS - 1)
    raw = _slot_raw[slot]
    if raw is not None and PyBytes_GET_SIZE(raw) == n and memcmp(PyBytes_AS_STRING(raw), p, n) == 0:
        return _slot_name[slot]
    raw = PyBytes_FromStringAndSize(<const char*>p, n)
    name = _names.get(raw)
    if name is None:
        try:
            name = PyUnicode_DecodeUTF8(<const char*>p, n, "strict")
        except UnicodeDecodeError:
            return None
        if n > _NAME_MAX_LEN:  # a forged huge name is not kept (the buffer refuses it anyway)
            return name
        if len(_names) >= _NAMES_MAX:
            _names.clear()
        _names[raw] = name
    _slot_raw[slot] = raw
    _slot_name[slot] = name
    return name


cdef inline double _f64le(const uint8_t* p) noexcept nogil:
    cdef uint64_t u = 0
    cdef int i
    for i in range(8):
        u |= (<uint64_t>p[i]) << (8 * i)
    cdef double d
    memcpy(&d, &u, 8)
    return d


cdef inline uint32_t _u32le(const uint8_t* p) noexcept nogil:
    return p[0] | (<uint32_t>p[1] << 8) | (<uint32_t>p[2] << 16) | (<uint32_t>p[3] << 24)


# ---------------------------------------------------------------- msgpack, out (the broadcasters' path)

from msgpack import packb as _packb

from ...core.messages import JointState as _JointState
from ...core.messages import Header as _Header, Quaternion as _Quaternion, Transform as _Transform
from ...core.messages import TransformStamped as _TransformStamped, Vector3 as _Vector3
from ...core.time cimport Time as _Time

# the messages' slot offsets (core.buffer_core._slot_offset): send_transform's writer reads the fields of
# exactly these types straight from their slots, without an attribute lookup each (one is ~20 ns warm,
# more after a sleep: ~1 us of a cold send_transform); any other object is read by attribute
cdef Py_ssize_t _W_HEADER = _slot_offset(_TransformStamped, "header")
cdef Py_ssize_t _W_CHILD = _slot_offset(_TransformStamped, "child_frame_id")
cdef Py_ssize_t _W_TF = _slot_offset(_TransformStamped, "transform")
cdef Py_ssize_t _W_STAMP = _slot_offset(_Header, "stamp")
cdef Py_ssize_t _W_FRAME = _slot_offset(_Header, "frame_id")
cdef Py_ssize_t _W_TRANS = _slot_offset(_Transform, "translation")
cdef Py_ssize_t _W_ROT = _slot_offset(_Transform, "rotation")
cdef Py_ssize_t _W_X = _slot_offset(_Vector3, "x")
cdef Py_ssize_t _W_Y = _slot_offset(_Vector3, "y")
cdef Py_ssize_t _W_Z = _slot_offset(_Vector3, "z")
cdef Py_ssize_t _W_QX = _slot_offset(_Quaternion, "x")
cdef Py_ssize_t _W_QY = _slot_offset(_Quaternion, "y")
cdef Py_ssize_t _W_QZ = _slot_offset(_Quaternion, "z")
cdef Py_ssize_t _W_QW = _slot_offset(_Quaternion, "w")
cdef bint _W_SLOTS = min(_W_HEADER, _W_CHILD, _W_TF, _W_STAMP, _W_FRAME, _W_TRANS, _W_ROT, _W_X, _W_Y,
                         _W_Z, _W_QX, _W_QY, _W_QZ, _W_QW) >= 0


cdef inline object _field(object o, Py_ssize_t offset, bint direct, str name):
    """o's field: from its slot when ``direct`` (o is of the exact message type), else by name. An
    unset slot reads as None (the caller then refuses the message: the Python path says why)."""
    cdef PyObject* v
    if direct:
        v = (<PyObject**>((<char*><PyObject*>o) + offset))[0]
        return <object>v if v != NULL else None
    return getattr(o, name)

# One TransformStamped is written straight as msgpack bytes: the map (field names and order)
# msgpack.packb(wire.tf_to_plain(ts)) writes, with sec/nanosec as uint32 and every number as float64
# (valid msgpack that any decoder reads back to the same dict, ints as floats). Anything unusual (a
# stamp that is not a zentf Time, sec beyond uint32, a non-number, a frame id that is not a str) gives
# None and the caller takes wire.py's dict path, which packs it or says why not.
cdef bytes _TF_KEY = b"\x81\xaatransforms"  # a TFMessage's map and its one key (also what enqueue checks)
cdef bytes _TF_HEAD = _TF_KEY + b"\x91"
cdef bytes _TS_HEAD = b"\x83\xa6header\x82\xa5stamp\x82\xa3sec\xce"
cdef bytes _TS_NSEC = b"\xa7nanosec\xce"
cdef bytes _TS_ROT = b"\xa8rotation\x84\xa1x\xcb"
cdef dict _ts_frames = {}       # (frame_id, child_frame_id) -> the bytes between the stamp and the values
cdef Py_ssize_t _TS_FRAMES_MAX = 10000
# the last (frame_id, child_frame_id, bytes) written: the same two str objects again (a broadcaster's
# usual call) skip the key tuple and the dict; one tuple, read once and replaced whole (threads)
cdef tuple _ts_last = (None, None, None)


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


cdef object _ts_frames_of(object parent, object child):
    """The bytes between a TransformStamped's stamp and its values, by (frame_id, child_frame_id),
    made once; None if a name is not a str or cannot be written."""
    key = (parent, child)
    frames = _ts_frames.get(key)
    if frames is None:
        if type(parent) is not str or type(child) is not str:
            return None
        try:
            frames = (b"\xa8frame_id" + _packb(parent) + b"\xaechild_frame_id" + _packb(child)
                      + b"\xa9transform\x82\xabtranslation\x83\xa1x\xcb")
        except Exception:  # e.g. a lone surrogate: the dict path says what is wrong
            return None
        if len(_ts_frames) >= _TS_FRAMES_MAX:
            _ts_frames.clear()
        _ts_frames[key] = frames
    return frames


cdef object _ts_write(object ts, bint whole):
    """The bytes of one TransformStamped (with the TFMessage head around it when ``whole``); None if
    it does not fit the template."""
    cdef double v[7]
    cdef int64_t ns, sec, nsec
    cdef Py_ssize_t size
    cdef char* o
    cdef bint direct = _W_SLOTS
    if type(ts) is not _TransformStamped:
        return None
    h = _field(ts, _W_HEADER, direct, "header")
    tr = _field(ts, _W_TF, direct, "transform")
    direct = direct and type(h) is _Header and type(tr) is _Transform
    stamp = _field(h, _W_STAMP, direct, "stamp")
    if type(stamp) is not _Time:
        return None
    global _ts_last
    parent = _field(h, _W_FRAME, direct, "frame_id")
    child = _field(ts, _W_CHILD, direct, "child_frame_id")
    cdef tuple last = _ts_last
    if <PyObject*>parent is PyTuple_GET_ITEM(last, 0) and <PyObject*>child is PyTuple_GET_ITEM(last, 1):
        frames = <object>PyTuple_GET_ITEM(last, 2)
    else:
        frames = _ts_frames_of(parent, child)
        if frames is None:
            return None
        _ts_last = (parent, child, frames)
    try:
        ns = (<_Time>stamp)._ns  # (C arithmetic below; beyond int64: the dict path)
    except (OverflowError, TypeError):
        return None
    if ns < 0:
        return None
    sec = ns // _NS
    nsec = ns - sec * _NS
    if sec > 0xFFFFFFFF:
        return None
    try:
        p = _field(tr, _W_TRANS, direct, "translation")
        q = _field(tr, _W_ROT, direct, "rotation")
        direct = direct and type(p) is _Vector3 and type(q) is _Quaternion
        v[0] = PyFloat_AsDouble(_field(p, _W_X, direct, "x"))
        v[1] = PyFloat_AsDouble(_field(p, _W_Y, direct, "y"))
        v[2] = PyFloat_AsDouble(_field(p, _W_Z, direct, "z"))
        v[3] = PyFloat_AsDouble(_field(q, _W_QX, direct, "x"))
        v[4] = PyFloat_AsDouble(_field(q, _W_QY, direct, "y"))
        v[5] = PyFloat_AsDouble(_field(q, _W_QZ, direct, "z"))
        v[6] = PyFloat_AsDouble(_field(q, _W_QW, direct, "w"))
    except Exception:
        return None
    size = ((PyBytes_GET_SIZE(_TF_HEAD) if whole else 0) + PyBytes_GET_SIZE(_TS_HEAD) + 4 + PyBytes_GET_SIZE(_TS_NSEC)
            + 4 + PyBytes_GET_SIZE(<bytes>frames) - 1 + PyBytes_GET_SIZE(_TS_ROT) - 1 + 7 * 9 + 5 * 2)
    out = PyBytes_FromStringAndSize(NULL, size)
    o = PyBytes_AS_STRING(out)
    if whole:
        o = _w_put(o, _TF_HEAD)
    o = _w_put(o, _TS_HEAD)
    o = _w_be32(o, <uint32_t>sec)
    o = _w_put(o, _TS_NSEC)
    o = _w_be32(o, <uint32_t>nsec)
    o = _w_put(o, <bytes>frames)
    o = _w_f64(o - 1, v[0])      # (the frames part and _TS_ROT end with the float's 0xcb marker)
    o = _w_f64(_w_key(o, b"y", 1), v[1])
    o = _w_f64(_w_key(o, b"z", 1), v[2])
    o = _w_put(o, _TS_ROT)
    o = _w_f64(o - 1, v[3])
    o = _w_f64(_w_key(o, b"y", 1), v[4])
    o = _w_f64(_w_key(o, b"z", 1), v[5])
    o = _w_f64(_w_key(o, b"w", 1), v[6])
    if o - PyBytes_AS_STRING(out) != size:
        raise AssertionError("ts_write: size")
    return out


def ts_item(ts):
    """One TransformStamped as msgpack bytes (an element of a TFMessage's list); None if unusual."""
    return _ts_write(ts, False)


def ts_payload(ts):
    """A TFMessage payload holding one TransformStamped (send_transform's common case); None if unusual."""
    return _ts_write(ts, True)


cdef class OneTransformSender:
    """A TransformBroadcaster's ``send_transform`` on zentf's wire, compiled: one TransformStamped goes
    from the caller to Zenoh's ``put`` in this one call (payload written in C, the constant attachment
    made once); anything else (a list, a dict, an unusual value) goes to ``slow``, the Python method."""

    cdef object put
    cdef object attachment
    cdef object slow

    def __init__(self, put, attachment, slow):
        self.put = put
        self.attachment = attachment
        self.slow = slow

    def __call__(self, transform):
        payload = _ts_write(transform, True)
        if payload is None:
            return self.slow(transform)
        self.put(payload, attachment=self.attachment)


# A JointState (a joint_state_publisher's or a driver's hundred-hertz message) is written the same way:
# the bytes msgpack.packb(msg.to_dict()) writes when every number is a float (ints are written as
# float64), the name list packed once and reused while the next message's names are equal.
cdef bytes _JS_HEAD = b"\x85\xa6header\x82\xa5stamp\x82\xa3sec"
# the last names (a copy) and their packed bytes, the last frame_id and its: each pair one tuple, read
# once into locals and replaced whole (another thread may publish other names meanwhile)
cdef tuple _js_names = (None, None)
cdef tuple _js_frame = (None, None)


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


cdef char* _w_floats(char* o, list seq, Py_ssize_t n) except? NULL:
    """The n numbers of seq as a msgpack array of float64; NULL (no exception) if seq changed since it
    was measured or a number does not fit a double: no Python code runs here, so nothing can change it
    meanwhile."""
    cdef Py_ssize_t i
    cdef double d
    if len(seq) != n:
        return NULL
    o = _w_array(o, n)
    for i in range(n):
        x = seq[i]
        if type(x) is float:
            d = <double>x
        elif type(x) is int:
            try:
                d = PyFloat_AsDouble(x)  # an int: no Python code (OverflowError beyond a double)
            except OverflowError:
                return NULL
        else:
            return NULL
        o = _w_f64(o, d)
    return o


def js_payload(msg):
    """A JointState as msgpack bytes (the generic encoder's map); None if anything is unusual (not a
    JointState, a stamp that is not a zentf Time, a non-float number, a name list that is not strs)."""
    global _js_names, _js_frame
    cdef Py_ssize_t size, npos, nvel, neff
    cdef char* o
    if type(msg) is not _JointState:
        return None
    h = msg.header
    stamp = h.stamp
    frame = h.frame_id
    names = msg.name
    pos, vel, eff = msg.position, msg.velocity, msg.effort
    if (type(stamp) is not _Time or type(frame) is not str or type(names) is not list or type(pos) is not list
            or type(vel) is not list or type(eff) is not list):  # (their numbers: checked as written)
        return None
    sec, nsec = divmod((<_Time>stamp)._ns, _NS)
    if not 0 <= sec < 2 ** 64:
        return None
    last, names_packed = _js_names
    if last is None or names != last:
        for x in <list>names:
            if type(x) is not str:
                return None
        try:
            names_packed = _packb(names)
        except Exception:  # a lone surrogate: the generic encoder says what is wrong
            return None
        _js_names = (list(names), names_packed)
    last, frame_packed = _js_frame
    if last is None or frame != last:
        try:
            frame_packed = _packb(frame)
        except Exception:
            return None
        _js_frame = (frame, frame_packed)
    npos, nvel, neff = len(pos), len(vel), len(eff)
    size = (PyBytes_GET_SIZE(_JS_HEAD) + 9 + 8 + 9 + 9 + PyBytes_GET_SIZE(<bytes>frame_packed)
            + 5 + PyBytes_GET_SIZE(<bytes>names_packed) + 9 + 9 + 7 + 3 * 5 + 9 * (npos + nvel + neff))
    buf = PyBytes_FromStringAndSize(NULL, size)  # an upper bound: cut to the length written below
    o = PyBytes_AS_STRING(buf)
    o = _w_put(o, _JS_HEAD)
    o = _w_uint(o, <uint64_t>sec)
    o = _w_uint(_w_key(o, b"nanosec", 7), <uint64_t>nsec)
    o = _w_put(_w_key(o, b"frame_id", 8), <bytes>frame_packed)
    o = _w_put(_w_key(o, b"name", 4), <bytes>names_packed)
    o = _w_floats(_w_key(o, b"position", 8), pos, npos)
    if o != NULL:
        o = _w_floats(_w_key(o, b"velocity", 8), vel, nvel)
    if o != NULL:
        o = _w_floats(_w_key(o, b"effort", 6), eff, neff)
    if o == NULL:  # changed by another thread meanwhile, or a huge int: the generic encoder decides
        return None
    return buf[:o - PyBytes_AS_STRING(buf)]


# ---------------------------------------------------------------- msgpack


cdef struct Sample:
    int64_t sec
    int64_t nsec
    const uint8_t* parent
    Py_ssize_t parent_len
    const uint8_t* child
    Py_ssize_t child_len
    double v[7]


cdef Py_ssize_t _KEEP_NAMES = 512  # names a batch keeps between messages (256 samples' worth)


cdef class _Batch:
    """Decoded samples kept in C (stamps, values) with their frame names, for BufferCore.ingest_one_c:
    no tuple and no float object per transform."""

    cdef list names             # parent, child per sample
    cdef int64_t* stamps
    cdef double* v              # 7 per sample
    cdef Py_ssize_t n, cap

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
        parent = _name(s.parent, s.parent_len)
        child = _name(s.child, s.child_len)
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
    """A field name: str keys only (a bin key matches in the raw per-element path, not in msgspec)."""
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


cdef int64_t _payload_messages = 0  # queued messages kept as payload bytes and handled (tests)


def payload_messages():
    """How many queued messages serve kept as their payload's bytes (TfHandler.enqueue) and handled (tests)."""
    return _payload_messages


def canonical_hits():
    """How many elements the canonical-layout path has read (tests)."""
    return _canonical_hits


cdef inline object _tuple(Sample* s):
    """The sample tuple; None if a frame name is not UTF-8."""
    parent = _name(s.parent, s.parent_len)
    child = _name(s.child, s.child_len)
    if parent is None or child is None:
        return None
    t = (parent, child, s.sec * _NS + s.nsec, s.v[0], s.v[1], s.v[2], s.v[3], s.v[4], s.v[5], s.v[6])
    PyObject_GC_UnTrack(t)  # str, int and floats only: it can hold no cycle (CPython's gc would untrack it too)
    return t


cdef int _emit(Sample* s, list out, _Batch batch, int64_t* newest) except -1:
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
    return _msgpack(payload, &newest, None, canonical)


cdef object _msgpack(object payload, int64_t* newest, _Batch batch, bint canonical=True):
    """msgpack_tf, also giving the newest stamp (-1 if none); with a batch, the samples go into it
    (True returned) instead of a list of tuples."""
    newest[0] = -1
    if type(payload) is not bytes:
        return None
    cdef Py_ssize_t size = PyBytes_GET_SIZE(payload)
    if size > _MAX_PAYLOAD:
        return None
    cdef Cur c
    c.p = <const uint8_t*>PyBytes_AS_STRING(payload)
    c.end = c.p + size
    cdef Py_ssize_t n, i, j, kn, count = -1
    cdef const uint8_t* k
    cdef Sample s
    out = [] if batch is None else None
    if not _container(&c, 0x80, 0xde, &n):
        return None
    for i in range(n):  # top level: "transforms" once, other fields skipped
        if not _key(&c, &k, &kn):
            return None
        if _is(k, kn, b"transforms", 10):
            if count >= 0 or not _container(&c, 0x90, 0xdc, &count):
                return None
            for j in range(count):
                if not _element(&c, &s, canonical):
                    return None
                if not _emit(&s, out, batch, newest):
                    return None
        elif not _skip(&c, 0):
            return None
    if count < 0 or c.p != c.end:
        return None
    return True if batch is not None else out


# ---------------------------------------------------------------- CDR (XCDR1 little-endian)

def cdr_tf(payload):
    """Samples of a well-formed ROS 2 CDR TFMessage payload; None if anything is doubtful.

    Layout per element: int32 sec, uint32 nanosec, frame_id and child_frame_id (uint32 length with the
    NUL, bytes, NUL; padding to 4 after frame_id), padding to 8 (counted after the 4-byte encapsulation
    header), 7 float64. Strings must end in their NUL here; bytes after the last element are ignored,
    as zentf.ros.tf.tf_samples ignores them.
    """
    cdef int64_t newest
    return _cdr(payload, &newest, None)


cdef inline bint _cdr_le(const uint8_t* p, Py_ssize_t n) noexcept nogil:
    """A little-endian XCDR1 encapsulation header (what ROS 2 sends) at the start of n bytes."""
    return n >= 8 and p[0] == 0 and p[1] == 1


cdef object _cdr(object payload, int64_t* newest, _Batch batch):
    """cdr_tf, also giving the newest stamp (-1 if none); with a batch, as _msgpack."""
    newest[0] = -1
    if type(payload) is not bytes:
        return None
    cdef Py_ssize_t end = PyBytes_GET_SIZE(payload)
    if end > _MAX_PAYLOAD or end < 8:
        return None
    cdef const uint8_t* p = <const uint8_t*>PyBytes_AS_STRING(payload)
    if not _cdr_le(p, end):
        return None
    cdef uint32_t n = _u32le(p + 4)
    if <uint64_t>n * 72 > <uint64_t>(end - 8):
        return None
    cdef Py_ssize_t off = 8, ln, i, j
    cdef int32_t sec
    cdef uint32_t nsec, u32
    cdef Sample s
    out = [] if batch is None else None
    for i in range(n):
        if end - off < 12:
            return None
        u32 = _u32le(p + off)
        memcpy(&sec, &u32, 4)
        nsec = _u32le(p + off + 4)
        ln = _u32le(p + off + 8)
        off += 12
        if sec < 0 or nsec >= _NS or ln < 1 or end - off < ln or p[off + ln - 1] != 0:
            return None
        s.parent = p + off
        s.parent_len = ln - 1
        off = (off + ln + 3) & ~(<Py_ssize_t>3)
        if end - off < 4:
            return None
        ln = _u32le(p + off)
        off += 4
        if ln < 1 or end - off < ln or p[off + ln - 1] != 0:
            return None
        s.child = p + off
        s.child_len = ln - 1
        off += ln
        off += (4 - off) & 7
        if end - off < 56:
            return None
        for j in range(7):
            s.v[j] = _f64le(p + off + 8 * j)
        off += 56
        s.sec = sec
        s.nsec = nsec
        if not _emit(&s, out, batch, newest):
            return None
    return True if batch is not None else out


# ---------------------------------------------------------------- the listener's ingest

#: How long (ns) a clock read may stand for "now" when a stamp is below its limit (TfIngest._too_new).
CLOCK_CACHE_NS = 100_000_000
cdef int64_t _CLOCK_CACHE = CLOCK_CACHE_NS
cdef tuple _NOTHING = (0, 0, 0, None)
cdef tuple _ONE = (1, 0, 0, None)       # the 1-transform message stored: no tuple built

cdef class TfIngest:
    """One topic's ingest for a TransformListener: ``ingest(payload, authority)`` -> (accepted, rejected,
    malformed, first problem), as the profile's ``ingest_tf`` returns it.

    A well-formed payload with nothing stamped beyond the clock's now + tolerance is decoded here and
    handed to ``core.set_transforms_raw`` in one call; anything else (a doubt, a stamp too far ahead,
    which the listener's future guard logs) goes to ``slow(payload, target, authority, is_static)``,
    the profile's Python path into ``target`` (the guard, or the buffer), so every problem is counted
    and named there. A buffer that raises gets ``insert`` (wire._insert: one by one).
    """

    cdef bint cdr
    cdef bint is_static
    cdef object slow
    cdef object insert
    cdef object target
    cdef object core
    cdef object now_ns
    cdef object tolerance_ns
    cdef _Batch batch           # a compiled BufferCore: samples go in from C (no tuples)
    cdef int64_t limit          # now + tolerance at the last clock read (-1: none)
    cdef int64_t limit_until    # CLOCK_MONOTONIC(_COARSE) ns until which limit may be used without a read

    def __init__(self, bint cdr, slow, insert, target, core, now_ns, tolerance_ns, bint is_static):
        self.batch = _Batch() if isinstance(core, BufferCore) else None
        self.cdr = cdr
        self.slow = slow
        self.insert = insert
        self.target = target
        self.core = core
        self.now_ns = now_ns            # the listener clock's now_ns, None: no future guard
        self.tolerance_ns = tolerance_ns
        self.is_static = is_static
        self.limit = -1
        self.limit_until = 0

    def reset_clock(self):
        """Forget the last clock read (the clock jumped back: the next stamp is compared afresh)."""
        self.limit = -1
        self.limit_until = 0

    def __call__(self, payload, authority):
        cdef int64_t newest
        if self.batch is not None:
            return self._direct(payload, authority)
        samples = _cdr(payload, &newest, None) if self.cdr else _msgpack(payload, &newest, None)
        if samples is None:
            return self.slow(payload, self.target, authority, self.is_static)
        if not samples:
            return 0, 0, 0, None
        if self._too_new(newest):
            return self.slow(payload, self.target, authority, self.is_static)
        try:
            accepted = self.core.set_transforms_raw(samples, authority, self.is_static)
        except Exception:  # the buffer must never take the listener down: one by one
            return self.insert(samples, self.core, authority, self.is_static, 0, None)
        return accepted, len(samples) - accepted, 0, None

    cdef bint _too_new(self, int64_t newest) except -1:
        """A stamp beyond the clock's now + tolerance: the listener's future guard must see it.

        The clock (a Python call, ~40% of a 1-transform message's decode and insert) is read again only
        when a stamp is beyond the last read's now + tolerance or that read is CLOCK_CACHE_NS old: a
        stamp is refused only against a fresh read, and one is let through against a read at most
        0.1 s old (by the kernel's coarse monotonic clock: a tick more at most; the listener forgets the
        read when its clock jumps back: reset_clock)."""
        cdef int64_t mono
        if self.now_ns is None:
            return False
        mono = _coarse_ns()
        if newest <= self.limit and mono < self.limit_until:
            return False
        now = self.now_ns()
        if not now:  # sim time before the first /clock: nothing to compare with
            self.limit = -1
            return False
        self.limit = now + self.tolerance_ns
        self.limit_until = mono + _CLOCK_CACHE
        return newest > self.limit

    cdef object _direct(self, object payload, object authority, bint fast_only=False):
        """__call__ for a compiled BufferCore: decoded into the batch, inserted sample by sample from C
        under one lock (BufferCore.ingest_*_c: set_transforms_raw's semantics, without tuples).
        ``fast_only``: None instead of taking the Python path (the caller looks at the encoding first)."""
        cdef int64_t newest
        cdef _Batch b = self.batch
        cdef BufferCore core = <BufferCore>self.core
        cdef Py_ssize_t i = 0, accepted = 0
        b.reset()
        ok = _cdr(payload, &newest, b) if self.cdr else _msgpack(payload, &newest, b)
        if ok is None:
            return None if fast_only else self.slow(payload, self.target, authority, self.is_static)
        if b.n == 0:
            return _NOTHING
        if self._too_new(newest):
            return None if fast_only else self.slow(payload, self.target, authority, self.is_static)
        names = b.names
        try:
            core.ingest_begin_c()
            try:
                while i < b.n:
                    accepted += core.ingest_one_c(names[2 * i], names[2 * i + 1], b.stamps[i], &b.v[7 * i],
                                                  authority, self.is_static)
                    i += 1
            finally:
                core.ingest_end_c(accepted)
        except Exception:  # the buffer must never take the listener down: the rest one by one
            rest = [(names[2 * k], names[2 * k + 1], b.stamps[k], b.v[7 * k], b.v[7 * k + 1], b.v[7 * k + 2],
                     b.v[7 * k + 3], b.v[7 * k + 4], b.v[7 * k + 5], b.v[7 * k + 6]) for k in range(i, b.n)]
            got, rejected, malformed, problem = self.insert(rest, self.core, authority, self.is_static, 0, None)
            return accepted + got, b.n - accepted - got, malformed, problem
        if accepted == 1 and b.n == 1:
            return _ONE
        return accepted, b.n - accepted, 0, None

    cdef object fast_c(self, object payload, object authority):
        """The compiled decode and insert alone (the listener's handler): None if the payload must take
        the Python path (``slow_c``) or the buffer is not a compiled BufferCore."""
        if self.batch is None:
            return None
        return self._direct(payload, authority, True)

    cdef object slow_c(self, object payload, object authority):
        """__call__ for what fast_c left: the Python path names the problems (or a plain buffer)."""
        if self.batch is None:
            return self(payload, authority)
        return self.slow(payload, self.target, authority, self.is_static)


# ---------------------------------------------------------------- the listener's thread, compiled

@cython.final
cdef class _Fifo:
    """One sender's waiting messages in serve: (sample, attachment bytes) or (payload bytes, authority)
    pairs (TfHandler.enqueue) in a list read from a head index, so a message costs two list appends
    and two reads, no tuple and no deque method call (~0.5k instructions a message in a flood).
    ``len()`` and ``popleft()`` for the listener's _shed."""
    cdef list items
    cdef Py_ssize_t head
    cdef object raw     # the second item of the message take() gave last (attachment bytes or authority)

    def __cinit__(self):
        self.items = []
        self.head = 0

    cdef inline Py_ssize_t size(self):
        return (PyList_GET_SIZE(self.items) - self.head) >> 1

    cdef inline int push(self, object sample, object raw) except -1:
        self.items.append(sample)
        self.items.append(raw)
        return 0

    cdef inline object take(self):
        """The oldest message (the queue must not be empty); its second item goes to self.raw."""
        cdef list items = self.items
        cdef Py_ssize_t h = self.head
        sample = items[h]
        self.raw = items[h + 1]
        items[h] = None
        items[h + 1] = None
        h += 2
        if h == PyList_GET_SIZE(items):       # empty now: start again at 0
            del items[:]
            h = 0
        elif h >= 2048 and 2 * h >= PyList_GET_SIZE(items):
            del items[:h]                     # half read: drop the read part (amortized O(1))
            h = 0
        self.head = h
        return sample

    def popleft(self):
        sample = self.take()
        return sample, self.raw

    def __len__(self):
        return self.size()


# messages of one backlogged sender handled in a row while the ring is empty (serve): the ring is looked
# at again within ~8 handles (~25 us), so a sender that shows up meanwhile waits no longer than that
cdef enum:
    _SOLO_RUN = 8


cdef class TfHandler:
    """One topic's ``handle(sample)`` for a TransformListener: encoding check, authority, decode and
    insert, counters; never raises (a payload that is not a TFMessage goes to the listener's
    ``_bad_message``, malformed elements to its ``_log_malformed``: the Python lines, rate-limited).

    The listener's ``_handler`` closure, compiled: the bytecode around the zenoh-python calls goes,
    and so do two of those calls for a well-formed message: the sample's encoding is read only when
    the payload is not a well-formed TFMessage (a payload the strict decoder reads as one is one,
    whatever its label; anything else gets the type check's line first, as before). Zenoh's callback
    (tf_static) calls it with the sample; the tf thread (``serve``) hands over the attachment's bytes
    it read already.
    """

    cdef object listener
    cdef object ingest
    cdef TfIngest cingest
    cdef object tf_encoding
    cdef object check_encoding      # None: the encoding is not looked at (ROS 2: the type is in the key)
    cdef object fixed_authority
    cdef object authority_of
    cdef dict authorities
    cdef object last_raw, last_authority  # the previous message's attachment and authority (one sender's run)
    cdef Py_ssize_t max_sender_key
    cdef public Py_ssize_t messages, transforms, rejected, malformed
    cdef public object topic        # the key expression the handler's subscriber was declared on (lines)

    def __init__(self, listener, ingest, tf_encoding, check_encoding, fixed_authority, authority_of,
                 dict authorities, Py_ssize_t max_sender_key):
        self.listener = listener
        self.ingest = ingest
        self.cingest = ingest if isinstance(ingest, TfIngest) else None
        self.tf_encoding = tf_encoding
        self.check_encoding = check_encoding
        self.fixed_authority = fixed_authority
        self.authority_of = authority_of
        self.authorities = authorities
        self.max_sender_key = max_sender_key
        self.messages = self.transforms = self.rejected = self.malformed = 0
        self.topic = "?"
        _zenoh_descriptors()

    def __call__(self, sample):
        """Zenoh's callback: True if something got into the buffer."""
        return self.handle(sample, None, False)

    cdef object _authority_of(self, object sample, object raw):
        """The authority of a sample whose attachment bytes are ``raw`` (the previous message's, the
        cache's, else the wire's reading of the attachment)."""
        authority = self.fixed_authority
        if authority is None:
            if raw is None:
                authority = None
            elif self.last_raw is not None and raw == self.last_raw:
                authority = self.last_authority
            else:
                authority = self.authorities.get(raw)
            if authority is None:
                authority = self.authority_of(sample.attachment, str(sample.key_expr))
                if raw is not None and len(raw) <= self.max_sender_key and len(self.authorities) < 1024:
                    self.authorities[raw] = authority
            if raw is not None:
                self.last_raw, self.last_authority = raw, authority
        return authority

    cdef int enqueue(self, _Fifo q, object sample, object raw) except -1:
        """Put a sample into serve's per-sender queue q: its payload's bytes with its authority when it
        starts as a TFMessage of this wire does (handle_payload), else the sample with its attachment's
        bytes (also if reading it fails: handle() then names that). A queued Zenoh sample pins the whole
        receive buffer it was cut from (Zenoh's, 64 kB) and ~300 bytes of Python object: in a
        1-transform flood, queueing samples made the listener's thread fault in and unmap memory for
        ~10 % of its time (perf; docs/architecture.md)."""
        cdef Py_ssize_t n
        cdef const char* p
        if raw is not None and self.cingest is not None:
            try:
                payload = _payload_of(sample)
                n = PyBytes_GET_SIZE(payload)
                p = PyBytes_AS_STRING(payload)
                if (_cdr_le(<const uint8_t*>p, n) if self.cingest.cdr
                        else n >= PyBytes_GET_SIZE(_TF_KEY)
                        and memcmp(p, PyBytes_AS_STRING(_TF_KEY), PyBytes_GET_SIZE(_TF_KEY)) == 0):
                    q.push(payload, self._authority_of(sample, raw))
                    return 0
            except Exception:
                pass
        q.push(sample, raw)
        return 0

    cdef bint handle(self, object sample, object raw, bint have_raw) except -1:
        """One message from its sample (``raw``: its attachment's bytes, when have_raw)."""
        try:
            if not have_raw and self.fixed_authority is None:
                raw = _attachment_of(sample)
            authority = self._authority_of(sample, raw)
            payload = _payload_of(sample)
        except Exception as e:
            self.listener._bad_message(sample, e)
            return False
        return self._ingest(sample, payload, authority)

    cdef bint handle_payload(self, object payload, object authority) except -1:
        """One queued message kept as its payload's bytes (``enqueue``): as handle, except on the
        Python path, where the sample is gone: its encoding is not looked at (the payload starts as a
        TFMessage does) and the lines name the topic's key."""
        global _payload_messages
        _payload_messages += 1
        return self._ingest(None, payload, authority)

    cdef bint _ingest(self, object sample, object payload, object authority) except -1:
        cdef Py_ssize_t accepted, rejected, malformed
        try:
            res = self.cingest.fast_c(payload, authority) if self.cingest is not None else None
            if res is None:
                # not a well-formed TFMessage (or a stamp too far ahead, or not a compiled buffer): the
                # encoding is looked at now, so a mislabelled payload gets the type check's one line
                if self.check_encoding is not None and sample is not None:
                    enc = sample.encoding
                    if enc != self.tf_encoding:  # cheap Rust-side compare for the common case
                        self.check_encoding(enc)
                if self.cingest is not None:
                    res = self.cingest.slow_c(payload, authority)
                else:
                    res = self.ingest(payload, authority)
            accepted, rejected, malformed, problem = <tuple>res
        except Exception as e:
            if sample is not None:
                self.listener._bad_message(sample, e)
            else:
                self.listener._bad_payload(self.topic, authority, e)
            return False
        # plain counters (statistics only; no lock on the hot path)
        self.messages += 1
        self.transforms += accepted
        self.rejected += rejected
        if malformed:
            self.malformed += malformed
            self.listener._log_malformed(str(sample.key_expr) if sample is not None else self.topic,
                                         authority, malformed, problem)
        return accepted > 0


cdef inline object _sender_key(object raw, object sender_of, Py_ssize_t max_sender_key):
    """The queue key of a message: its sender (the attachment's bytes, or what the wire makes of them)."""
    if raw is None:
        return b""
    key = sender_of(raw) if sender_of is not None else raw
    if len(key) > max_sender_key:
        key = key[:max_sender_key]
    return key


cdef inline bint _strike(dict strikes, object key, bint ok, Py_ssize_t suspect_after,
                         Py_ssize_t max_senders) except -1:
    """Note whether a sender's message put anything into the buffer; True once it is suspect."""
    cdef Py_ssize_t k
    if ok:
        if strikes and key in strikes:
            del strikes[key]
        return False
    k = strikes.get(key, 0) + 1
    strikes[key] = k
    if len(strikes) > 4 * max_senders:
        strikes.clear()
    return k >= suspect_after


def serve(listener, ring, TfHandler handle, sender_of, Py_ssize_t drain_batch, Py_ssize_t max_pending,
          Py_ssize_t suspect_after, Py_ssize_t suspect_queue, Py_ssize_t max_senders, bytes others,
          Py_ssize_t max_sender_key, Py_ssize_t release_after, release, log, double tail_window,
          release_later):
    """The tf thread of a TransformListener (its ``_serve``, compiled; the constants are zentf.transport.listener's):
    drain the ring into per-sender FIFOs, then handle one message per sender in turn (issue 10's
    fairness: a flood delays only its sender's data), shedding and logging as _serve did.

    A message that arrives alone (nothing waiting, the ring empty behind it) is handled at once, without
    a queue (no order changes); the first one after a wait on an empty ring is, without even looking
    at the ring behind it (a look costs ~0.5 us of the e2e latency; what came meanwhile is next). When
    one sender has a backlog, the ring was just found empty and no sender is striking (see _strike), up
    to _SOLO_RUN of its messages are handled in a row (the ring is looked at again ~25 us later). Not done:
    several messages of a lone backlogged sender per round while the ring still holds samples (measured:
    the legitimate edge's staleness p99 under bench/abuse.py's valid flood went from 35-42 to 92-93 ms with
    16 a round: the ring must be emptied into the per-sender queues as fast as it fills).

    Memory (zentf.transport.heap): when the ring runs empty after ``release_after`` messages, ``release()``; when it
    runs empty within ``tail_window`` s of that with fewer messages since (the tail of a flood the thread
    keeps up with, so it idles between messages), ``release_later()`` (the listener's timer releases
    once the ring has stayed quiet)."""
    recv, try_recv = ring.recv, ring.try_recv
    cdef dict queues = {}
    cdef dict strikes = {}          # messages in a row that put nothing into the buffer, per sender
    cdef dict shed
    cdef Py_ssize_t pending = 0, burst = 0, n, extra, j, r, run
    cdef _Fifo q
    cdef _Fifo last_q = None   # the queue the previous sample went to (a flood's sender)
    cdef object emptied, raw, last_key = None
    cdef int64_t last_release = 0, window = <int64_t>(tail_window * 1e9)
    cdef bint ok, suspect, woke
    while True:
        try:  # blocks in Zenoh (GIL released) when idle; fails once undeclared
            woke = False
            sample = try_recv()
            if sample is None and not pending:
                # the ring is empty: the end of a burst, then wait (idle)
                if burst >= release_after:
                    # a burst is over: glibc would keep the memory it freed (docs/protocol.md)
                    release()
                    log.debug("a burst of %d tf messages is over: freed memory released", burst)
                    burst = 0
                    last_release = _coarse_ns()
                elif 0 < burst and last_release and _coarse_ns() - last_release < window:
                    release_later()
                sample = recv()
                woke = True
        except Exception:
            return
        n = 0
        shed = None
        while sample is not None:
            raw = _attachment_of(sample)  # read once: handle() gets it too (the authority)
            key = _sender_key(raw, sender_of, max_sender_key)
            if not pending:
                if woke:  # the first sample after a wait on an empty ring: no look behind it (latency)
                    nxt = None
                else:
                    try:
                        nxt = try_recv()
                    except Exception:
                        return
                if nxt is None:  # alone: nothing to be fair to, no queue
                    _strike(strikes, key, handle.handle(sample, raw, True), suspect_after, max_senders)
                    n += 1
                    sample = None
                    break
            else:
                nxt = None
            if last_key is not None and key == last_key:  # a flood: the same sender as the last sample
                q = last_q
            else:
                q = queues.get(key)
                if q is None:
                    if len(queues) >= max_senders:
                        key = others
                        q = queues.get(key)
                    if q is None:
                        q = _Fifo()
                        queues[key] = q
                last_key, last_q = key, q
            suspect = strikes and strikes.get(key, 0) >= suspect_after  # (no lookup while nobody strikes)
            if suspect and q.size() >= suspect_queue:
                q.take()  # a suspect sender: its newest suspect_queue wait, the oldest goes
                if shed is None:
                    shed = {}
                shed[key] = shed.get(key, 0) + 1
                pending -= 1
            # a suspect's messages mostly go unread (shed above): not read now, which would slow the
            # draining of a flood (issue 10's staleness); it keeps at most suspect_queue samples
            if suspect:
                q.push(sample, raw)
            else:  # the payload's bytes if it looks like a TFMessage: the sample (and Zenoh's buffer) go now
                handle.enqueue(q, sample, raw)
            pending += 1
            if pending > max_pending:
                big = listener._shed(queues, q, key)
                if shed is None:
                    shed = {}
                shed[big] = shed.get(big, 0) + 1
                pending -= 1
            n += 1
            if nxt is not None:  # read ahead above: it is next, where the ring would have given it
                sample = nxt
                continue
            if n >= drain_batch:  # short rounds: a light sender is served often however big the flood
                break
            try:
                sample = try_recv()
            except Exception:
                return
        burst += n
        if shed:
            listener._log_shed(shed, queues)
        if not pending:
            continue
        # one sender waiting, the ring just found empty and no sender whose messages put nothing into
        # the buffer (a valid backlog being worked off, nobody else to be fair to): a few of its
        # messages in a row before looking at the ring again
        run = _SOLO_RUN if sample is None and len(queues) == 1 and not strikes else 1
        emptied = None
        for key, value in queues.items():  # nothing below adds or removes a queue while this runs
            q = <_Fifo>value
            for r in range(run):
                if q.size() == 0:
                    break
                sample = q.take()
                raw = q.raw
                pending -= 1
                if type(sample) is bytes:
                    ok = handle.handle_payload(sample, raw)
                else:
                    ok = handle.handle(sample, raw, True)
                if _strike(strikes, key, ok, suspect_after, max_senders) \
                        and q.size() > suspect_queue:  # queued before it turned suspect
                    extra = q.size() - suspect_queue
                    for j in range(extra):
                        q.take()
                    pending -= extra
                    listener._log_shed({key: extra}, queues)
            sample = None
            if q.size() == 0:
                if emptied is None:
                    emptied = []
                emptied.append(key)
        if emptied is not None:
            for key in emptied:
                del queues[key]
            last_key = last_q = None
