# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""JointState -> zentf's msgpack bytes, in C: a joint_state_publisher's or a driver's hundred-hertz message.

``js_payload`` writes the bytes ``msgpack.packb(msg.to_dict())`` writes when every number is a float
(ints are written as float64), the name list packed once and reused while the next message's names are
equal; anything unusual gives None and zentf.transport.wire.codec's generic encoder decides.
"""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from cpython.float cimport PyFloat_AsDouble
from libc.stdint cimport int64_t, uint64_t

from msgpack import packb as _packb

from ...core.messages import JointState as _JointState
from ...core.time cimport Time as _Time
from .msgpack_writer cimport _w_array, _w_f64, _w_key, _w_put, _w_uint

__all__ = ["js_payload"]

cdef int64_t _NS = 1000000000

cdef bytes _JS_HEAD = b"\x85\xa6header\x82\xa5stamp\x82\xa3sec"
# the last names (a copy) and their packed bytes, the last frame_id and its: each pair one tuple, read
# once into locals and replaced whole (another thread may publish other names meanwhile)
cdef tuple _js_names = (None, None)
cdef tuple _js_frame = (None, None)


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

