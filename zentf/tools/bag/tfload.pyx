# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""Compiled bag ingest: the records of a chunk, piece by piece, straight into a BufferCore.

Why: loading a recording's tf sample by sample in Python costs a bytes object, a row tuple and ten
float/int objects per transform (~3 us); here a chunk's records are walked in C, each TFMessage is
decoded in place (ROS 2 CDR, ROS 1 serialization, zentf's msgpack) and its transforms go to ``BufferCore.ingest_one_c``
with no Python object but the interned frame names. Chunks arrive in pieces of bounded size (the
caller decompresses them so: a bomb never sits in memory whole); a record cut by a piece boundary is
carried over, a record too large to be a transform message is skipped without being kept.

Strict on purpose, as the listener's decoders are: anything doubtful in a message (a bad length, a
string without its NUL, a stamp out of range, a name that is not UTF-8, an unknown definition) hands
the whole message to ``fallback(channel, payload)``, the Python path that decodes it as the
uncompiled loader did, so the compiled path only ever stores what that path would store.
"""
cimport cython
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize, PyBytes_GET_SIZE
from cpython.exc cimport PyErr_CheckSignals
from libc.stdint cimport int64_t, uint8_t, uint32_t, uint64_t
from libc.stdlib cimport free, malloc, realloc
from libc.string cimport memcmp, memcpy, memset

from zentf.core.buffer_core cimport BufferCore
from zentf.ros.frame_names cimport frame_name
from zentf.transport.ingest.decoders cimport Sample, cdr_walk, msgpack_walk, ros1_walk

from .sqliteapi cimport SQLITE_BLOB, SQLITE_DONE, SQLITE_OK, SQLITE_OPEN_READONLY, SQLITE_OPEN_URI, SQLITE_ROW
from .sqliteapi cimport SqliteApi, sqlite_api

__all__ = ["TfLoader", "KIND_SKIP", "KIND_CDR", "KIND_ROS1", "KIND_OTHER", "KIND_MSGPACK", "MCAP", "ROS1"]

#: what a channel (MCAP channel id, ROS 1 connection id) carries
KIND_SKIP, KIND_CDR, KIND_ROS1, KIND_OTHER, KIND_MSGPACK = 0, 1, 2, 3, 4
#: record framings ``feed`` reads
MCAP, ROS1 = 0, 1

from zentf.ros.tf import MAX_PAYLOAD

cdef Py_ssize_t _MAX_PAYLOAD = MAX_PAYLOAD
cdef int64_t _NS = 1000000000
cdef uint32_t _MAX_CHANNELS = 1 << 20      # larger ids are not in any real bag: such messages are skipped
cdef Py_ssize_t _MAX_DEFINITION = 16 << 20  # a schema/channel/connection record larger than this is damage


cdef inline uint32_t _u32(const uint8_t* p) noexcept nogil:
    return p[0] | (<uint32_t>p[1] << 8) | (<uint32_t>p[2] << 16) | (<uint32_t>p[3] << 24)


cdef inline uint64_t _u64(const uint8_t* p) noexcept nogil:
    cdef uint64_t u
    memcpy(&u, p, 8)  # little-endian hosts only (setup.py builds for x86-64 and arm64)
    return u


cdef inline void _seven(const uint8_t* p, double* v) noexcept nogil:
    memcpy(v, p, 56)


@cython.final  # its cdef methods are called directly (no vtable): the C compiler inlines the small ones
cdef class TfLoader:
    """Decodes the transform messages of a bag's records into ``core``; see the module docstring.

    ``set_channel(id, kind, authority, is_static)`` says what a channel carries; ``feed(piece)`` reads
    records (``framing`` MCAP or ROS1) across pieces; ``end_chunk()`` says whether the last chunk ended
    on a record boundary; ``message(id, payload)`` takes one message read elsewhere (top-level MCAP
    messages, SQLite rows). Only transforms stamped within [start, end] are stored, statics always.
    """

    cdef BufferCore core
    cdef uint8_t* kinds
    cdef uint8_t* statics
    cdef list auths
    cdef uint32_t nchan
    cdef public int64_t start, end
    cdef public object fallback       # fallback(channel, payload bytes): the Python path for one message
    cdef public object on_definition  # on_definition(opcode, header bytes, body bytes): a channel/connection
    cdef public int framing
    cdef public Py_ssize_t messages, transforms, fallbacks, skipped_records
    # dry: decode and track the stamps' range without storing (a time window's probe of a chunk)
    cdef public bint dry
    cdef public int64_t stamp_min, stamp_max
    cdef uint8_t* carry
    cdef Py_ssize_t carry_len, carry_cap, carry_need
    cdef uint64_t skip
    cdef Sample* samples              # a msgpack message's samples (msgpack_walk grows it)
    cdef Py_ssize_t samples_cap
    cdef bint samples_owned           # always True (the walkers realloc the loader's own buffer)

    def __cinit__(self):
        self.kinds = NULL
        self.statics = NULL
        self.carry = NULL
        self.samples = NULL
        self.samples_cap = 0
        self.samples_owned = True

    def __init__(self, BufferCore core, fallback, on_definition=None, int framing=MCAP,
                 int64_t start=0, int64_t end=(1 << 63) - 1):
        self.core = core
        self.fallback = fallback
        self.on_definition = on_definition
        self.framing = framing
        self.start = start
        self.end = end
        self.auths = []
        self.nchan = 0
        self.reset_stamps()

    def reset_stamps(self):
        """Forget the range of decoded dynamic stamps (stamp_min > stamp_max: none yet)."""
        self.stamp_min = (1 << 63) - 1
        self.stamp_max = -1

    def __dealloc__(self):
        free(self.kinds)
        free(self.statics)
        free(self.carry)
        free(self.samples)

    # ------------------------------------------------------------------ channels

    def set_channel(self, uint64_t cid, int kind, authority, bint is_static):
        """What messages of channel ``cid`` are: KIND_SKIP (ignored), KIND_CDR, KIND_ROS1, KIND_MSGPACK (a zentf
        recording's TFMessage), KIND_OTHER (always through ``fallback``)."""
        cdef uint32_t n
        cdef void* p
        if cid >= _MAX_CHANNELS:
            return
        if cid >= self.nchan:
            n = max(<uint32_t>cid + 1, 2 * self.nchan, 64)
            p = realloc(self.kinds, n)
            if p == NULL:
                raise MemoryError()
            self.kinds = <uint8_t*>p
            p = realloc(self.statics, n)
            if p == NULL:
                raise MemoryError()
            self.statics = <uint8_t*>p
            memset(self.kinds + self.nchan, 0, n - self.nchan)
            memset(self.statics + self.nchan, 0, n - self.nchan)
            self.auths.extend([None] * (n - self.nchan))
            self.nchan = n
        self.kinds[cid] = kind
        self.statics[cid] = is_static
        self.auths[cid] = authority

    cdef inline int _kind(self, uint64_t cid) noexcept:
        return self.kinds[cid] if cid < self.nchan else 0

    # ------------------------------------------------------------------ one message

    def message(self, uint64_t cid, payload):
        """One message's payload of channel ``cid``: bytes; anything else (a SQLite cell that is not a blob)
        is a message with nothing to store."""
        if type(payload) is not bytes:
            if self._kind(cid):
                self.messages += 1
                self.skipped_records += 1
            return
        cdef const uint8_t* p = <const uint8_t*>PyBytes_AS_STRING(payload)
        self._message(cid, p, PyBytes_GET_SIZE(payload))

    def sqlite(self, bytes uri, bytes sql, list topic_ids, list channels):
        """Step ``sql`` (rows of topic id, data) over the rosbag2 database ``uri`` (opened read-only) in C,
        each row's blob into ``_message`` in place, topic ``topic_ids[i]`` as channel ``channels[i]``.
        Returns (rows read, None) or (rows read, (SQLite error code, its message)) if SQLite failed;
        None if the SQLite library could not be found (the caller reads through Python's sqlite3)."""
        cdef const SqliteApi* api = sqlite_api()
        if api == NULL:
            return None
        cdef Py_ssize_t k, nt = len(topic_ids), rows = 0
        cdef int64_t tids[64]
        cdef uint64_t cids[64]
        cdef int64_t tid
        cdef uint64_t cid
        cdef void* db = NULL
        cdef void* stmt = NULL
        cdef int rc
        cdef const uint8_t* blob
        cdef int n
        if nt > 64 or nt != len(channels):
            raise ValueError("at most 64 topics, one channel each")
        for k in range(nt):
            tids[k] = topic_ids[k]
            cids[k] = channels[k]
        try:
            rc = api.open_v2(uri, &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, NULL)
            if rc != SQLITE_OK:
                return rows, self._sqlite_error(api, db, rc)
            api.busy_timeout(db, 5000)  # as Python's sqlite3.connect (timeout=5.0)
            rc = api.prepare_v2(db, sql, -1, &stmt, NULL)
            if rc != SQLITE_OK:
                return rows, self._sqlite_error(api, db, rc)
            while True:
                rc = api.step(stmt)
                if rc == SQLITE_DONE:
                    return rows, None
                if rc != SQLITE_ROW:
                    return rows, self._sqlite_error(api, db, rc)
                rows += 1
                if (rows & 4095) == 0:
                    PyErr_CheckSignals()  # Ctrl-C stops a long read
                tid = api.column_int64(stmt, 0)
                cid = 0xFFFFFFFF
                for k in range(nt):
                    if tids[k] == tid:
                        cid = cids[k]
                        break
                if api.column_type(stmt, 1) != SQLITE_BLOB:
                    if self._kind(cid):
                        self.messages += 1
                        self.skipped_records += 1
                    continue
                blob = <const uint8_t*>api.column_blob(stmt, 1)
                n = api.column_bytes(stmt, 1)
                if n > _MAX_PAYLOAD and self._kind(cid):
                    # larger than any decoder takes (the Python path refuses it too): not copied for it
                    self.messages += 1
                    self.skipped_records += 1
                    continue
                self._message(cid, blob if blob != NULL else <const uint8_t*>b"", n if blob != NULL else 0)
        finally:
            if stmt != NULL:
                api.finalize(stmt)
            if db != NULL:
                api.close(db)

    cdef object _sqlite_error(self, const SqliteApi* api, void* db, int rc):
        """(primary error code, SQLite's message) as Python's sqlite3 would report them."""
        if db == NULL:
            return rc & 0xff, "unable to open database file" if (rc & 0xff) == 14 else "out of memory"
        cdef const char* m = api.errmsg(db)
        return api.errcode(db) & 0xff, (<bytes>(<char*>m)).decode("utf-8", "replace") if m != NULL else ""

    cdef int _message(self, uint64_t cid, const uint8_t* p, Py_ssize_t n) except -1:
        cdef int kind = self._kind(cid)
        cdef int done = 0
        if kind == 0:
            return 0
        self.messages += 1
        if kind == KIND_CDR:
            done = self._cdr(p, n, self.auths[cid], self.statics[cid])
        elif kind == KIND_ROS1:
            done = self._ros1(p, n, self.auths[cid], self.statics[cid])
        elif kind == KIND_MSGPACK:
            done = self._msgpack(p, n, self.auths[cid], self.statics[cid])
        if not done:
            self.fallbacks += 1
            self.fallback(cid, PyBytes_FromStringAndSize(<const char*>p, n))
        return 0

    cdef int _insert(self, const uint8_t* parent, Py_ssize_t plen, const uint8_t* child, Py_ssize_t clen,
                     int64_t stamp, const uint8_t* values, object auth, bint is_static) except -1:
        """One decoded transform into the core (lock held); skipped if outside the window or a name is
        not UTF-8 (the Python decoders skip such an element too)."""
        cdef double v[7]
        if not is_static:
            if stamp < self.stamp_min:
                self.stamp_min = stamp
            if stamp > self.stamp_max:
                self.stamp_max = stamp
            if stamp < self.start or stamp > self.end:
                return 0
        if self.dry:
            return 0
        a = frame_name(parent, plen)
        b = frame_name(child, clen)
        if a is None or b is None:
            return 0
        _seven(values, v)
        self.transforms += 1
        return self.core.ingest_one_c(a, b, stamp, v, auth, is_static)

    cdef int _cdr(self, const uint8_t* p, Py_ssize_t end, object auth, bint is_static) except -1:
        """A ROS 2 CDR TFMessage into the core, read by the listener's walker (decoders.cdr_walk); 0 (nothing
        stored) if it doubts the message. An element whose name is not UTF-8 is skipped (as the Python
        decoder skips it)."""
        return self._samples(cdr_walk(p, end, &self.samples, &self.samples_cap, &self.samples_owned), auth,
                             is_static)

    cdef int _ros1(self, const uint8_t* p, Py_ssize_t end, object auth, bint is_static) except -1:
        """A ROS 1 tf2_msgs/TFMessage into the core, read by decoders.ros1_walk (ROS 1 time is unsigned); 0
        (nothing stored) if it doubts the message."""
        return self._samples(ros1_walk(p, end, &self.samples, &self.samples_cap, &self.samples_owned), auth,
                             is_static)

    cdef int _samples(self, Py_ssize_t n, object auth, bint is_static) except -1:
        """The n walked samples into the core (a name that is not UTF-8 skips its element); 0 if the walker
        doubted the message (n == -1)."""
        cdef Py_ssize_t i, accepted = 0
        cdef Sample* s
        if n == -2:
            raise MemoryError()
        if n < 0:
            return 0
        self.core.ingest_begin_c()
        try:
            for i in range(n):
                s = &self.samples[i]
                accepted += self._insert(s.parent, s.parent_len, s.child, s.child_len, s.sec * _NS + s.nsec,
                                         <const uint8_t*>s.v, auth, is_static)
        finally:
            self.core.ingest_end_c(accepted)
            if self.samples_cap > 4096:
                self._trim()
        return 1

    cdef void _trim(self) noexcept:
        """A huge message's samples are not kept (called when samples_cap > 4096)."""
        free(self.samples)
        self.samples = NULL
        self.samples_cap = 0

    cdef int _msgpack(self, const uint8_t* p, Py_ssize_t size, object auth, bint is_static) except -1:
        """A zentf (msgpack) TFMessage into the core, read by the listener's walker (the same strict schema);
        0 (nothing stored) if it doubts the message or a name is not UTF-8."""
        cdef Py_ssize_t n = msgpack_walk(p, size, &self.samples, &self.samples_cap, &self.samples_owned, True), i
        cdef Py_ssize_t accepted = 0
        cdef Sample* s
        if n == -2:
            raise MemoryError()
        if n < 0:
            return 0
        for i in range(n):  # every name first: a doubt stores nothing
            s = &self.samples[i]
            if frame_name(s.parent, s.parent_len) is None or frame_name(s.child, s.child_len) is None:
                return 0
        self.core.ingest_begin_c()
        try:
            for i in range(n):
                s = &self.samples[i]
                accepted += self._insert(s.parent, s.parent_len, s.child, s.child_len, s.sec * _NS + s.nsec,
                                         <const uint8_t*>s.v, auth, is_static)
        finally:
            self.core.ingest_end_c(accepted)
            if self.samples_cap > 4096:
                self._trim()
        return 1

    # ------------------------------------------------------------------ records, piece by piece

    def feed(self, piece):
        """The next piece (bytes) of a chunk's records."""
        cdef const uint8_t* p = <const uint8_t*>PyBytes_AS_STRING(piece)
        cdef Py_ssize_t n = PyBytes_GET_SIZE(piece), pos = 0, take, total
        while pos < n:
            if self.skip:
                take = <Py_ssize_t>min(self.skip, <uint64_t>(n - pos))
                self.skip -= take
                pos += take
                continue
            if self.carry_len == 0:
                pos += self._records(p + pos, n - pos)
                if pos == n:
                    break
            # a record cut by the end of a piece: carry it over (or skip it) until it is whole
            if self.carry_need == 0:
                pos += self._grow_head(p + pos, n - pos)
                if self.carry_need == 0:
                    break  # its head is not complete yet: the piece is used up
                if self.carry_need < 0:  # not kept: skip what is left of it
                    self.skip = <uint64_t>(-self.carry_need) - <uint64_t>self.carry_len
                    self.carry_len = 0
                    self.carry_need = 0
                    self.skipped_records += 1
                    continue
            take = min(self.carry_need - self.carry_len, n - pos)
            self._append(p + pos, take)
            pos += take
            if self.carry_len == self.carry_need:
                total = self.carry_need
                self.carry_len = 0
                self.carry_need = 0
                self._records(self.carry, total)

    def end_chunk(self):
        """True if the chunk's records ended on a record boundary; resets the carry-over either way."""
        ok = self.carry_len == 0 and self.skip == 0
        self.carry_len = 0
        self.carry_need = 0
        self.skip = 0
        return ok

    cdef int _append(self, const uint8_t* p, Py_ssize_t n) except -1:
        cdef void* q
        cdef Py_ssize_t cap
        if self.carry_len + n > self.carry_cap:
            cap = max(self.carry_len + n, 2 * self.carry_cap, 4096)
            q = realloc(self.carry, cap)
            if q == NULL:
                raise MemoryError()
            self.carry = <uint8_t*>q
            self.carry_cap = cap
        memcpy(self.carry + self.carry_len, p, n)
        self.carry_len += n
        return 0

    cdef Py_ssize_t _grow_head(self, const uint8_t* p, Py_ssize_t n) except -1:
        """Move bytes of a cut record into the carry until its size is known; then carry_need is the
        record's whole length (kept) or minus it (skipped). Returns the bytes taken."""
        cdef Py_ssize_t want, taken = 0, take
        while True:
            want = self._head_size(self.carry, self.carry_len)
            if want <= self.carry_len:
                break
            take = min(want - self.carry_len, n - taken)
            if take <= 0:
                return taken
            self._append(p + taken, take)
            taken += take
            if self.carry_len < want:
                return taken
        self.carry_need = self._record_size(self.carry, self.carry_len)  # < 0: skip -carry_need bytes in all
        return taken

    cdef Py_ssize_t _head_size(self, const uint8_t* p, Py_ssize_t have) noexcept:
        """Bytes needed to know a record's size and whether it is kept."""
        if self.framing == MCAP:
            if have < 9 or p[0] != 0x05 or _u64(p + 1) < 2:
                return 9  # opcode and length
            return 11  # and a message's channel id
        if have < 4:
            return 4
        return <Py_ssize_t>min(<uint64_t>_u32(p) + 8, <uint64_t>(1 << 20) + 8)

    cdef int64_t _record_size(self, const uint8_t* p, Py_ssize_t have) except? -2:
        """The length of the record starting at p (head complete), negative if it is not to be kept."""
        cdef uint64_t m, total
        cdef uint32_t hl, dl
        cdef int op
        cdef uint64_t cid
        if self.framing == MCAP:
            op = p[0]
            m = _u64(p + 1)
            total = 9 + m
            if total > (1 << 62):
                return -(1 << 62)
            if op == 0x05 and m >= 22:
                cid = p[9] | (<uint64_t>p[10] << 8)
                if self._kind(cid) and m <= <uint64_t>_MAX_PAYLOAD + 22:
                    return total
            elif op in (0x03, 0x04) and m <= <uint64_t>_MAX_DEFINITION:
                return total
            return -<int64_t>total
        hl = _u32(p)
        if hl > (1 << 20):
            return -(1 << 62)  # a header this long is damage: the rest of the chunk is skipped
        dl = _u32(p + 4 + hl)
        total = 8 + <uint64_t>hl + dl
        op = _ros1_op(p + 4, hl)
        if op == 0x07 and dl <= <uint64_t>_MAX_DEFINITION:
            return total
        if op == 0x02 and self._kind(_ros1_conn(p + 4, hl)) and dl <= <uint64_t>_MAX_PAYLOAD:
            return total
        return -<int64_t>total

    cdef Py_ssize_t _records(self, const uint8_t* p, Py_ssize_t n) except -1:
        """The whole records at the start of p[:n]; returns the bytes they take."""
        cdef Py_ssize_t pos = 0
        cdef uint64_t m
        cdef uint32_t hl, dl
        cdef int op
        if self.framing == MCAP:
            while n - pos >= 9:
                op = p[pos]
                m = _u64(p + pos + 1)
                if m > <uint64_t>(n - pos - 9):
                    break
                if op == 0x05:
                    if m >= 22:
                        self._message(p[pos + 9] | (<uint64_t>p[pos + 10] << 8), p + pos + 9 + 22, m - 22)
                elif op == 0x03 or op == 0x04:
                    self._definition(op, p + pos + 9, m, NULL, 0)
                pos += 9 + m
            return pos
        while n - pos >= 8:
            hl = _u32(p + pos)
            if <uint64_t>hl + 8 > <uint64_t>(n - pos):
                break
            dl = _u32(p + pos + 4 + hl)
            if <uint64_t>hl + 8 + dl > <uint64_t>(n - pos):
                break
            op = _ros1_op(p + pos + 4, hl)
            if op == 0x02:
                self._message(_ros1_conn(p + pos + 4, hl), p + pos + 8 + hl, dl)
            elif op == 0x07:
                self._definition(op, p + pos + 4, hl, p + pos + 8 + hl, dl)
            pos += 8 + hl + dl
        return pos

    cdef int _definition(self, int op, const uint8_t* head, Py_ssize_t hn, const uint8_t* body,
                         Py_ssize_t bn) except -1:
        if self.on_definition is not None:
            self.on_definition(op, PyBytes_FromStringAndSize(<const char*>head, hn),
                               PyBytes_FromStringAndSize(<const char*>body, bn) if body != NULL else b"")
        return 0


cdef const uint8_t* _ros1_field(const uint8_t* h, Py_ssize_t n, const char* name, Py_ssize_t nl,
                                Py_ssize_t* vlen) noexcept:
    """The value of header field ``name`` (NULL if absent or the header is malformed)."""
    cdef Py_ssize_t i = 0
    cdef uint32_t k
    while n - i >= 4:
        k = _u32(h + i)
        i += 4
        if k > <uint32_t>(n - i):
            return NULL
        if k > <uint32_t>nl and h[i + nl] == 61 and memcmp(h + i, name, nl) == 0:  # '='
            vlen[0] = k - nl - 1
            return h + i + nl + 1
        i += k
    return NULL


cdef int _ros1_op(const uint8_t* h, Py_ssize_t n) noexcept:
    cdef Py_ssize_t vl
    cdef const uint8_t* v = _ros1_field(h, n, b"op", 2, &vl)
    return v[0] if v != NULL and vl == 1 else -1


cdef uint64_t _ros1_conn(const uint8_t* h, Py_ssize_t n) noexcept:
    cdef Py_ssize_t vl
    cdef const uint8_t* v = _ros1_field(h, n, b"conn", 4, &vl)
    return _u32(v) if v != NULL and vl == 4 else 0xFFFFFFFF
