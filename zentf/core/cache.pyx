# cython: language_level=3, annotation_typing=False
"""tf2's per-frame caches, compiled: TimeCache (samples over time) and StaticCache (one sample, any time).

As in tf2 (cache.cpp, static_cache.cpp), BufferCore keeps one cache object per frame and asks it
for the sample at a time; the walk over the tree is in buffer_core.pyx, which calls these caches
through their C methods (``get_c``, ``parent_at_c``, ...) without touching Python objects.

Storage is a ring per frame, oldest first, searched by bisection, in one allocation: the float64
values (tx, ty, tz, qx, qy, qz, qw) of every slot, then the low 32 bits of each stamp's offset from
the frame's first stamp, at most 60 bytes a sample; the high bits once per run of samples sharing
them (~4.3 s of stamps; the first run in the object, a table only from the second on). A column that has held one value, bit for bit, since the frame's first sample (a fixed
joint's translation, a planar base's z, roll and pitch) is kept once, not per slot, until a sample
brings another value: then every slot gets the column (_widen). Answers are the same to the bit:
the constant value goes through the same arithmetic as a stored one would.
Large rings live in anonymous mappings of their own (mremap growth), small ones in malloc'd arrays
(docs/architecture.md, "How samples are stored", has the why and the numbers). The parent
id is kept once per frame while it never changes (tf2 stores it in every sample); a frame whose
parent does change gets a per-sample int32 column from then on. Callers hold BufferCore's lock.
"""
from libc.math cimport acos, cos, sin, sqrt
from libc.stdint cimport UINT32_MAX, int32_t, int64_t, uint32_t, uint64_t
from libc.stdlib cimport free, malloc, realloc
from libc.string cimport memcpy, memmove
from posix.mman cimport MAP_ANONYMOUS, MAP_FAILED, MAP_PRIVATE, PROT_READ, PROT_WRITE, mmap, munmap

from .constants import INSERT_OK, INSERT_OLD, INSERT_REPEATED
from .time import fmt_stamp

__all__ = ["CacheBase", "TimeCache", "StaticCache"]

cdef enum:
    _OK = 0
    _OLD = 1
    _REPEATED = 2

assert (INSERT_OK, INSERT_OLD, INSERT_REPEATED) == (_OK, _OLD, _REPEATED)


cdef class CacheBase:
    """What BufferCore asks of a frame's cache (tf2 TimeCacheInterface)."""

    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1:
        return _OK

    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept:
        return False

    cdef int32_t parent_at_c(self, int64_t t) noexcept:
        return 0

    cdef int32_t latest_parent_c(self) noexcept:
        return 0

    cdef int span_c(self, int64_t lo, int64_t hi, int32_t* parent, Py_ssize_t* first, Py_ssize_t* last,
                    int64_t* split) noexcept:
        """get_c's answer for every time of [lo, hi] (0 < lo <= hi) at once, for a batch of lookups:
        1 if there is data at each of them, from one parent (*parent; the samples read are first..last),
        0 if there is none at any, -1 if that changes at *split (lo < *split <= hi)."""
        return 0

    cdef object link_columns(self, Py_ssize_t first, Py_ssize_t last):
        """(stamps int64[k], values float64[k, 7]) of samples first..last (span_c's); stamps None if static."""
        return None

    cdef void clear_c(self) noexcept:
        pass

    # ---------------------------------------------------------------- Python face (tools, tests)

    def insert(self, int64_t stamp, int32_t parent, values) -> int:
        """Store one sample: INSERT_OK, INSERT_OLD (older than the cache keeps) or INSERT_REPEATED."""
        cdef double v[7]
        cdef int k
        if len(values) != 7:
            raise ValueError("a sample has 7 values: tx, ty, tz, qx, qy, qz, qw")
        for k in range(7):
            v[k] = values[k]
        return self.insert_c(stamp, parent, v)

    def get(self, int64_t t):
        """(parent, tx, ty, tz, qx, qy, qz, qw) at t, interpolated as tf2 does; None if not available."""
        cdef int32_t p = 0
        cdef double o[7]
        if not self.get_c(t, &p, o):
            return None
        return (p, o[0], o[1], o[2], o[3], o[4], o[5], o[6])

    def parent_at(self, int64_t t) -> int:
        """Parent id of the sample that applies at t, 0 if none (tf2 getParent)."""
        return self.parent_at_c(t)

    def clear(self) -> None:
        self.clear_c()


cdef enum:
    _MAP_MIN = 65536     # a ring whose values take this many bytes or more gets mappings of its own

cdef extern from * nogil:
    """
    #include <string.h>
    #include <sys/mman.h>
    #if defined(MREMAP_MAYMOVE) && !defined(ZENTF_NO_MREMAP)
    #define zentf_mremap(p, old, new_, flags) mremap((p), (old), (new_), (flags))
    #else
    /* no mremap (macOS, the BSDs; or ZENTF_NO_MREMAP to test this path): a new mapping and a copy */
    #ifndef MREMAP_MAYMOVE
    #define MREMAP_MAYMOVE 1
    #endif
    static void* zentf_mremap(void* p, size_t old, size_t new_, int flags) {
        void* q = mmap(NULL, new_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        (void)flags;
        if (q == MAP_FAILED)
            return MAP_FAILED;
        memcpy(q, p, old < new_ ? old : new_);
        munmap(p, old);
        return q;
    }
    #endif
    """
    int MREMAP_MAYMOVE               # Linux's mremap (Python.h defines _GNU_SOURCE), else the copy above
    void* zentf_mremap(void* p, size_t old, size_t new, int flags)

cdef extern from "<unistd.h>" nogil:
    long sysconf(int name)
    int _SC_PAGESIZE

cdef size_t _PAGE = <size_t>sysconf(_SC_PAGESIZE)


