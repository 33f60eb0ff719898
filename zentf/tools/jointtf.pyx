# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""robot_state_publisher's hot path compiled: one JointState's positions -> its TFMessage bytes in one call.

Why: at 100 Hz the publisher wakes every 10 ms with cold caches, and then each of the ~15 numpy calls
of the pure-Python path (``_Plan.payload``, ``JointTransforms.Subset.compute``, the finite check and
the throttle) costs 5-15 us instead of 1: ~230 us per message on a 100-joint chain (bench/urdf.py),
against ~10 us here. Same maths as ``JointTransforms.Subset.compute`` (zentf/urdf/kinematics.py) and
the same bytes as ``_Plan.payload``'s numpy path (zentf/tools/robot_state_publisher.py), which stays
the reference and the fallback without build_ext; tests/test_urdf_publishers.py compares the two.
"""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from libc.math cimport cos, isfinite, sin
from libc.stdint cimport int64_t, uint8_t, uint32_t, uint64_t
from libc.stdlib cimport free, malloc
from libc.string cimport memcmp, memcpy

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


cdef inline uint64_t _rd(const uint8_t* p, int n) noexcept nogil:
    """n big-endian bytes at p as an unsigned integer."""
    cdef uint64_t v = 0
    cdef int i
    for i in range(n):
        v = (v << 8) | p[i]
    return v


cdef struct _Reader:
    const uint8_t* p
    const uint8_t* end


cdef inline Py_ssize_t _head(_Reader* r, uint8_t fix, uint8_t fixmask, uint8_t b16, uint8_t b32) noexcept nogil:
    """The length of a msgpack map/array/str header of one family (fix form, 16/32-bit forms); -1 if another."""
    cdef uint8_t b
    if r.p >= r.end:
        return -1
    b = r.p[0]
    if (b & fixmask) == fix:
        r.p += 1
        return b & (~fixmask & 0xff)
    if b == b16 and r.end - r.p >= 3:
        r.p += 3
        return <Py_ssize_t>_rd(r.p - 2, 2)
    if b == b32 and r.end - r.p >= 5:
        r.p += 5
        return <Py_ssize_t>_rd(r.p - 4, 4)
    return -1


cdef inline Py_ssize_t _str(_Reader* r) noexcept nogil:
    """Skip a msgpack str; its length, -1 if not a str (or cut short)."""
    cdef Py_ssize_t n
    if r.p < r.end and r.p[0] == 0xd9 and r.end - r.p >= 2:
        n = r.p[1]
        r.p += 2
    else:
        n = _head(r, 0xa0, 0xe0, 0xda, 0xdb)
    if n < 0 or r.end - r.p < n:
        return -1
    r.p += n
    return n


cdef inline bint _key(_Reader* r, const char* name, Py_ssize_t n) noexcept nogil:
    """True (and past it) when the next item is the str ``name``; the reader does not move otherwise."""
    cdef const uint8_t* p = r.p
    if _str(r) == n and memcmp(r.p - n, name, n) == 0:
        return True
    r.p = p
    return False


cdef inline bint _uint(_Reader* r, uint64_t* out) noexcept nogil:
    """A non-negative msgpack integer."""
    cdef uint8_t b
    cdef int n
    if r.p >= r.end:
        return False
    b = r.p[0]
    if b < 0x80:
        out[0] = b
        r.p += 1
        return True
    if 0xcc <= b <= 0xcf:
        n = 1 << (b - 0xcc)
        if r.end - r.p < 1 + n:
            return False
        out[0] = _rd(r.p + 1, n)
        r.p += 1 + n
        return True
    return False


cdef inline bint _float(_Reader* r, double* out) noexcept nogil:
    """A msgpack float64 or float32 (what encoders write for a float)."""
    cdef uint64_t u
    cdef uint32_t u32
    cdef float f
    if r.p >= r.end:
        return False
    if r.p[0] == 0xcb and r.end - r.p >= 9:
        u = _rd(r.p + 1, 8)
        memcpy(out, &u, 8)
        r.p += 9
        return True
    if r.p[0] == 0xca and r.end - r.p >= 5:
        u32 = <uint32_t>_rd(r.p + 1, 4)
        memcpy(&f, &u32, 4)
        out[0] = f
        r.p += 5
        return True
    return False


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
    cdef double* given       # positions read by read(), n_names of them

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

    def __dealloc__(self):
        free(self.given)

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
        cdef Py_ssize_t i
        cdef double[::1] values = self.values
        for i in range(self.n_sel):
            values[i] = <double>position[self.sel[i]]
        for i in range(self.k - self.n_sel):
            values[self.n_sel + i] = (<double>position[self.mimic_src[i]]) * self.mimic_mult[i] + self.mimic_off[i]
        for i in range(self.k):
            if not isfinite(values[i]):
                return None
        return self.build(sec, nsec)

    def learn(self, bytes payload, Py_ssize_t n_names):
        """Remember the name list's bytes of a JointState this plan was made for (msgpack, as sent), so
        that ``read`` knows the next ones without decoding a name."""
        cdef _Reader r
        cdef const uint8_t* at
        r.p = <const uint8_t*>PyBytes_AS_STRING(payload)
        r.end = r.p + PyBytes_GET_SIZE(payload)
        at = self._names_at(&r, n_names)
        if at == NULL:
            return
        if self.given == NULL or n_names != self.n_names:
            free(self.given)
            self.given = <double*>malloc(max(n_names, 1) * sizeof(double))
            if self.given == NULL:
                self.n_names = -1
                raise MemoryError()
        self.n_names = n_names
        self.names_raw = PyBytes_FromStringAndSize(<const char*>at, r.p - at)

    cdef const uint8_t* _names_at(self, _Reader* r, Py_ssize_t n_names) noexcept:
        """Move r past the map head and to the end of the "name" value; its start (NULL: not there)."""
        cdef Py_ssize_t m = _head(r, 0x80, 0xf0, 0xde, 0xdf), i, j
        cdef const uint8_t* start = NULL
        for i in range(m):
            if _key(r, "name", 4):
                start = r.p
                if _head(r, 0x90, 0xf0, 0xdc, 0xdd) != n_names:
                    return NULL
                for j in range(n_names):
                    if _str(r) < 0:
                        return NULL
                return start
            if _str(r) < 0 or not self._skip(r):
                return NULL
        return NULL

    cdef bint _skip(self, _Reader* r) noexcept:
        """Skip one value of a JointState field: a header map, a str, an array of numbers or of strs."""
        cdef Py_ssize_t n, i
        cdef uint64_t u
        cdef double d
        cdef const uint8_t* p = r.p
        n = _head(r, 0x80, 0xf0, 0xde, 0xdf)
        if n >= 0:  # a map (the header, its stamp): str keys, values a str, an int or a map
            for i in range(n):
                if _str(r) < 0:
                    return False
                if not (_uint(r, &u) or _str(r) >= 0 or self._skip(r)):
                    return False
            return True
        r.p = p
        n = _head(r, 0x90, 0xf0, 0xdc, 0xdd)
        if n >= 0:
            for i in range(n):
                if not (_float(r, &d) or _uint(r, &u) or _str(r) >= 0):
                    return False
            return True
        r.p = p
        return _str(r) >= 0

    def read(self, bytes payload):
        """A JointState payload whose names are the learned ones, as sent: (sec, nanosec) with its positions
        taken in, ready for ``build``; None when anything is unlike that (names, types, sizes, a value that
        is not finite): then the general decoder takes the message and says what is wrong."""
        cdef _Reader r
        cdef Py_ssize_t m, i, n, nr = PyBytes_GET_SIZE(self.names_raw)
        cdef uint64_t sec = (<uint64_t>1) << 40, nsec = (<uint64_t>1) << 40, u
        cdef bint got_names = False, got_pos = False, got_head = False
        cdef double* given = self.given
        cdef double[::1] values = self.values
        cdef const uint8_t* p
        if nr == 0 or given == NULL:
            return None
        r.p = <const uint8_t*>PyBytes_AS_STRING(payload)
        r.end = r.p + PyBytes_GET_SIZE(payload)
        m = _head(&r, 0x80, 0xf0, 0xde, 0xdf)
        if m < 3:
            return None
        for i in range(m):
            if _key(&r, "name", 4):
                if got_names or r.end - r.p < nr or memcmp(r.p, PyBytes_AS_STRING(self.names_raw), nr) != 0:
                    return None
                r.p += nr
                got_names = True
            elif _key(&r, "position", 8):
                if got_pos or _head(&r, 0x90, 0xf0, 0xdc, 0xdd) != self.n_names:
                    return None
                for n in range(self.n_names):
                    if not _float(&r, &given[n]):
                        if not _uint(&r, &u):  # an integral position, as a dict-built message may hold
                            return None
                        given[n] = <double>u
                got_pos = True
            elif _key(&r, "header", 6):
                if got_head or _head(&r, 0x80, 0xf0, 0xde, 0xdf) != 2:
                    return None
                for n in range(2):
                    if _key(&r, "stamp", 5):
                        if _head(&r, 0x80, 0xf0, 0xde, 0xdf) != 2:
                            return None
                        if not (_key(&r, "sec", 3) and _uint(&r, &sec) and _key(&r, "nanosec", 7)
                                and _uint(&r, &nsec)):
                            return None
                    elif not (_key(&r, "frame_id", 8) and _str(&r) >= 0):
                        return None
                got_head = True
            elif _key(&r, "velocity", 8) or _key(&r, "effort", 6):
                p = r.p
                if _head(&r, 0x90, 0xf0, 0xdc, 0xdd) < 0:
                    return None
                r.p = p
                if not self._skip(&r):
                    return None
            else:
                return None
        if not (got_names and got_pos and got_head) or r.p != r.end or sec >= ((<uint64_t>1) << 32) \
                or nsec >= 1_000_000_000:
            return None
        for i in range(self.n_sel):
            values[i] = given[self.sel[i]]
        for i in range(self.k - self.n_sel):
            values[self.n_sel + i] = given[self.mimic_src[i]] * self.mimic_mult[i] + self.mimic_off[i]
        for i in range(self.k):
            if not isfinite(values[i]):
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
