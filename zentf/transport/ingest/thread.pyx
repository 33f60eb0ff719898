# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
"""A TransformListener's ``tf`` thread, compiled: drain Zenoh's ring into per-sender queues and handle
one message per sender in turn, so a flood delays only its sender's data (docs/protocol.md, "Limits").

``serve(ring, handler, limits)`` runs until the ring is undeclared; ``handler`` (handler.pyx TfHandler)
decodes and inserts, and its ``events`` hear what was dropped and when a burst is over; ``limits``
(``ServeLimits``) bounds the queues in messages and in bytes.
"""
cimport cython
from cpython.bytes cimport PyBytes_GET_SIZE
from cpython.list cimport PyList_GET_SIZE
from libc.stdint cimport int64_t

from .coarse_clock cimport coarse_ns
from .handler cimport Senders, TfHandler, attachment_of, payload_of

__all__ = ["serve", "ServeLimits", "payload_messages"]

#: The queue of the senders beyond ``max_senders`` (no real sender key starts with a NUL byte).
OTHERS = b"\x00others"

cdef int64_t _payload_messages = 0  # queued messages kept as payload bytes and handled (tests)


def payload_messages():
    """How many queued messages serve kept as their payload's bytes (TfHandler.queued) and handled (tests)."""
    return _payload_messages


cdef class ServeLimits:
    """The tf thread's bounds (a TransformListener's constants, zentf.transport.listener):

    - ``drain_batch``: samples moved from the ring to the queues between two rounds;
    - ``max_pending``, ``max_pending_bytes``: messages, and payload bytes, waiting in all the queues; beyond
      either the biggest backlog loses its oldest;
    - ``suspect_after``, ``suspect_queue``: a sender none of whose last suspect_after messages put anything
      into the buffer keeps only its newest suspect_queue waiting;
    - ``max_senders``: senders with a queue of their own (the rest share one);
    - ``release_after``, ``release_bytes``: a burst of this many messages, or of this many payload bytes,
      is over when the ring runs empty (``events.burst_over()``); ``tail_window``: s after that within
      which running empty again is its tail (``events.burst_tail()``).
    """
    cdef readonly Py_ssize_t drain_batch, max_pending, max_pending_bytes, suspect_after, suspect_queue
    cdef readonly Py_ssize_t max_senders, release_after, release_bytes
    cdef readonly double tail_window

    def __init__(self, *, Py_ssize_t drain_batch, Py_ssize_t max_pending, Py_ssize_t max_pending_bytes,
                 Py_ssize_t suspect_after, Py_ssize_t suspect_queue, Py_ssize_t max_senders,
                 Py_ssize_t release_after, Py_ssize_t release_bytes, double tail_window):
        self.drain_batch = drain_batch
        self.max_pending = max_pending
        self.max_pending_bytes = max_pending_bytes
        self.suspect_after = suspect_after
        self.suspect_queue = suspect_queue
        self.max_senders = max_senders
        self.release_after = release_after
        self.release_bytes = release_bytes
        self.tail_window = tail_window


@cython.final
cdef class _Fifo:
    """One sender's waiting messages: (sample, attachment bytes) or (payload bytes, authority) pairs, each
    with its payload's size, in a list read from a head index, so a message costs three list appends and
    three reads, no tuple and no deque method call (~0.5k instructions a message in a flood)."""
    cdef list items
    cdef Py_ssize_t head
    cdef Py_ssize_t nbytes  # payload bytes waiting
    cdef object raw     # the second item of the message take() gave last (attachment bytes or authority)

    def __cinit__(self):
        self.items = []
        self.head = 0
        self.nbytes = 0

    cdef inline Py_ssize_t size(self):
        return (PyList_GET_SIZE(self.items) - self.head) // 3

    cdef inline int push(self, object sample, object raw, Py_ssize_t nbytes) except -1:
        self.items.append(sample)
        self.items.append(raw)
        self.items.append(nbytes)
        self.nbytes += nbytes
        return 0

    cdef inline object take(self):
        """The oldest message (the queue must not be empty); its second item goes to self.raw."""
        cdef list items = self.items
        cdef Py_ssize_t h = self.head
        sample = items[h]
        self.raw = items[h + 1]
        self.nbytes -= <Py_ssize_t>items[h + 2]
        items[h] = None
        items[h + 1] = None
        h += 3
        if h == PyList_GET_SIZE(items):       # empty now: start again at 0
            del items[:]
            h = 0
        elif h >= 3072 and 2 * h >= PyList_GET_SIZE(items):
            del items[:h]                     # half read: drop the read part (amortized O(1))
            h = 0
        self.head = h
        return sample


# messages of one backlogged sender handled in a row while the ring is empty (serve): the ring is looked
# at again within ~8 handles (~25 us), so a sender that shows up meanwhile waits no longer than that
cdef enum:
    _SOLO_RUN = 8


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


cdef inline Py_ssize_t _sample_size(object sample):
    """The payload size of a queued Zenoh sample (no copy); 0 if it cannot be read (handle() names that)."""
    try:
        return len(sample.payload)
    except Exception:
        return 0


cdef object _biggest(dict queues, _Fifo q, object key, bint by_bytes, Py_ssize_t max_pending):
    """The backlog that loses its oldest when too much waits in all: usually the sender just heard (q),
    else the one with the most messages (or bytes)."""
    cdef _Fifo other
    if (q.nbytes * len(queues) < max_pending) if by_bytes else (q.size() * len(queues) < max_pending):
        best = -1
        for k, v in queues.items():
            other = <_Fifo>v
            n = other.nbytes if by_bytes else other.size()
            if n > best:
                best, key = n, k
    return key