cdef inline size_t _pages(size_t nbytes) noexcept nogil:
    return (nbytes + _PAGE - 1) & ~(_PAGE - 1)


cdef void* _arr_resize(void* p, size_t old, size_t new, bint* mapped, bint want_map) noexcept nogil:
    """Resize an array of old bytes to new bytes, keeping its first min(old, new) bytes.

    p NULL allocates, new 0 frees (returns NULL). want_map: the array gets an anonymous mapping
    of its own (large rings), which mremap grows or shrinks by moving page-table entries (no
    copy, no hole left in the malloc heap), and whose untouched pages cost no memory; otherwise
    malloc/realloc, so ten thousand one-sample frames stay a few hundred bytes each. Returns
    NULL, p untouched, when no memory is to be had; a shrink never fails. mapped says where p
    lives, and is updated.
    """
    cdef void* q
    cdef size_t keep = old if old < new else new
    if new == 0:
        if p != NULL:
            if mapped[0]:
                munmap(p, _pages(old))
            else:
                free(p)
        mapped[0] = False
        return NULL
    if want_map:
        if p != NULL and mapped[0]:
            q = zentf_mremap(p, _pages(old), _pages(new), MREMAP_MAYMOVE)
            return NULL if q == MAP_FAILED else q
        q = mmap(NULL, _pages(new), PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0)
        if q != MAP_FAILED:
            if p != NULL:
                memcpy(q, p, keep)
                free(p)
            mapped[0] = True
            return q
        # no mapping to be had (the kernel bounds a process's map count): malloc serves
    if p != NULL and not mapped[0]:
        return realloc(p, new)
    q = malloc(new)
    if q == NULL:
        if p != NULL and new < old:  # a mapped array shrinking below _MAP_MIN: stay mapped
            q = zentf_mremap(p, _pages(old), _pages(new), MREMAP_MAYMOVE)
            return p if q == MAP_FAILED else q
        return NULL
    if p != NULL:
        memcpy(q, p, keep)
        munmap(p, _pages(old))
    mapped[0] = False
    return q


cdef inline bint _big(Py_ssize_t cap, size_t w) noexcept:
    """A ring of cap slots of w values is large: its arrays get mappings of their own."""
    return <size_t>cap * w * sizeof(double) >= _MAP_MIN


cdef inline size_t _ring_bytes(Py_ssize_t cap, size_t w) noexcept:
    """Bytes of a ring of cap slots of w values: the values, then the stamps' low words."""
    return <size_t>cap * (w * sizeof(double) + sizeof(uint32_t))


