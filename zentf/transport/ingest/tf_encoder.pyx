# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""TransformStamped -> TFMessage bytes, in C: the broadcasters' path (zentf's msgpack, ROS 2's CDR).

``ts_payload`` (a TFMessage of one transform), ``ts_item`` (one element of a longer list) and
``OneTransformSender`` (a TransformBroadcaster's send_transform, from the caller to Zenoh's ``put``)
write the map ``msgpack.packb(wire.tf_to_plain(ts))`` writes, with sec/nanosec as uint32 and every number
as float64 (valid msgpack that any decoder reads back to the same dict, ints as floats). Anything unusual
(a stamp that is not a zentf Time, sec beyond uint32, a non-number, a frame id that is not a str) gives
None and the caller takes zentf.transport.wire.codec's dict path, which packs it or says why not.
``cdr_ts_payload`` and ``OneTransformSenderCdr`` do the same for ROS 2's wire (zentf.ros.tf.encode_tf's bytes).
"""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from cpython.float cimport PyFloat_AsDouble
from cpython.object cimport PyObject
from cpython.tuple cimport PyTuple_GET_ITEM
from libc.stdint cimport int64_t, uint32_t, uint64_t
from libc.string cimport memcpy
from posix.time cimport CLOCK_REALTIME, clock_gettime, timespec

from msgpack import packb as _packb

from ...core.buffer_core cimport _slot_offset
from ...core.messages import Header as _Header, Quaternion as _Quaternion, Transform as _Transform
from ...core.messages import TransformStamped as _TransformStamped, Vector3 as _Vector3
from ...core.time cimport Time as _Time
from .msgpack_writer cimport _w_be32, _w_f64, _w_key, _w_put

__all__ = ["ts_item", "ts_payload", "OneTransformSender", "TF_KEY", "cdr_ts_payload", "OneTransformSenderCdr"]

cdef int64_t _NS = 1000000000

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


cdef bytes _TF_KEY = b"\x81\xaatransforms"  # a TFMessage's map and its one key
#: The first bytes of every TFMessage zentf writes (the listener's thread checks a payload starts so).
TF_KEY = _TF_KEY
cdef bytes _TF_HEAD = _TF_KEY + b"\x91"
cdef bytes _TS_HEAD = b"\x83\xa6header\x82\xa5stamp\x82\xa3sec\xce"
cdef bytes _TS_NSEC = b"\xa7nanosec\xce"
cdef bytes _TS_ROT = b"\xa8rotation\x84\xa1x\xcb"
cdef dict _ts_frames = {}       # (frame_id, child_frame_id) -> the bytes between the stamp and the values
cdef Py_ssize_t _TS_FRAMES_MAX = 10000
# the last (frame_id, child_frame_id, bytes) written: the same two str objects again (a broadcaster's
# usual call) skip the key tuple and the dict; one tuple, read once and replaced whole (threads)
cdef tuple _ts_last = (None, None, None)


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



cdef inline int64_t _stamp_ns(object stamp):
    """A Time's nanoseconds; -1 when they are negative or do not fit int64 (the encoders' templates refuse it)."""
    try:
        return (<_Time>stamp)._ns
    except (OverflowError, TypeError):
        return -1


cdef inline bint _ts_values(object tr, bint direct, double* v):
    """A Transform's translation and rotation into v[0:7]; False if any field is not a float."""
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
        return False
    return True


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
    ns = _stamp_ns(stamp)  # (C arithmetic below; beyond int64: the dict path)
    if ns < 0:
        return None
    sec = ns // _NS
    nsec = ns - sec * _NS
    if sec > 0xFFFFFFFF:
        return None
    if not _ts_values(tr, direct, v):
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


# ---------------------------------------------------------------- ROS 2's CDR, one transform

from ...ros.errors import CdrError as _CdrError
from ...ros.tf import frames_between as _cdr_middle  # frame_id, padding, child_frame_id, padding (bounded cache)

cdef tuple _cdr_last = (None, None, None)  # (frame_id, child_frame_id, the bytes between stamp and values)


