# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""A TransformListener's per-topic ingest, compiled: a sample's payload to the buffer.

``TfIngest`` decodes a payload (decoders.pyx), checks its stamps against the listener's future guard and
inserts it from C; ``TfHandler`` is one topic's handler around it (authority, encoding check, counters,
the lines), Zenoh's callback for ``tf_static`` and the listener's thread's (thread.pyx) for ``tf``.
What it has to say goes to ``events``, the object the listener hands over (``IngestEvents``): a payload
that is not a TFMessage, malformed elements, messages dropped unread, a burst that is over.
"""
cimport cython
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_GET_SIZE
from libc.stdint cimport int64_t, uint8_t
from libc.string cimport memcmp

from ...core.buffer_core cimport BufferCore
from .coarse_clock cimport coarse_ns
from .decoders cimport Batch, cdr_le, decode_cdr, decode_msgpack

from ..wire.codec import insert_samples
from .tf_encoder import TF_KEY

__all__ = ["IngestEvents", "Senders", "SenderTail", "TfIngest", "TfHandler", "CLOCK_CACHE_NS"]

cdef bytes _TF_KEY = TF_KEY

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

cdef object _SampleType = None, _get_payload = None, _get_attachment = None, _get_key_expr = None, _to_bytes = None


cdef int _zenoh_descriptors() except -1:
    """Find zenoh.Sample's payload and attachment getters and ZBytes.to_bytes (once; the handlers and the
    tf thread use them for zenoh.Sample objects, anything else is read by name)."""
    global _SampleType, _get_payload, _get_attachment, _get_key_expr, _to_bytes
    if _SampleType is not None:
        return 0
    import zenoh
    d = zenoh.Sample.__dict__
    _get_payload, _get_attachment, _get_key_expr = d["payload"], d["attachment"], d["key_expr"]
    _to_bytes = zenoh.ZBytes.__dict__["to_bytes"]
    _SampleType = zenoh.Sample
    return 0


cdef object payload_of(object sample):
    """sample.payload.to_bytes()"""
    if type(sample) is _SampleType:
        return _call1(_to_bytes, _descr_get(_get_payload, sample))
    return sample.payload.to_bytes()


cdef object wildcard_key(object sample, object concrete):
    """The sample's key expression when it is not a concrete key (a put on ``**`` or ``t$*`` arrives
    under that wildcard in every subscriber it intersects: it is no topic's message), else None.
    ``concrete``: the subscriber's own key (a zenoh.KeyExpr without wildcards) or None; a sample on it
    is compared in Rust, without its key becoming a str (~900 of the ~1,750 instructions of a check)."""
    cdef str key
    if type(sample) is _SampleType:
        ke = _descr_get(_get_key_expr, sample)
        if concrete is not None and ke == concrete:
            return None
        key = str(ke)
    else:
        key = str(sample.key_expr)
    return key if "*" in key else None


cdef object attachment_of(object sample):
    """The attachment's bytes, None without one."""
    if type(sample) is _SampleType:
        att = _descr_get(_get_attachment, sample)
        return None if att is None else _call1(_to_bytes, att)
    att = sample.attachment
    return None if att is None else att.to_bytes()


class IngestEvents:
    """What the ingest path tells its owner (a TransformListener builds one and hands it to its
    handlers): each method is called on the thread that met the event and must not raise."""

    def bad_message(self, key: str, sender: str, error: Exception) -> None:
        """A payload on ``key`` that is not a TFMessage at all (or could not be read)."""

    def malformed(self, key: str, authority: str, count: int, problem) -> None:
        """``count`` malformed transform elements in one message; ``problem`` names the first."""

    def dropped(self, counts: dict, waiting: dict) -> None:
        """Messages dropped unread, by sender key (``waiting``: what is still queued from each)."""

    def burst_over(self) -> None:
        """A burst of messages has been handled (time to give freed memory back)."""

    def burst_tail(self) -> None:
        """The ring ran empty again soon after a burst was over, with little handled since."""


cdef class SenderTail:
    """``sender_of`` for attachments that carry the sender's identity after per-sample fields: an
    attachment of ``size`` bytes whose byte ``marker_at`` is ``marker`` -> its bytes from ``marker_at + 1``
    on; any other attachment is its own key. Callable like any ``sender_of``; Senders runs it in C."""

    def __init__(self, Py_ssize_t size, Py_ssize_t marker_at, int marker):
        if not 0 <= marker_at < size:
            raise ValueError("marker_at must fall inside the attachment")
        self.size = size
        self.marker_at = marker_at
        self.marker = marker

    def __call__(self, bytes raw):
        return self.key(raw)

    cdef object key(self, bytes raw):
        cdef const uint8_t* p = <const uint8_t*>PyBytes_AS_STRING(raw)
        cdef Py_ssize_t n = self.size - self.marker_at - 1
        if PyBytes_GET_SIZE(raw) == self.size and p[self.marker_at] == self.marker:
            # the same sender as the last sample (a flood's): its key again, no slice made
            if self.last is not None and memcmp(p + self.marker_at + 1, PyBytes_AS_STRING(self.last), n) == 0:
                return self.last
            self.last = raw[self.marker_at + 1:]
            return self.last
        return raw