cdef inline Py_ssize_t _fit(Py_ssize_t cap, size_t w) noexcept:
    """cap, or more slots if the ring is mapped: as many as its whole pages hold."""
    if _big(cap, w):
        return <Py_ssize_t>(_pages(_ring_bytes(cap, w)) // (w * sizeof(double) + sizeof(uint32_t)))
    return cap


cdef inline Py_ssize_t _bisect32r(const uint32_t* a, Py_ssize_t lo, Py_ssize_t hi, uint32_t x) noexcept:
    """First index in [lo, hi) whose value is > x (bisect_right), hi if none."""
    cdef Py_ssize_t mid
    while lo < hi:
        mid = (lo + hi) >> 1
        if x < a[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo


cdef inline Py_ssize_t _bisect32(const uint32_t* a, Py_ssize_t lo, Py_ssize_t hi, uint32_t x) noexcept:
    """First index in [lo, hi) whose value is >= x (bisect_left), hi if none."""
    cdef Py_ssize_t mid
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


cdef class TimeCache(CacheBase):
    """Samples of one dynamic frame, oldest first (tf2 TimeCache)."""

    is_static = False

    def __cinit__(self, int64_t max_ns):
        self.max_ns = max_ns
        self._lo = NULL
        self._d = NULL
        self._par = NULL
        self._runs = &self._run0
        self._ip = NULL
        self._kc = NULL
        self._mm = 0
        self._cap = 0
        self._runs_cap = 1
        self._reset()

    def __dealloc__(self):
        self._release()

    cdef void _reset(self) noexcept:
        self._head = 0
        self._n = 0
        self._base = 0
        self._epoch = 0
        self._nruns = 0
        self._mm &= ~1
        self._par0 = 0
        self._cm = 0x7f                  # no sample yet: every column counts as constant until one differs
        self._nv = 0
        self._w = 1
        self.newest = -1
        self.oldest = -1
        if self._ip != NULL:
            self._ip.memo_t = -1
            self._ip.sp_t0 = 0
            self._ip.sp_t1 = 0  # empty interval: never matches

    cdef void _release(self) noexcept:
        """Give every array back (the ring, the parents, the runs, the interpolation state, the constants)."""
        cdef bint m
        cdef size_t cap = <size_t>self._cap
        m = (self._mm & 2) != 0
        _arr_resize(self._d, _ring_bytes(cap, self._w), 0, &m, False)
        m = (self._mm & 4) != 0
        _arr_resize(self._par, cap * sizeof(int32_t), 0, &m, False)
        if self._runs != &self._run0:
            free(self._runs)
        free(self._ip)
        free(self._kc)
        self._lo = NULL
        self._d = NULL
        self._par = NULL
        self._runs = &self._run0
        self._ip = NULL
        self._kc = NULL
        self._mm = 0
        self._cap = 0
        self._runs_cap = 1

    cdef void clear_c(self) noexcept:
        self._release()
        self._reset()

    def __len__(self) -> int:
        return self._n

    cdef inline Py_ssize_t _slot(self, Py_ssize_t i) noexcept:
        cdef Py_ssize_t j = self._head + i
        if j >= self._cap:
            j -= self._cap
        return j

    cdef inline int64_t _stamp(self, Py_ssize_t i) noexcept:
        """The full stamp of logical sample i: its run's high word, its own low word."""
        cdef int64_t v = self._base + i
        cdef _Run* runs = self._runs
        cdef Py_ssize_t a = 0, b = self._nruns, mid   # the last run starting at or before v
        while b - a > 1:
            mid = (a + b) >> 1
            if runs[mid].start <= v:
                a = mid
            else:
                b = mid
        return self._epoch + ((runs[a].hi << 32) | <int64_t>self._lo[self._slot(i)])

    cdef inline void _place(self, void* blk, Py_ssize_t cap, size_t w) noexcept:
        """The ring is blk, cap slots of w values: the values first, then the low words."""
        self._d = <double*>blk
        self._lo = <uint32_t*>(<double*>blk + <size_t>cap * w) if blk != NULL else NULL
        self._cap = cap

    cdef int _set_cap(self, Py_ssize_t cap) noexcept:
        """Resize the ring to cap slots (>= n, more if mapped pages hold more); -1 if no memory
        (then nothing changed). The values and the low words share one allocation, values first:
        growing moves the low words up after the resize, shrinking moves them down before it. A
        wrapped ring keeps its order: growing moves the shorter of its two parts, shrinking
        unrolls it first."""
        cdef Py_ssize_t old = self._cap, h, r, t, grow
        cdef size_t w = self._w
        cdef bint m1 = (self._mm & 2) != 0, m2 = (self._mm & 4) != 0
        cdef void* blk
        cdef void* par = NULL
        cdef bint big
        cap = _fit(cap, w)
        big = _big(cap, w)
        if cap == old:
            return 0
        if cap < old:
            if self._head + self._n > cap and self._unroll() < 0:
                return -1
            # the low words go down to where they sit in the smaller ring (slots past n hold nothing)
            memmove(self._d + <size_t>cap * w, self._lo, cap * sizeof(uint32_t))
            blk = _arr_resize(self._d, _ring_bytes(old, w), _ring_bytes(cap, w), &m1, big)
            if blk == NULL:              # a shrink does not fail; were it to, put the low words back
                memmove(self._lo, self._d + <size_t>cap * w, cap * sizeof(uint32_t))
                return -1
        else:
            blk = _arr_resize(self._d, _ring_bytes(old, w), _ring_bytes(cap, w), &m1, big)
            if blk == NULL:
                return -1
            if old:                      # the low words up to their new place, after cap values
                memmove(<double*>blk + <size_t>cap * w, <double*>blk + <size_t>old * w, old * sizeof(uint32_t))
        if self._par != NULL:
            par = _arr_resize(self._par, old * sizeof(int32_t), cap * sizeof(int32_t), &m2, big)
            if par == NULL:              # only growth fails: shrink the ring back
                memmove(<double*>blk + <size_t>old * w, <double*>blk + <size_t>cap * w, old * sizeof(uint32_t))
                blk = _arr_resize(blk, _ring_bytes(cap, w), _ring_bytes(old, w), &m1, m1)
                self._place(blk, old, w)
                self._mm = (self._mm & 5) | (m1 << 1)
                return -1
            self._par = <int32_t*>par
        self._place(blk, cap, w)
        self._mm = (self._mm & 1) | (m1 << 1) | (m2 << 2)
        h = self._head
        if cap > old and h + self._n > old:  # wrapped: [h, old) is the oldest part, [0, r) the newest
            r = h + self._n - old
            t = old - h
            grow = cap - old
            if r <= grow and r < t:          # the newest part fits right after the old end
                memcpy(&self._lo[old], self._lo, r * sizeof(uint32_t))
                memcpy(&self._d[w * old], self._d, r * w * sizeof(double))
                if self._par != NULL:
                    memcpy(&self._par[old], self._par, r * sizeof(int32_t))
            else:                            # the oldest part moves to the new end
                memmove(&self._lo[h + grow], &self._lo[h], t * sizeof(uint32_t))
                memmove(&self._d[w * (h + grow)], &self._d[w * h], t * w * sizeof(double))
                if self._par != NULL:
                    memmove(&self._par[h + grow], &self._par[h], t * sizeof(int32_t))
                self._head = h + grow
        return 0

    cdef int _unroll(self) noexcept:
        """Move the samples to slots 0..n-1, oldest first; -1 if no memory (nothing changed)."""
        cdef Py_ssize_t h = self._head, n = self._n, cap = self._cap, r, t
        cdef size_t w = self._w
        cdef char* tmp
        if h == 0:
            return 0
        if h + n <= cap:
            memmove(self._lo, &self._lo[h], n * sizeof(uint32_t))
            memmove(self._d, &self._d[w * h], n * w * sizeof(double))
            if self._par != NULL:
                memmove(self._par, &self._par[h], n * sizeof(int32_t))
            self._head = 0
            return 0
        r = h + n - cap                      # newest part, at [0, r)
        t = cap - h                          # oldest part, at [h, cap)
        tmp = <char*>malloc(r * w * sizeof(double))
        if tmp == NULL:
            return -1
        memcpy(tmp, self._lo, r * sizeof(uint32_t))
        memmove(self._lo, &self._lo[h], t * sizeof(uint32_t))
        memcpy(&self._lo[t], tmp, r * sizeof(uint32_t))
        memcpy(tmp, self._d, r * w * sizeof(double))
        memmove(self._d, &self._d[w * h], t * w * sizeof(double))
        memcpy(&self._d[w * t], tmp, r * w * sizeof(double))
        if self._par != NULL:
            memcpy(tmp, self._par, r * sizeof(int32_t))
            memmove(self._par, &self._par[h], t * sizeof(int32_t))
            memcpy(&self._par[t], tmp, r * sizeof(int32_t))
        free(tmp)
        self._head = 0
        return 0

    cdef int _own_parents(self) except -1:
        """Switch to a parent per sample (the frame's parent changed): every stored one is _par0."""
        cdef bint m = False
        cdef int32_t* par = <int32_t*>_arr_resize(NULL, 0, self._cap * sizeof(int32_t), &m, (self._mm & 2) != 0)
        cdef Py_ssize_t i
        if par == NULL:
            raise MemoryError()
        for i in range(self._cap):
            par[i] = self._par0
        self._par = par
        self._mm = (self._mm & ~4) | (m << 2)
        return 0

    cdef int _add_run(self, Py_ssize_t k, int64_t hi, int64_t start) noexcept:
        """Insert run (hi, start) at index k; -1 if no memory (nothing changed)."""
        cdef _Run* runs = self._runs
        cdef int32_t cap
        if self._nruns == self._runs_cap:    # a table of its own (the object's room holds one run)
            cap = self._runs_cap * 2
            if runs == &self._run0:
                runs = <_Run*>malloc(cap * sizeof(_Run))
                if runs != NULL:
                    runs[0] = self._run0
            else:
                runs = <_Run*>realloc(runs, cap * sizeof(_Run))
            if runs == NULL:
                return -1
            self._runs = runs
            self._runs_cap = cap
        memmove(&runs[k + 1], &runs[k], (self._nruns - k) * sizeof(_Run))
        runs[k].hi = hi
        runs[k].start = start
        self._nruns += 1
        return 0

    cdef inline int32_t _parent(self, Py_ssize_t j) noexcept:
        return self._par0 if self._par == NULL else self._par[j]

    cdef Py_ssize_t _grown(self) noexcept:
        """The capacity a full ring grows to.

        Steady (pruning): by 1/64, the rate went up a little. Filling up in malloc'd arrays: by
        1/8, little slack (a copy each time, by realloc). A frame whose rate says its cache will
        hold a large ring (cache time x samples per second) moves to mappings at once, and
        doubles there while it fills: untouched pages cost nothing, mremap copies nothing, and
        the malloc heap keeps no holes from its growth. Pruning then trims it to what it holds.
        """
        cdef Py_ssize_t n = self._n, cap = n + (n >> 4) + 4
        cdef size_t w = self._w
        cdef int64_t span
        if self._mm & 1:
            return n + (n >> 6) + 4
        if self._mm & 2:
            return 2 * n
        if n >= 8 and not _big(cap, w):
            span = self.newest - self.oldest
            if span > 0 and <double>self.max_ns / <double>span * <double>(n - 1) >= <double>(_MAP_MIN // (w * sizeof(double))):
                return _MAP_MIN // (w * sizeof(double)) + 1
        return cap

    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1:
        cdef int64_t newest = self.newest, hi, rel
        cdef Py_ssize_t i, j, k, lo, n = self._n
        cdef _Run* runs
        cdef unsigned char diff = 0, c, q, nv = self._nv, w
        cdef const uint64_t* vb = <const uint64_t*>v
        cdef const uint64_t* kb
        cdef double* slot
        cdef _Konst* kc = self._kc
        if n == 0:                       # every column constant so far: its value, once
            if kc == NULL:
                kc = <_Konst*>malloc(sizeof(_Konst))
                if kc == NULL:
                    raise MemoryError()
                self._kc = kc
            memcpy(kc.k, v, 7 * sizeof(double))
            for q in range(7):
                kc.vc[q] = q
        elif nv != 7:                    # a column held constant so far (bit for bit) changes: stored per slot
            kb = <const uint64_t*>kc.k
            for q in range(nv, 7):
                c = kc.vc[q]
                if vb[c] != kb[c]:
                    diff |= 1 << c
            if diff and self._widen(self._cm & ~diff) < 0:
                raise MemoryError()
        if n == self._cap and self._set_cap(self._grown()) < 0:
            raise MemoryError()
        nv = self._nv
        w = self._w
        if n == 0:
            self._par0 = parent
            self._epoch = stamp          # runs count 2**32 ns from the first sample
        elif self._par == NULL and parent != self._par0:
            self._own_parents()
        rel = stamp - self._epoch
        hi = rel >> 32
        if stamp > newest:
            if self._nruns == 0 or self._runs[self._nruns - 1].hi != hi:
                if self._add_run(self._nruns, hi, self._base + n) < 0:
                    raise MemoryError()
            j = self._slot(n)
            self._lo[j] = <uint32_t>rel
            slot = &self._d[w * j]
            if nv == 7:
                memcpy(slot, v, 7 * sizeof(double))
            else:
                self._pack(slot, v)
            if self._par != NULL:
                self._par[j] = parent
            self._n = n + 1
            self.newest = stamp
            if newest < 0:
                self.oldest = stamp
                return _OK
            newest = stamp
        else:
            if newest - stamp > self.max_ns:
                return _OLD
            lo = self._bound(stamp, False)
            if self._stamp(lo) == stamp:
                return _REPEATED
            runs = self._runs
            k = 0                            # the run of this stamp's high word, added if new
            while k < self._nruns and runs[k].hi < hi:
                k += 1
            if k == self._nruns or runs[k].hi != hi:
                if self._add_run(k, hi, self._base + lo) < 0:
                    raise MemoryError()
                runs = self._runs
            for i in range(k + 1, self._nruns):  # later runs start one sample later
                runs[i].start += 1
            k = n                            # shift lo..n-1 up one slot
            while k > lo:
                j = self._slot(k)
                i = self._slot(k - 1)
                self._lo[j] = self._lo[i]
                memcpy(&self._d[w * j], &self._d[w * i], w * sizeof(double))
                if self._par != NULL:
                    self._par[j] = self._par[i]
                k -= 1
            j = self._slot(lo)
            self._lo[j] = <uint32_t>rel
            self._pack(&self._d[w * j], v)
            if self._par != NULL:
                self._par[j] = parent
            self._n = n + 1
            if self._ip != NULL:
                self._ip.memo_t = -1
                self._ip.sp_t1 = self._ip.sp_t0  # an interval was split
            if lo == 0:
                self.oldest = stamp
        if self.oldest < newest - self.max_ns:
            self._prune()
        return _OK

    cdef void _prune(self) noexcept:
        """Drop samples older than newest - cache time, right after an insert (ROS 1 order; ROS 2
        prunes before inserting): pop while oldest + max < newest."""
        cdef Py_ssize_t lo = self._bound(self.newest - self.max_ns, False), n, d = 0
        cdef _Run* runs = self._runs
        self._head = self._slot(lo)
        self._n -= lo
        self._base += lo
        while d + 1 < self._nruns and runs[d + 1].start <= self._base:  # runs that fell out entirely
            d += 1
        if d:
            memmove(runs, &runs[d], (self._nruns - d) * sizeof(_Run))
            self._nruns -= d
        runs[0].start = self._base
        self.oldest = self._epoch + ((runs[0].hi << 32) | <int64_t>self._lo[self._head])
        if self._ip != NULL:
            self._ip.memo_t = -1     # the memoized time may have fallen out
        n = self._n
        if not self._mm & 1:  # the cache is full: from now on it holds about n samples, keep no slack
            self._mm |= 1
            if self._cap > n + 1:
                self._set_cap(n + 1)
        elif self._cap > _fit(n + (n >> 3) + 16, self._w):  # fewer samples than before (a slower rate): give room back
            self._set_cap(n + (n >> 6) + 4)

    cdef Py_ssize_t _bound(self, int64_t t, bint right) noexcept:
        """Logical index of the first sample after t (right: bisect_right) or at or after t
        (bisect_left); n if none. The run of t's high word, then its low words, bisected."""
        cdef int64_t hi
        cdef uint32_t x
        cdef _Run* runs = self._runs
        cdef Py_ssize_t a = 0, b = self._nruns, mid, first, last, ps, cap = self._cap, seg
        if self._n == 0 or t < self.oldest:
            return 0
        hi = (t - self._epoch) >> 32
        x = <uint32_t>(t - self._epoch)
        while a < b:                         # the first run whose high word is >= t's
            mid = (a + b) >> 1
            if runs[mid].hi < hi:
                a = mid + 1
            else:
                b = mid
        if a == self._nruns:
            return self._n
        first = runs[a].start - self._base
        if runs[a].hi > hi:
            return first
        last = runs[a + 1].start - self._base if a + 1 < self._nruns else self._n
        if right:                            # first low word > x is the first >= x + 1
            if x == UINT32_MAX:
                return last
            x += 1
        # the run's slots are at most two contiguous stretches of the ring: [ps, cap) then [0, ...)
        ps = self._head + first
        if ps >= cap:
            ps -= cap
        if ps + (last - first) <= cap:
            return first + _bisect32(self._lo, ps, ps + (last - first), x) - ps
        seg = cap - ps
        if self._lo[0] < x:
            return first + seg + _bisect32(self._lo, 0, last - first - seg, x)
        return first + _bisect32(self._lo, ps, cap, x) - ps

    cdef inline Py_ssize_t _floor(self, int64_t t, Py_ssize_t* run) noexcept:
        """Logical index of the newest sample at or before t, and its run (t inside the range).
        One run (less than 4.3 s stored): bisect_right of the low words over the ring's two stretches."""
        cdef uint32_t x
        cdef Py_ssize_t head, n, cap
        if self._nruns != 1:
            return self._floor_runs(t, run)
        x = <uint32_t>(t - self._epoch)
        head = self._head
        n = self._n
        cap = self._cap
        run[0] = 0
        if head + n > cap and x >= self._lo[0]:
            return cap - head + _bisect32r(self._lo, 0, head + n - cap, x) - 1
        return _bisect32r(self._lo, head, head + n if head + n <= cap else cap, x) - head - 1

    cdef Py_ssize_t _floor_runs(self, int64_t t, Py_ssize_t* run) noexcept:
        """_floor over several runs: the last run whose high word is <= t's, then bisect_right of
        its low words."""
        cdef int64_t hi = (t - self._epoch) >> 32
        cdef uint32_t x = <uint32_t>(t - self._epoch)
        cdef _Run* runs = self._runs
        cdef Py_ssize_t a = self._nruns - 1, b, mid, first, last, ps, cap = self._cap, seg, r
        if a < 8:                            # a few runs (a cache of some seconds): from the newest
            while runs[a].hi > hi:
                a -= 1
        else:
            a = 0
            b = self._nruns
            while b - a > 1:
                mid = (a + b) >> 1
                if runs[mid].hi <= hi:
                    a = mid
                else:
                    b = mid
        first = runs[a].start - self._base
        last = runs[a + 1].start - self._base if a + 1 < self._nruns else self._n
        if runs[a].hi < hi:                  # the whole run is older than t
            run[0] = a
            return last - 1
        ps = self._head + first              # the run's slots: [ps, cap) then [0, ...) if it wraps
        if ps >= cap:
            ps -= cap
        if ps + (last - first) <= cap:
            r = first + _bisect32r(self._lo, ps, ps + (last - first), x) - ps
        else:
            seg = cap - ps
            if x >= self._lo[0]:
                r = first + seg + _bisect32r(self._lo, 0, last - first - seg, x)
            else:
                r = first + _bisect32r(self._lo, ps, cap, x) - ps
        if r == first:                       # before the run's first sample: the previous run's last
            run[0] = a - 1
        else:
            run[0] = a
        return r - 1

    cdef inline void _unpack(self, Py_ssize_t j, double* out) noexcept:
        """The seven values of slot j: the constant columns from _kc, the others from the slot."""
        cdef const double* slot = &self._d[self._w * j]
        cdef const unsigned char* vc
        cdef unsigned char q, c, nv = self._nv, cm = self._cm
        if (cm & 0x78) == 0:                 # the rotation varies whole: the last 4 values of the slot
            memcpy(&out[3], &slot[nv - 4], 4 * sizeof(double))
            q = 0
            for c in range(3):
                if (cm >> c) & 1:
                    out[c] = self._kc.k[c]
                else:
                    out[c] = slot[q]
                    q += 1
            return
        vc = self._kc.vc
        for q in range(nv):
            out[vc[q]] = slot[q]
        for q in range(nv, 7):
            out[vc[q]] = self._kc.k[vc[q]]

    cdef inline void _pack(self, double* slot, const double* v) noexcept:
        """Store the varying values of sample v in slot (_unpack's inverse)."""
        cdef const unsigned char* vc
        cdef unsigned char q, c, nv = self._nv, cm = self._cm
        if (cm & 0x78) == 0:                 # the rotation varies whole: the last 4 values of the slot
            memcpy(&slot[nv - 4], &v[3], 4 * sizeof(double))
            q = 0
            for c in range(3):
                if not (cm >> c) & 1:
                    slot[q] = v[c]
                    q += 1
            return
        vc = self._kc.vc
        for q in range(nv):
            slot[q] = v[vc[q]]

    cdef inline void _unpack2(self, Py_ssize_t j0, Py_ssize_t j1, double* a, double* b) noexcept:
        """_unpack of slots j0 and j1 at once (an interpolation's two samples)."""
        cdef const double* s0 = &self._d[self._w * j0]
        cdef const double* s1 = &self._d[self._w * j1]
        cdef const unsigned char* vc = self._kc.vc   # some column is constant: _kc is there
        cdef unsigned char q, c, nv = self._nv
        for q in range(nv):
            c = vc[q]
            a[c] = s0[q]
            b[c] = s1[q]
        for q in range(nv, 7):
            c = vc[q]
            a[c] = b[c] = self._kc.k[c]

    cdef inline void _copy(self, Py_ssize_t i, int32_t* parent, double* out) noexcept:
        cdef Py_ssize_t j = self._slot(i)
        parent[0] = self._parent(j)
        if self._nv == 7:
            memcpy(out, &self._d[7 * j], 7 * sizeof(double))
        else:
            self._unpack(j, out)

    cdef int _widen(self, unsigned char cm) noexcept:
        """Keep only the columns of cm constant: every slot gets the others (a new ring, the
        stored samples' values and low words copied over); -1 if no memory (nothing changed).
        Once every column varies (cm 0), the constants' block is given back."""
        cdef unsigned char nv = 0, nk = 0, w, c
        cdef unsigned char vc[7]
        cdef double full[7]
        cdef bint m = False, m_old
        cdef double* d
        cdef double* slot
        cdef Py_ssize_t i, j, cap = self._cap
        for c in range(7):                   # the varying columns, then the constant ones
            if not (cm >> c) & 1:
                vc[nv] = c
                nv += 1
        for c in range(7):
            if (cm >> c) & 1:
                vc[nv + nk] = c
                nk += 1
        w = nv if nv else 1
        if cap:
            d = <double*>_arr_resize(NULL, 0, _ring_bytes(cap, w), &m, _big(cap, w))
            if d == NULL:
                return -1
            for i in range(self._n):
                j = self._slot(i)
                self._unpack(j, full)
                slot = &d[w * j]
                for c in range(nv):
                    slot[c] = full[vc[c]]
            memcpy(d + <size_t>cap * w, self._lo, cap * sizeof(uint32_t))
            m_old = (self._mm & 2) != 0
            _arr_resize(self._d, _ring_bytes(cap, self._w), 0, &m_old, False)
            self._place(d, cap, w)
            self._mm = (self._mm & ~2) | (m << 1)
        self._cm, self._nv, self._w = cm, nv, w
        if cm == 0:
            free(self._kc)
            self._kc = NULL
        else:
            memcpy(self._kc.vc, vc, 7)
        return 0

    cdef void _span(self, _Interp* ip, Py_ssize_t i, Py_ssize_t run) noexcept:
        """Constants to interpolate between samples i and i+1 exactly like tf2.

        tf2's slerp is (q0·sin((1-r)θ) + ±q1·sin(rθ)) / sin θ, with θ from the normalized dot
        product and the sign picking the short way; rewritten as q0·cos(rθ) + a·sin(rθ) with
        a = (±q1 - q0·cos θ) / sin θ (an identity, no normalization assumed), so each query costs
        one cos and one sin. Translation: p0 + r·(p1 - p0).
        """
        cdef Py_ssize_t j0 = self._slot(i), j1 = self._slot(i + 1)
        cdef const double* a                 # translations (3 values)
        cdef const double* b
        cdef const double* qa                # rotations (4 values)
        cdef const double* qb
        cdef double ua[7]
        cdef double ub[7]
        cdef double* sp = ip.sp
        cdef double x1, y1, z1, w1, dot, c, theta, inv
        cdef int k
        cdef unsigned char nv = self._nv, cm, q
        cdef _Run* runs = self._runs
        cdef int64_t e = self._epoch + (runs[run].hi << 32)
        if nv == 7:
            a = &self._d[7 * j0]
            b = &self._d[7 * j1]
            qa = a + 3
            qb = b + 3
        else:                                # constant columns apply their one value: the same arithmetic
            cm = self._cm
            a = &self._d[self._w * j0]
            b = &self._d[self._w * j1]
            if (cm & 0x78) != 0:             # a constant rotation column: merge all seven
                self._unpack2(j0, j1, ua, ub)
                a, b, qa, qb = ua, ub, &ua[3], &ub[3]
            else:                            # the rotation varies whole: the last 4 values of a slot
                qa = a + nv - 4
                qb = b + nv - 4
                q = 0
                for k in range(3):
                    if (cm >> k) & 1:
                        ua[k] = ub[k] = self._kc.k[k]
                    else:
                        ua[k] = a[q]
                        ub[k] = b[q]
                        q += 1
                a = ua
                b = ub
        ip.sp_t0 = e + <int64_t>self._lo[j0]
        if run + 1 < self._nruns and runs[run + 1].start == self._base + i + 1:
            e = self._epoch + (runs[run + 1].hi << 32)  # sample i + 1 begins the next run
        ip.sp_t1 = e + <int64_t>self._lo[j1]
        ip.sp_p = self._parent(j0)
        ip.sp_same = self._parent(j1) == ip.sp_p
        if not ip.sp_same:                   # different parents: the older sample applies
            memcpy(&sp[1], a, 3 * sizeof(double))
            memcpy(&sp[4], qa, 4 * sizeof(double))
            return
        sp[0] = 1.0 / <double>(ip.sp_t1 - ip.sp_t0)
        for k in range(3):
            sp[1 + k] = a[k]
            sp[4 + k] = b[k] - a[k]
        x1, y1, z1, w1 = qb[0], qb[1], qb[2], qb[3]
        dot = qa[0] * x1 + qa[1] * y1 + qa[2] * z1 + qa[3] * w1
        c = (-dot if dot < 0 else dot) / sqrt(
            (qa[0] * qa[0] + qa[1] * qa[1] + qa[2] * qa[2] + qa[3] * qa[3]) * (x1 * x1 + y1 * y1 + z1 * z1 + w1 * w1))
        theta = acos(1.0 if c > 1.0 else c)
        for k in range(4):
            sp[7 + k] = qa[k]
        if theta != 0.0:
            if dot < 0:
                x1, y1, z1, w1 = -x1, -y1, -z1, -w1
            if c > 1.0:
                c = 1.0
            inv = 1.0 / sqrt((1.0 - c) * (1.0 + c))  # 1 / sin θ; cos θ is c itself
            sp[11] = (x1 - qa[0] * c) * inv
            sp[12] = (y1 - qa[1] * c) * inv
            sp[13] = (z1 - qa[2] * c) * inv
            sp[14] = (w1 - qa[3] * c) * inv
        else:
            sp[11] = sp[12] = sp[13] = sp[14] = 0.0
        sp[15] = theta

    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept:
        cdef int64_t newest = self.newest
        cdef double r, c, s
        cdef double* sp
        cdef _Interp* ip = self._ip
        cdef _Interp local
        cdef Py_ssize_t i, run
        cdef int k
        if t == newest or t == 0:
            if newest < 0:
                return False
            self._copy(self._n - 1, parent, out)
            return True
        if ip != NULL and t == ip.memo_t:
            parent[0] = ip.memo_p
            memcpy(out, ip.memo, 7 * sizeof(double))
            return True
        if t > newest or t < self.oldest or self._n == 1:
            return False
        if t == self.oldest:
            self._copy(0, parent, out)
            return True
        if ip == NULL:  # the first interpolation asked of this frame: room for its state
            ip = <_Interp*>malloc(sizeof(_Interp))
            if ip == NULL:
                ip = &local          # no memory: interpolate all the same, remember nothing
            else:
                self._ip = ip
            ip.sp_t0 = 0
            ip.sp_t1 = 0
        if not (ip.sp_t0 <= t < ip.sp_t1):
            i = self._floor(t, &run)
            self._span(ip, i, run)
        sp = ip.sp
        parent[0] = ip.sp_p
        if not ip.sp_same:
            memcpy(out, &sp[1], 7 * sizeof(double))
            return True
        r = <double>(t - ip.sp_t0) * sp[0]
        out[0] = sp[1] + r * sp[4]
        out[1] = sp[2] + r * sp[5]
        out[2] = sp[3] + r * sp[6]
        if sp[15] != 0.0:
            c = cos(r * sp[15])
            s = sin(r * sp[15])
            for k in range(4):
                out[3 + k] = sp[7 + k] * c + sp[11 + k] * s
        else:
            for k in range(4):
                out[3 + k] = sp[7 + k]
        ip.memo_t = t
        ip.memo_p = parent[0]
        memcpy(ip.memo, out, 7 * sizeof(double))
        return True

    cdef int32_t parent_at_c(self, int64_t t) noexcept:
        cdef int64_t newest = self.newest
        cdef Py_ssize_t run
        if newest < 0:
            return 0
        if t == 0 or t == newest:
            return self._parent(self._slot(self._n - 1))
        if t > newest or t < self.oldest or self._n == 1:
            return 0
        return self._parent(self._slot(self._floor(t, &run)))

    cdef int32_t latest_parent_c(self) noexcept:
        if self._n == 0:
            return 0
        return self._parent(self._slot(self._n - 1))

    cdef int span_c(self, int64_t lo, int64_t hi, int32_t* parent, Py_ssize_t* first, Py_ssize_t* last,
                    int64_t* split) noexcept:
        cdef int64_t newest = self.newest, oldest = self.oldest
        cdef Py_ssize_t i0, i1, i, run
        cdef int32_t p
        if newest < 0 or hi < oldest or lo > newest:
            return 0
        if lo < oldest:
            split[0] = oldest
            return -1
        if hi > newest:
            split[0] = newest + 1
            return -1
        # (one sample: oldest == newest, so lo == hi == its stamp here)
        i0 = self._floor(lo, &run)
        i1 = self._floor(hi, &run)
        p = self._parent(self._slot(i0))
        if self._par != NULL:
            for i in range(i0 + 1, i1 + 1):
                if self._parent(self._slot(i)) != p:
                    split[0] = self._stamp(i)
                    return -1
        parent[0] = p
        first[0] = i0
        # the sample after the range ends the last interval, unless its parent differs: tf2 then
        # returns the older sample as is
        if self._stamp(i1) < hi and self._parent(self._slot(i1 + 1)) == p:
            last[0] = i1 + 1
        else:
            last[0] = i1
        return 1

    cdef object link_columns(self, Py_ssize_t first, Py_ssize_t last):
        st, _, d = self.columns(first, last + 1)
        return st, d

    # ---------------------------------------------------------------- Python face

    def error(self, int64_t t) -> str:
        """The text tf2's findClosest gives for a failed query at t (empty cache: no text)."""
        cdef Py_ssize_t n = self._n
        if n == 0:
            return ""
        newest, oldest = self.newest, self.oldest
        if n == 1:
            return (f"Lookup would require extrapolation at time {fmt_stamp(t)}, "
                    f"but only time {fmt_stamp(newest)} is in the buffer")
        if t > newest:
            return (f"Lookup would require extrapolation {fmt_stamp(t - newest)}s into the future.  "
                    f"Requested time {fmt_stamp(t)} but the latest data is at time {fmt_stamp(newest)}")
        return (f"Lookup would require extrapolation {fmt_stamp(oldest - t)}s into the past.  "
                f"Requested time {fmt_stamp(t)} but the earliest data is at time {fmt_stamp(oldest)}")

    def newest_stamp(self) -> int:
        return 0 if self._n == 0 else self.newest

    def oldest_stamp(self) -> int:
        return 0 if self._n == 0 else self.oldest

    def nbytes(self) -> int:
        """Bytes allocated for samples (capacity, not only the samples held) and their runs."""
        return (self._cap * (sizeof(uint32_t) + self._w * sizeof(double) + (sizeof(int32_t) if self._par != NULL else 0))
                + (self._runs_cap * sizeof(_Run) if self._runs != &self._run0 else 0)
                + (sizeof(_Konst) if self._kc != NULL else 0))

    @property
    def capacity(self) -> int:
        """Slots the ring has room for (samples held + slack)."""
        return self._cap

    @property
    def mapped(self) -> bool:
        """True while the values array lives in an anonymous mapping of its own (large rings)."""
        return (self._mm & 2) != 0

    def columns(self, Py_ssize_t start=0, Py_ssize_t stop=-1):
        """Copies of samples start..stop-1 (all by default), oldest first: (stamps int64[k], parents
        int32[k], values float64[k, 7])."""
        import numpy as np
        cdef Py_ssize_t n = self._n, i, j, k = 0
        cdef int64_t v
        if stop < 0 or stop > n:
            stop = n
        if start < 0:
            start = 0
        if start > stop:
            start = stop
        st = np.empty(stop - start, dtype=np.int64)
        par = np.empty(stop - start, dtype=np.int32)
        d = np.empty((stop - start, 7), dtype=np.float64)
        cdef int64_t[::1] stv = st
        cdef int32_t[::1] pv = par
        cdef double[:, ::1] dv = d
        for i in range(start, stop):
            j = self._slot(i)
            v = self._base + i
            while k + 1 < self._nruns and self._runs[k + 1].start <= v:
                k += 1
            stv[i - start] = self._epoch + ((self._runs[k].hi << 32) | <int64_t>self._lo[j])
            pv[i - start] = self._parent(j)
            self._unpack(j, &dv[i - start, 0])
        return st, par, d


cdef class StaticCache(CacheBase):
    """The single sample of a static frame, valid at every time (tf2 StaticCache)."""

    is_static = True

    def __cinit__(self):
        self.newest = 0   # statics report stamp 0 (ignored by the latest-common-time minimum)
        self._parent = 0
        self._v[:] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]

    def __len__(self) -> int:
        return 1

    cdef int insert_c(self, int64_t stamp, int32_t parent, const double* v) except -1:
        self._parent = parent
        memcpy(self._v, v, 7 * sizeof(double))
        return _OK

    cdef void clear_c(self) noexcept:
        """Static frames survive clear() in tf2."""

    cdef bint get_c(self, int64_t t, int32_t* parent, double* out) noexcept:
        parent[0] = self._parent
        memcpy(out, self._v, 7 * sizeof(double))
        return True

    cdef int32_t parent_at_c(self, int64_t t) noexcept:
        return self._parent

    cdef int32_t latest_parent_c(self) noexcept:
        return self._parent

    cdef int span_c(self, int64_t lo, int64_t hi, int32_t* parent, Py_ssize_t* first, Py_ssize_t* last,
                    int64_t* split) noexcept:
        parent[0] = self._parent
        first[0] = last[0] = 0
        return 1

    cdef object link_columns(self, Py_ssize_t first, Py_ssize_t last):
        import numpy as np
        d = np.empty((1, 7), dtype=np.float64)
        cdef double[:, ::1] dv = d
        memcpy(&dv[0, 0], self._v, 7 * sizeof(double))
        return None, d

    @property
    def sample(self) -> tuple:
        """(parent, tx, ty, tz, qx, qy, qz, qw)."""
        cdef double* v = self._v
        return (self._parent, v[0], v[1], v[2], v[3], v[4], v[5], v[6])

    def error(self, int64_t t) -> str:
        return ""

    def newest_stamp(self) -> int:
        return 0

    def oldest_stamp(self) -> int:
        return 0

    def nbytes(self) -> int:
        return 64