cdef inline char* _w_le32(char* o, uint32_t v) noexcept:
    o[0] = <char>v
    o[1] = <char>(v >> 8)
    o[2] = <char>(v >> 16)
    o[3] = <char>(v >> 24)
    return o + 4


cdef inline char* _w_le64(char* o, double d) noexcept:
    cdef uint64_t u
    cdef int i
    memcpy(&u, &d, 8)
    for i in range(8):
        o[i] = <char>(u >> (8 * i))
    return o + 8


cdef object _cdr_write(object ts):
    """A CDR TFMessage (encapsulation header included) holding one TransformStamped, the bytes
    zentf.ros.tf.encode_tf writes; None if it does not fit the template (that encoder says why)."""
    global _cdr_last
    cdef double v[7]
    cdef int64_t ns, sec
    cdef Py_ssize_t size, i
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
    parent = _field(h, _W_FRAME, direct, "frame_id")
    child = _field(ts, _W_CHILD, direct, "child_frame_id")
    cdef tuple last = _cdr_last
    if <PyObject*>parent is PyTuple_GET_ITEM(last, 0) and <PyObject*>child is PyTuple_GET_ITEM(last, 1):
        mid = <object>PyTuple_GET_ITEM(last, 2)
    else:
        if type(parent) is not str or type(child) is not str:
            return None
        try:
            mid = _cdr_middle(parent, child, 12)
        except (_CdrError, UnicodeEncodeError):
            return None
        _cdr_last = (parent, child, mid)
    ns = _stamp_ns(stamp)
    if ns < 0:
        return None
    sec = ns // _NS
    if sec > 0x7FFFFFFF:  # int32 seconds
        return None
    if not _ts_values(tr, direct, v):
        return None
    size = 16 + PyBytes_GET_SIZE(<bytes>mid) + 56
    out = PyBytes_FromStringAndSize(NULL, size)
    o = PyBytes_AS_STRING(out)
    o = _w_le32(o, 0x00000100)  # 00 01 00 00: CDR little-endian
    o = _w_le32(o, 1)
    o = _w_le32(o, <uint32_t>sec)
    o = _w_le32(o, <uint32_t>(ns - sec * _NS))
    o = _w_put(o, <bytes>mid)
    for i in range(7):
        o = _w_le64(o, v[i])
    return out


def cdr_ts_payload(ts):
    """A CDR TFMessage payload holding one TransformStamped (send_transform's common case on ROS 2's
    wire); None if unusual."""
    return _cdr_write(ts)


cdef class OneTransformSenderCdr:
    """A TransformBroadcaster's ``send_transform`` on ROS 2's wire, compiled: one TransformStamped goes
    from the caller to Zenoh's ``put`` in this one call, with rmw_zenoh's attachment (the publisher's
    next sequence number from ``seq``, the source time, its 16-byte ``gid``) written in C; anything else
    goes to ``slow``, the Python method."""

    cdef object put
    cdef object seq
    cdef bytes gid
    cdef object slow

    def __init__(self, put, seq, bytes gid, slow):
        if len(gid) != 16:
            raise ValueError("a GID is 16 bytes")
        self.put = put
        self.seq = seq
        self.gid = gid
        self.slow = slow

    def __call__(self, transform):
        cdef timespec ts
        cdef int64_t n, now
        cdef char* o
        payload = _cdr_write(transform)
        if payload is None:
            return self.slow(transform)
        n = next(self.seq)
        clock_gettime(CLOCK_REALTIME, &ts)
        now = ts.tv_sec * 1_000_000_000 + ts.tv_nsec
        att = PyBytes_FromStringAndSize(NULL, 33)  # zenoh-ext serialized (int64, int64, uint8[16])
        o = PyBytes_AS_STRING(att)
        o = _w_le32(_w_le32(o, <uint32_t>n), <uint32_t>(<uint64_t>n >> 32))
        o = _w_le32(_w_le32(o, <uint32_t>now), <uint32_t>(<uint64_t>now >> 32))
        o[0] = 16
        memcpy(o + 1, PyBytes_AS_STRING(self.gid), 16)
        self.put(payload, attachment=att)