def serve(ring, TfHandler handle, ServeLimits limits):
    """The tf thread of a TransformListener: drain the ring into per-sender FIFOs, then handle one
    message per sender in turn, shedding what the limits do not hold (``handle.events.dropped``).

    A message that arrives alone (nothing waiting, the ring empty behind it) is handled at once, without
    a queue (no order changes); the first one after a wait on an empty ring is, without even looking
    at the ring behind it (a look costs ~0.5 us of the e2e latency; what came meanwhile is next). When
    one sender has a backlog, the ring was just found empty and no sender is striking (see _strike), up
    to _SOLO_RUN of its messages are handled in a row (the ring is looked at again ~25 us later). Not
    several messages of a lone backlogged sender per round while the ring still holds samples: the ring
    must be emptied into the per-sender queues as fast as it fills, or an honest sender's next message
    waits behind the flood (bench/abuse.py measures its staleness).

    Memory: when the ring runs empty after ``release_after`` messages or ``release_bytes`` payload bytes,
    ``events.burst_over()``; when it runs empty within ``tail_window`` s of that with less since (the
    tail of a flood the thread keeps up with, so it idles between messages), ``events.burst_tail()``."""
    global _payload_messages
    recv, try_recv = ring.recv, ring.try_recv
    cdef Senders senders = handle.senders
    events = handle.events
    cdef Py_ssize_t drain_batch = limits.drain_batch, max_pending = limits.max_pending
    cdef Py_ssize_t max_bytes = limits.max_pending_bytes, suspect_after = limits.suspect_after
    cdef Py_ssize_t suspect_queue = limits.suspect_queue, max_senders = limits.max_senders
    cdef Py_ssize_t release_after = limits.release_after, release_bytes = limits.release_bytes
    cdef dict queues = {}
    cdef dict strikes = {}          # messages in a row that put nothing into the buffer, per sender
    cdef dict shed
    cdef Py_ssize_t pending = 0, pending_bytes = 0, burst = 0, n, extra, j, r, run, size
    cdef Py_ssize_t bytes_at_release = 0, dropped_bytes = 0
    cdef _Fifo q, big_q
    cdef _Fifo last_q = None   # the queue the previous sample went to (a flood's sender)
    cdef object emptied, raw, last_key = None
    cdef int64_t last_release = 0, window = <int64_t>(limits.tail_window * 1e9)
    cdef bint ok, suspect, woke
    while True:
        try:  # blocks in Zenoh (GIL released) when idle; fails once undeclared
            woke = False
            sample = try_recv()
            if sample is None and not pending:
                # the ring is empty: the end of a burst, then wait (idle)
                if burst and (burst >= release_after
                              or handle.payload_bytes + dropped_bytes - bytes_at_release >= release_bytes):
                    # a burst is over: glibc would keep the memory it freed (zentf.transport.heap)
                    events.burst_over()
                    burst = 0
                    bytes_at_release = handle.payload_bytes + dropped_bytes
                    last_release = coarse_ns()
                elif 0 < burst and last_release and coarse_ns() - last_release < window:
                    events.burst_tail()
                sample = recv()
                woke = True
        except Exception:
            return
        n = 0
        shed = None
        while sample is not None:
            raw = attachment_of(sample)  # read once: handle() gets it too (the authority)
            key = senders.queue_key(raw)
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
                        key = OTHERS
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
            # a suspect's messages mostly go unread (shed above): not copied now, which would slow the
            # draining of a flood; the sample is queued (its size read, not its bytes)
            payload = None if suspect else handle.queued(sample, raw)
            pending_bytes -= q.nbytes
            if payload is not None:  # its bytes: the sample (and Zenoh's buffer) go now
                q.push(payload, handle.authority(sample, raw), PyBytes_GET_SIZE(payload))
            else:
                q.push(sample, raw, _sample_size(sample))
            pending_bytes += q.nbytes
            pending += 1
            while pending > max_pending or pending_bytes > max_bytes:
                big = _biggest(queues, q, key, pending <= max_pending,
                               max_bytes if pending <= max_pending else max_pending)
                big_q = <_Fifo>queues[big]
                if big_q.size() == 0:
                    break
                size = big_q.nbytes
                big_q.take()
                pending_bytes -= size - big_q.nbytes
                dropped_bytes += size - big_q.nbytes
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
            events.dropped(shed, {k: (<_Fifo>queues[k]).size() for k in shed if k in queues})
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
                size = q.nbytes
                sample = q.take()
                raw = q.raw
                pending -= 1
                pending_bytes -= size - q.nbytes
                if type(sample) is bytes:
                    _payload_messages += 1
                    ok = handle.handle_payload(sample, raw)
                else:
                    ok = handle.handle(sample, raw, True)
                if _strike(strikes, key, ok, suspect_after, max_senders) \
                        and q.size() > suspect_queue:  # queued before it turned suspect
                    extra = q.size() - suspect_queue
                    size = q.nbytes
                    for j in range(extra):
                        q.take()
                    pending -= extra
                    pending_bytes -= size - q.nbytes
                    dropped_bytes += size - q.nbytes
                    events.dropped({key: extra}, {key: q.size()})
            sample = None
            if q.size() == 0:
                if emptied is None:
                    emptied = []
                emptied.append(key)
        if emptied is not None:
            for key in emptied:
                del queues[key]
            last_key = last_q = None