cdef class Senders:
    """How a wire names the sender of a sample, for a listener's handlers and its thread: the authority
    recorded with its transforms (``authority_of(attachment, fallback)``, or one ``fixed`` for every
    sample: ROS 2 carries no sender name) and the key of its queue in the thread (``sender_of(attachment
    bytes)``, None: the bytes are it). Authorities read are kept by attachment bytes, at most 1024 and
    none longer than ``max_key`` bytes (a forged huge attachment is read, not kept; longer queue keys are cut)."""

    def __init__(self, authority_of, fixed=None, sender_of=None, Py_ssize_t max_key=1024):
        self.authority_of = authority_of
        self.fixed = fixed
        self.sender_of = sender_of
        self.tail = sender_of if isinstance(sender_of, SenderTail) else None
        self.cache = {}
        self.max_key = max_key

    cdef object queue_key(self, object raw):
        """The queue key of a message: its sender (the attachment's bytes, or what the wire makes of them)."""
        if raw is None:
            return b""
        if self.tail is not None:
            key = self.tail.key(raw)
        else:
            key = self.sender_of(raw) if self.sender_of is not None else raw
        if len(key) > self.max_key:
            key = key[:self.max_key]
        return key


#: How long (ns) a clock read may stand for "now" when a stamp is below its limit (TfIngest._too_new).
CLOCK_CACHE_NS = 100_000_000
cdef int64_t _CLOCK_CACHE = CLOCK_CACHE_NS
cdef tuple _NOTHING = (0, 0, 0, None)
cdef tuple _ONE = (1, 0, 0, None)       # the 1-transform message stored: no tuple built

cdef class TfIngest:
    """One topic's ingest for a TransformListener: ``ingest(payload, authority)`` -> (accepted, rejected,
    malformed, first problem), as the profile's ``ingest_tf`` returns it.

    A well-formed payload (``cdr``: ROS 2's CDR, else zentf's msgpack) with nothing stamped beyond the
    clock's now + tolerance is decoded here and inserted into ``core`` from C under one lock; anything
    else (a doubt, a stamp too far ahead, which the listener's future guard logs) goes to
    ``slow(payload, target, authority, is_static)``, the profile's ``ingest_tf`` into ``target`` (the
    guard, or the buffer), so every problem is counted and named there. ``now_ns`` (the listener
    clock's, None: no future guard) and ``tolerance_ns`` are the guard's.
    """

    # (fields: handler.pxd) batch: a compiled BufferCore's samples go in from C (no tuples); limit: now +
    # tolerance at the last clock read (-1: none); limit_until: coarse monotonic ns until which limit
    # may be used without a read

    def __init__(self, bint cdr, slow, target, core, now_ns, tolerance_ns, bint is_static):
        self.batch = Batch() if isinstance(core, BufferCore) else None
        self.cdr = cdr
        self.slow = slow
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
        samples = decode_cdr(payload, &newest, None) if self.cdr else decode_msgpack(payload, &newest, None)
        if samples is None:
            return self.slow(payload, self.target, authority, self.is_static)
        if not samples:
            return 0, 0, 0, None
        if self._too_new(newest):
            return self.slow(payload, self.target, authority, self.is_static)
        try:
            accepted = self.core.set_transforms_raw(samples, authority, self.is_static)
        except Exception:  # the buffer must never take the listener down: one by one
            return insert_samples(samples, self.core, authority, self.is_static)
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
        mono = coarse_ns()
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
        cdef Batch b = self.batch
        cdef BufferCore core = <BufferCore>self.core
        cdef Py_ssize_t i = 0, accepted = 0
        b.reset()
        ok = decode_cdr(payload, &newest, b) if self.cdr else decode_msgpack(payload, &newest, b)
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
            got, rejected, malformed, problem = insert_samples(rest, self.core, authority, self.is_static)
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


