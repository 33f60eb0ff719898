# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""Frame names from wire bytes: one interned str per name, shared by every compiled decoder.

Why: a stream of TFMessages repeats the same few names; turning their bytes into a str every time costs an
allocation and a UTF-8 decode per name. ``zentf.ros.tf``'s dict holds the names, bounded there (the Python decoders
use it too), and a direct-mapped memo in front makes a hit a hash and a memcmp, with no bytes object.
"""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from cpython.unicode cimport PyUnicode_DecodeUTF8
from libc.stdint cimport uint8_t, uint32_t
from libc.string cimport memcmp

from zentf.core.constants import DEFAULT_MAX_FRAME_ID_LENGTH
from zentf.ros.tf import _FRAMES as _NAMES
from zentf.ros.tf import _FRAMES_FORGET, _FRAMES_HELD, _ENTRY_BYTES, FRAME_CACHE_BYTES, FRAME_CACHE_SIZE

cdef dict _names = _NAMES
cdef list _held = _FRAMES_HELD  # estimated bytes in _names, shared with zentf.ros.tf.keep_frame_name
cdef Py_ssize_t _MAX_NAMES = FRAME_CACHE_SIZE
cdef Py_ssize_t _MAX_BYTES = FRAME_CACHE_BYTES
cdef Py_ssize_t _ENTRY = _ENTRY_BYTES
cdef Py_ssize_t _NAME_MAX_LEN = DEFAULT_MAX_FRAME_ID_LENGTH
cdef enum:
    SLOTS = 8192       # a fleet of 100 robots x 51 frames cycles through 5,100 names
    MEMO_MAX_LEN = 64  # longer names are not memoized: the memo holds at most SLOTS x 64 bytes of names
cdef list _slot_raw = [None] * SLOTS
cdef list _slot_name = [None] * SLOTS


cdef void _forget_memo() noexcept:
    """Empty the memo: every name it hands out must be the one _names holds (one str per name)."""
    cdef Py_ssize_t i
    for i in range(SLOTS):
        _slot_raw[i] = None
        _slot_name[i] = None


def forget_memo() -> None:
    """The memo's part of zentf.ros.tf.forget_frame_names (called when the names start over)."""
    _forget_memo()


_FRAMES_FORGET.append(forget_memo)


cdef object frame_name(const uint8_t* p, Py_ssize_t n):
    """UTF-8 bytes -> interned str; None if not valid UTF-8 (the caller's Python path names that)."""
    cdef uint32_t h = 2166136261u
    cdef Py_ssize_t i
    cdef object raw
    cdef Py_ssize_t cost
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
        # zentf.ros.tf.keep_frame_name's bounds (names and bytes), inline: a forged flood is all new names
        cost = 2 * n + _ENTRY
        if len(_names) >= _MAX_NAMES or <Py_ssize_t>_held[0] + cost > _MAX_BYTES:
            _names.clear()
            _held[0] = 0
            _forget_memo()
        _names[raw] = name
        _held[0] = <Py_ssize_t>_held[0] + cost
    if n <= MEMO_MAX_LEN:
        _slot_raw[slot] = raw
        _slot_name[slot] = name
    return name
