# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""robot_state_publisher's hot path compiled: one JointState's positions -> its TFMessage bytes in one call.

Why: at 100 Hz the publisher wakes every 10 ms with cold caches, where each numpy call costs several
times its warm price; the fifteen or so a message would need (selection, kinematics, the finite check,
the throttle, the bytes) would cost far more than this one call (docs/performance.md). Same maths as
``JointTransforms.Subset.compute`` (zentf/urdf/kinematics.py); tests/test_urdf_publishers.py compares
the published transforms with the model's forward kinematics.
"""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from libc.math cimport cos, isfinite, sin
from libc.stdint cimport int64_t, uint8_t, uint32_t, uint64_t
from libc.stdlib cimport free, realloc
from libc.string cimport memcmp, memcpy

from ..transport.ingest.msgpack_reader cimport Cur, _container, _float, _int, _is, _skip, _str

__all__ = ["JointTfFiller"]


cdef inline void _be32(char* p, uint32_t v) noexcept nogil:
    p[0] = <char>(v >> 24)
    p[1] = <char>(v >> 16)
    p[2] = <char>(v >> 8)
    p[3] = <char>v


cdef inline void _be64(char* p, double d) noexcept nogil:
    cdef uint64_t u
    memcpy(&u, &d, 8)
    cdef int i
    for i in range(8):
        p[i] = <char>(u >> (56 - 8 * i))


cdef inline bint _key(Cur* c, const char* name, Py_ssize_t n) noexcept nogil:
    """True (and past it) when the next item is the str ``name``; the cursor does not move otherwise."""
    cdef const uint8_t* start = c.p
    cdef const uint8_t* k
    cdef Py_ssize_t m
    if _str(c, &k, &m) and _is(k, m, name, n):
        return True
    c.p = start
    return False


cdef const uint8_t* _names_at(Cur* c, Py_ssize_t n_names) noexcept nogil:
    """Move c past a JointState map's head to the end of its "name" value (n_names strs); that value's
    start, NULL if it is not there or not so."""
    cdef Py_ssize_t m, i, j, n, ln
    cdef const uint8_t* start
    cdef const uint8_t* s
    if not _container(c, 0x80, 0xde, &m):
        return NULL
    for i in range(m):
        if _key(c, "name", 4):
            start = c.p
            if not _container(c, 0x90, 0xdc, &n) or n != n_names:
                return NULL
            for j in range(n):
                if not _str(c, &s, &ln):
                    return NULL
            return start
        if not (_str(c, &s, &ln) and _skip(c, 0)):
            return NULL
    return NULL


cdef class JointTfFiller:
    """One joint-name list's constants (a ``_Plan``): ``payload(position, sec, nsec)`` gives the TFMessage
    bytes (None when a value is not finite); ``fresh``/``mark`` are the publish_frequency throttle."""

    cdef bytes template
    cdef Py_ssize_t k, n_sel, n_known
    cdef Py_ssize_t[::1] sel, mimic_src, known, sec_at, nsec_at, val_at
    cdef double[::1] mimic_mult, mimic_off, half, values
    cdef double[:, ::1] t0, q0, q0a, slide
    cdef int64_t[::1] last
    cdef Py_ssize_t n_names
    cdef bytes names_raw     # the msgpack bytes of the name list last seen with this plan (b"": none yet)
    cdef double* given       # a message's positions by index (read: all n_names; payload: the ones used)
    cdef Py_ssize_t given_cap

    def __init__(self, bytes template, Py_ssize_t[::1] sel, Py_ssize_t[::1] mimic_src, double[::1] mimic_mult,
                 double[::1] mimic_off, Py_ssize_t[::1] known, int64_t[::1] last, double[:, ::1] t0,
                 double[:, ::1] q0, double[:, ::1] q0a, double[::1] half, double[:, ::1] slide,
                 Py_ssize_t[::1] sec_at, Py_ssize_t[::1] nsec_at, Py_ssize_t[::1] val_at):
        self.template = template
        self.sel, self.mimic_src, self.mimic_mult, self.mimic_off = sel, mimic_src, mimic_mult, mimic_off
        self.known, self.last = known, last
        self.t0, self.q0, self.q0a, self.half, self.slide = t0, q0, q0a, half, slide
        self.sec_at, self.nsec_at, self.val_at = sec_at, nsec_at, val_at
        self.n_sel = sel.shape[0]
        self.n_known = known.shape[0]
        self.k = self.n_sel + mimic_src.shape[0]
        if not (t0.shape[0] == q0.shape[0] == q0a.shape[0] == half.shape[0] == slide.shape[0] == self.k
                == sec_at.shape[0] == nsec_at.shape[0] == val_at.shape[0]) or t0.shape[1] != 3 \
                or q0.shape[1] != 4 or q0a.shape[1] != 4 or slide.shape[1] != 3:
            raise ValueError("JointTfFiller: inconsistent shapes")
        cdef Py_ssize_t i, n = len(template)
        for i in range(self.k):
            if not (0 <= sec_at[i] <= n - 4 and 0 <= nsec_at[i] <= n - 4 and 0 <= val_at[i] <= n - 84):
                raise ValueError("JointTfFiller: a hole outside the template")
        self.values = memoryview(bytearray(8 * max(self.k, 1))).cast("d")
        self.n_names = -1
        self.names_raw = b""
        self.given = NULL
        self.given_cap = 0

    def __dealloc__(self):
        free(self.given)

    cdef int _room(self, Py_ssize_t n) except -1:
        """``given`` holds at least n positions."""
        cdef double* p
        if n > self.given_cap:
            p = <double*>realloc(self.given, n * sizeof(double))
            if p == NULL:
                raise MemoryError()
            self.given, self.given_cap = p, n
        return 0

    cdef bint _values(self) noexcept:
        """The joint values from ``given`` (selected, then mimics from their masters); False if one, or the
        translation it makes, is not finite."""
        cdef Py_ssize_t i
        cdef double* given = self.given
        cdef double[::1] values = self.values
        for i in range(self.n_sel):
            values[i] = given[self.sel[i]]
        for i in range(self.k - self.n_sel):
            values[self.n_sel + i] = given[self.mimic_src[i]] * self.mimic_mult[i] + self.mimic_off[i]
        for i in range(self.k):  # the value, and the translation it makes (a prismatic joint can overflow)
            if not (isfinite(values[i]) and isfinite(self.t0[i, 0] + self.slide[i, 0] * values[i])
                    and isfinite(self.t0[i, 1] + self.slide[i, 1] * values[i])
                    and isfinite(self.t0[i, 2] + self.slide[i, 2] * values[i])):
                return False
        return True

    def fresh(self, int64_t stamp, int64_t interval):
        """True when some joint of the list was last published at least ``interval`` before ``stamp``."""
        cdef Py_ssize_t i
        cdef int64_t low
        if self.n_known == 0:
            return True
        low = self.last[self.known[0]]
        for i in range(1, self.n_known):
            if self.last[self.known[i]] < low:
                low = self.last[self.known[i]]
        return stamp >= low + interval

    def mark(self, int64_t stamp):
        """Record ``stamp`` as the last publish of every joint of the list."""
        cdef Py_ssize_t i
        for i in range(self.n_known):
            self.last[self.known[i]] = stamp

    def payload(self, position, uint32_t sec, uint32_t nsec):
        """The TFMessage bytes at these positions and stamp; None when a value is not finite."""
        cdef Py_ssize_t i, j
        self._room(len(position))
        for i in range(self.n_sel):  # only the positions the plan uses are taken (as floats)
            j = self.sel[i]
            self.given[j] = <double>position[j]
        for i in range(self.k - self.n_sel):
            j = self.mimic_src[i]
            self.given[j] = <double>position[j]
        if not self._values():
            return None
        return self.build(sec, nsec)

    def learn(self, bytes payload, Py_ssize_t n_names):
        """Remember the name list's bytes of a JointState this plan was made for (msgpack, as sent), so
        that ``read`` knows the next ones without decoding a name."""
        cdef Cur c
        cdef const uint8_t* at
        c.p = <const uint8_t*>PyBytes_AS_STRING(payload)
        c.end = c.p + PyBytes_GET_SIZE(payload)
        at = _names_at(&c, n_names)
        if at == NULL:
            return
        self._room(n_names)
        self.n_names = n_names
        self.names_raw = PyBytes_FromStringAndSize(<const char*>at, c.p - at)

    def read(self, bytes payload):
        """A JointState payload whose names are the learned ones, as sent: (sec, nanosec) with its positions
        taken in, ready for ``build``; None when anything is unlike that (names, types, sizes, a value that
        is not finite): then the general decoder takes the message and says what is wrong."""
        cdef Cur c
        cdef Py_ssize_t m, i, n, k, nr = PyBytes_GET_SIZE(self.names_raw)
        cdef int64_t sec = -1, nsec = -1
        cdef double v
        cdef bint got_names = False, got_pos = False, got_head = False
        cdef double* given = self.given
        cdef const uint8_t* s
        if nr == 0 or given == NULL:
            return None
        c.p = <const uint8_t*>PyBytes_AS_STRING(payload)
        c.end = c.p + PyBytes_GET_SIZE(payload)
        if not _container(&c, 0x80, 0xde, &m) or m < 3:
            return None
        for i in range(m):
            if _key(&c, "name", 4):
                if got_names or c.end - c.p < nr or memcmp(c.p, PyBytes_AS_STRING(self.names_raw), nr) != 0:
                    return None
                c.p += nr
                got_names = True
            elif _key(&c, "position", 8):
                if got_pos or not _container(&c, 0x90, 0xdc, &n) or n != self.n_names:
                    return None
                for k in range(n):
                    if not _float(&c, &given[k]):  # a float, or an integer as the general decoder takes it
                        return None
                got_pos = True
            elif _key(&c, "header", 6):
                if got_head or not _container(&c, 0x80, 0xde, &n) or n != 2:
                    return None
                for k in range(2):
                    if _key(&c, "stamp", 5):
                        if not (_container(&c, 0x80, 0xde, &n) and n == 2 and _key(&c, "sec", 3)
                                and _int(&c, &sec) and _key(&c, "nanosec", 7) and _int(&c, &nsec)):
                            return None
                    elif not (_key(&c, "frame_id", 8) and _str(&c, &s, &n)):
                        return None
                got_head = True
            elif _key(&c, "velocity", 8) or _key(&c, "effort", 6):  # numbers, not read
                if not _container(&c, 0x90, 0xdc, &n):
                    return None
                for k in range(n):
                    if not _float(&c, &v):
                        return None
            else:
                return None
        if not (got_names and got_pos and got_head) or c.p != c.end or not (0 <= sec < (<int64_t>1 << 32)) \
                or not (0 <= nsec < 1_000_000_000):
            return None
        if not self._values():
            return None
        return (sec, nsec)

    def build(self, uint32_t sec, uint32_t nsec):
        """The TFMessage bytes of the values last taken in (``payload`` or ``read``) at this stamp."""
        cdef Py_ssize_t i
        cdef double v, h, c, s
        cdef double[::1] values = self.values
        cdef bytes out = PyBytes_FromStringAndSize(PyBytes_AS_STRING(self.template), len(self.template))
        cdef char* buf = PyBytes_AS_STRING(out)
        cdef char* p
        for i in range(self.k):
            v = values[i]
            h = v * self.half[i]
            c = cos(h)
            s = sin(h)
            _be32(buf + self.sec_at[i], sec)
            _be32(buf + self.nsec_at[i], nsec)
            p = buf + self.val_at[i]
            # translation x, y, z then rotation x, y, z, w (offsets as _Plan._VALUE_OFFSETS)
            _be64(p, self.t0[i, 0] + self.slide[i, 0] * v)
            _be64(p + 11, self.t0[i, 1] + self.slide[i, 1] * v)
            _be64(p + 22, self.t0[i, 2] + self.slide[i, 2] * v)
            _be64(p + 43, self.q0[i, 0] * c + self.q0a[i, 0] * s)
            _be64(p + 54, self.q0[i, 1] * c + self.q0a[i, 1] * s)
            _be64(p + 65, self.q0[i, 2] * c + self.q0a[i, 2] * s)
            _be64(p + 76, self.q0[i, 3] * c + self.q0a[i, 3] * s)
        return out