cdef class TfHandler:
    """One topic's ``handle(sample)`` for a TransformListener: encoding check, authority, decode and
    insert (``ingest``: a TfIngest, or any ``ingest(payload, authority)``), counters; never raises (a
    payload that is not a TFMessage and malformed elements go to ``events``, which writes the lines).

    The sample's encoding is read only when the payload is not a well-formed TFMessage (a payload the
    strict decoder reads as one is one, whatever its label; anything else gets the type check's line,
    ``check_encoding(encoding)`` raising, unless it equals ``tf_encoding``). Zenoh's callback (tf_static)
    calls it with the sample; the tf thread hands over the attachment's bytes it read already, or the
    payload's bytes (``queued``).
    """

    def __init__(self, ingest, Senders senders, events, str topic="?", check_encoding=None, tf_encoding=None):
        self.ingest = ingest
        self.cingest = ingest if isinstance(ingest, TfIngest) else None
        self.senders = senders
        self.events = events
        self.topic = topic  # the key expression the handler's subscriber was declared on (lines)
        self.concrete = None
        if isinstance(topic, str) and "*" not in topic and "$" not in topic:
            import zenoh
            try:
                self.concrete = zenoh.KeyExpr(topic)
            except Exception:  # not a key expression (a test's label): every key is read as a str
                self.concrete = None
        self.check_encoding = check_encoding  # None: not looked at (ROS 2: the type is in the key)
        self.tf_encoding = tf_encoding
        self.messages = self.transforms = self.rejected = self.malformed = self.wildcard = 0
        self.payload_bytes = 0
        _zenoh_descriptors()

    def __call__(self, sample):
        """Zenoh's callback: True if something got into the buffer."""
        return self.handle(sample, None, False)

    cdef object authority(self, object sample, object raw):
        """The authority of a sample whose attachment bytes are ``raw`` (the previous message's, the
        cache's, else the wire's reading of the attachment)."""
        cdef Senders s = self.senders
        authority = s.fixed
        if authority is None:
            if raw is None:
                authority = None
            elif self.last_raw is not None and raw == self.last_raw:
                authority = self.last_authority
            else:
                authority = s.cache.get(raw)
            if authority is None:
                authority = s.authority_of(sample.attachment, str(sample.key_expr))
                if raw is not None and len(raw) <= s.max_key and len(s.cache) < 1024:
                    s.cache[raw] = authority
            if raw is not None:  # (per handler: the tf thread's and Zenoh's callback's runs stay apart)
                self.last_raw, self.last_authority = raw, authority
        return authority

    cdef object queued(self, object sample, object raw):
        """The payload's bytes of a sample the tf thread queues, when it starts as a TFMessage of this
        wire does (then handle_payload); None: the sample itself is queued (also if reading it fails:
        handle() then names that). A queued Zenoh sample pins the whole receive buffer it was cut from
        (Zenoh's, 64 kB) and ~300 bytes of Python object: in a 1-transform flood, queueing samples made
        the listener's thread fault in and unmap memory for ~10 % of its time (perf)."""
        cdef Py_ssize_t n
        cdef const char* p
        if raw is None or self.cingest is None:
            return None
        try:
            if wildcard_key(sample, self.concrete) is not None:
                return None  # queued as the sample: handle() names and drops it
            payload = payload_of(sample)
        except Exception:
            return None
        n = PyBytes_GET_SIZE(payload)
        p = PyBytes_AS_STRING(payload)
        if (cdr_le(<const uint8_t*>p, n) if self.cingest.cdr
                else n >= PyBytes_GET_SIZE(_TF_KEY)
                and memcmp(p, PyBytes_AS_STRING(_TF_KEY), PyBytes_GET_SIZE(_TF_KEY)) == 0):
            return payload
        return None

    cdef bint handle(self, object sample, object raw, bint have_raw) except -1:
        """One message from its sample (``raw``: its attachment's bytes, when have_raw)."""
        try:
            wild = wildcard_key(sample, self.concrete)
            if wild is not None:
                self.wildcard += 1
                self.events.bad_message(wild, self.senders.authority_of(sample.attachment, "unknown sender"),
                                        ValueError("sent on a key expression with wildcards, not on the topic"))
                return False
            if not have_raw and self.senders.fixed is None:
                raw = attachment_of(sample)
            authority = self.authority(sample, raw)
            payload = payload_of(sample)
        except Exception as e:
            self._bad(sample, None, e)
            return False
        return self._ingest(sample, payload, authority)

    cdef bint handle_payload(self, object payload, object authority) except -1:
        """One queued message kept as its payload's bytes (``queued``): as handle, except on the Python
        path, where the sample is gone: its encoding is not looked at (the payload starts as a TFMessage
        does) and the lines name the topic's key."""
        return self._ingest(None, payload, authority)

    cdef bint _ingest(self, object sample, object payload, object authority) except -1:
        cdef Py_ssize_t accepted, rejected, malformed
        self.payload_bytes += PyBytes_GET_SIZE(payload) if type(payload) is bytes else len(payload)
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
            self._bad(sample, authority, e)
            return False
        # plain counters (statistics only; no lock on the hot path)
        self.messages += 1
        self.transforms += accepted
        self.rejected += rejected
        if malformed:
            self.malformed += malformed
            self.events.malformed(str(sample.key_expr) if sample is not None else self.topic,
                                  authority, malformed, problem)
        return accepted > 0

    cdef int _bad(self, object sample, object authority, object error) except -1:
        """A message that is not a TFMessage: its key and sender to events.bad_message."""
        key, sender = self.topic, authority
        if sample is not None:
            try:
                key = str(sample.key_expr)
                sender = self.senders.authority_of(sample.attachment, "unknown sender")
            except Exception:
                key, sender = "?", None
        self.events.bad_message(key, sender or "unknown sender", error)
        return 0
