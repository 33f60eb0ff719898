# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""robot_state_publisher's hot path compiled: one JointState's positions -> its TFMessage bytes in one call.

Why: at 100 Hz the publisher wakes every 10 ms with cold caches, and then each of the ~15 numpy calls
of the pure-Python path (``_Plan.payload``, ``JointTransforms.Subset.compute``, the finite check and
the throttle) costs 5-15 us instead of 1: ~230 us per message on a 100-joint chain (bench/urdf.py),
against ~10 us here. Same maths as ``JointTransforms.Subset.compute`` (zentf/urdf/kinematics.py) and
the same bytes as ``_Plan.payload``'s numpy path (zentf/tools/robot_state_publisher.py), which stays
the reference and the fallback without build_ext; tests/test_urdf_publishers.py compares the two.
"""
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize
from libc.math cimport cos, isfinite, sin
from libc.stdint cimport int64_t, uint32_t, uint64_t
from libc.string cimport memcpy

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


cdef class JointTfFiller:
    """One joint-name list's constants (a ``_Plan``): ``payload(position, sec, nsec)`` gives the TFMessage
    bytes (None when a value is not finite); ``fresh``/``mark`` are the publish_frequency throttle."""

    cdef bytes template
    cdef Py_ssize_t k, n_sel, n_known
    cdef Py_ssize_t[::1] sel, mimic_src, known, sec_at, nsec_at, val_at
    cdef double[::1] mimic_mult, mimic_off, half, values
    cdef double[:, ::1] t0, q0, q0a, slide
    cdef int64_t[::1] last

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
        cdef double v, h, c, s
        cdef double[::1] values = self.values
        for i in range(self.n_sel):
            values[i] = <double>position[self.sel[i]]
        for i in range(self.k - self.n_sel):
            values[self.n_sel + i] = (<double>position[self.mimic_src[i]]) * self.mimic_mult[i] + self.mimic_off[i]
        for i in range(self.k):
            if not isfinite(values[i]):
                return None
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
