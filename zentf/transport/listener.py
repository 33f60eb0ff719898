"""TransformListener: fills a Buffer from ``tf`` (fairly per sender) and ``tf_static``."""
from __future__ import annotations

import atexit
import logging
import math
import threading
import uuid
import weakref
from collections.abc import Callable
from typing import Any

from ..core.messages import TFMessage
from ..core.ratelimit import RateLimitedLogger
from ..core.time import Duration
from .entities import undeclare_all
from .heap import release_free_memory
from .ingest.handler import IngestEvents, Senders, TfHandler, TfIngest  # compiled: decode + future check + insert
from .ingest.thread import ServeLimits, serve  # compiled: the tf thread
from .node import Node

__all__ = ["TransformListener", "StaticTransformListener", "DEFAULT_FUTURE_TOLERANCE"]

log = logging.getLogger("zentf.transport.listener")

#: Seconds a ``tf`` sample may be stamped ahead of the listener's clock before it is refused
#: (a deliberate difference from tf2, which takes any stamp: one sample stamped years ahead would
#: otherwise own the edge's latest value and push every honest sample out as TF_OLD_DATA).
DEFAULT_FUTURE_TOLERANCE = 5.0
#: ``tf`` messages Zenoh holds for the listener's thread; beyond it Zenoh drops the oldest, so a flood
#: never backs up into the network (where an honest message would wait behind it).
RING_CAPACITY = 16384
#: Samples moved from the ring to the per-sender queues between two rounds (one message per sender).
DRAIN_BATCH = 256
#: Messages, and payload bytes, waiting in the per-sender queues in all; beyond either the biggest
#: backlog loses its oldest (a flood of big forged messages must not grow the listener's memory).
MAX_PENDING = 100_000
MAX_PENDING_BYTES = 32 * 1024 * 1024
#: A sender none of whose last SUSPECT_AFTER messages put anything into the buffer (NaN, forged frames
#: past the cap, garbage...) keeps only its newest SUSPECT_QUEUE waiting (ROS 2's tf queue depth).
SUSPECT_AFTER = 8
SUSPECT_QUEUE = 100
#: Senders with a queue of their own; messages of further senders share one.
MAX_SENDERS = 64
#: Sender keys (attachment bytes) are cut to this length: a forged huge attachment must not be kept
#: as a dictionary key (a node name is at most 256 characters, a ROS 2 GID 16 bytes).
MAX_SENDER_KEY = 1024
#: When the ring runs empty after at least this many ``tf`` messages, or this many payload bytes (a burst
#: is over), the memory the process freed meanwhile goes back to the OS (zentf.transport.heap): often
#: enough to bound a flood's memory, rarely enough to cost about 1% of the listener thread's time
#: (docs/performance.md).
RELEASE_AFTER = 256
RELEASE_BYTES = 8 * 1024 * 1024
#: The tail of a flood: when the ring runs empty within TAIL_WINDOW s of such a release, with fewer
#: messages since, the memory goes back once the ring has stayed quiet for TAIL_DELAY s (a timer: the
#: thread waits in the ring), so the last < RELEASE_AFTER messages of a flood are given back too.
TAIL_WINDOW = 2.0
TAIL_DELAY = 0.1


def _tolerance_ns(value: Any) -> int | None:
    """Seconds (or Duration) -> ns; None (or a negative number) turns the guard off."""
    if value is None:
        return None
    if isinstance(value, Duration):
        return value.nanoseconds
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"future_tolerance must be seconds or None, got {type(value).__name__}")
    if math.isnan(value):
        raise ValueError("future_tolerance must be a number of seconds, got nan")
    if value < 0 or math.isinf(value):
        return None
    return round(value * 1e9)


class _FutureGuard:
    """What ``wire.ingest_tf`` inserts into: drops samples stamped too far ahead, passes the rest on."""

    __slots__ = ("core", "clock", "now_ns", "tolerance_ns", "refused", "limiter")

    def __init__(self, core: Any, clock: Any, tolerance_ns: int, limiter: RateLimitedLogger) -> None:
        self.core = core
        self.clock = clock
        self.now_ns = clock.now_ns
        self.tolerance_ns = tolerance_ns
        self.refused = 0
        self.limiter = limiter

    def _split(self, samples: list, authority: str, now: int | None = None) -> list:
        """The samples not stamped beyond now + tolerance; the rest are counted and logged."""
        if now is None:
            now = self.now_ns()
        if not now:  # sim time before the first /clock: nothing to compare with
            return samples
        limit = now + self.tolerance_ns
        for s in samples:
            if s[2] > limit:
                break
        else:
            return samples
        keep = [s for s in samples if s[2] <= limit]
        bad = [s for s in samples if s[2] > limit]
        self.refused += len(bad)
        s = bad[0]
        self.limiter.log(logging.WARNING, ("TF_FUTURE_DATA", authority),
                         'TF_FUTURE_DATA ignoring transform for child_frame_id "%s" from authority "%s": '
                         "stamp %.6f is %.3f s ahead of this listener's clock (tolerance %.3f s)",
                         s[1], authority, s[2] / 1e9, (s[2] - now) / 1e9, self.tolerance_ns / 1e9)
        return keep

    def set_transforms_raw(self, samples: list, authority: str, is_static: bool = False) -> int:
        now = self.now_ns()
        if now:  # (the common case inline: nothing ahead, one clock read, no copy)
            limit = now + self.tolerance_ns
            for s in samples:
                if s[2] > limit:
                    samples = self._split(samples, authority, now)
                    if not samples:
                        return 0
                    break
        return self.core.set_transforms_raw(samples, authority, is_static)

    def set_transform_raw(self, *args: Any) -> bool:
        sample, authority = args[:10], args[10]
        if not self._split([sample], authority):
            return False
        return self.core.set_transform_raw(*args)


class _Events(IngestEvents):
    """What the compiled ingest path tells a listener: counted here, logged rate-limited (names escaped)."""

    def __init__(self, limiter: RateLimitedLogger, release_later: Callable[[], None]) -> None:
        self.limiter = limiter
        self.release_later = release_later
        self.bad_messages = 0      # payloads that were not a TFMessage at all
        self.dropped_messages = 0  # tf messages dropped unread: a sender's backlog grew too big

    def bad_message(self, key: str, sender: str, error: Exception) -> None:
        self.bad_messages += 1
        self.limiter.log(logging.WARNING, ("bad", key, sender), "dropped bad message on '%s' from %s: %s",
                         key, sender, str(error))

    def malformed(self, key: str, authority: str, count: int, problem: str | None) -> None:
        self.limiter.log(logging.WARNING, ("malformed", key, authority),
                         "skipped %d malformed transform(s) on '%s' from %s: %s",
                         count, key, authority, problem or "")

    def dropped(self, counts: dict[bytes, int], waiting: dict[bytes, int]) -> None:
        for key, n in counts.items():
            self.dropped_messages += n
            sender = key.decode("utf-8", "replace") if key else "unknown sender"
            self.limiter.log(logging.WARNING, ("overload", key),
                             "tf listener overloaded: dropped %d message(s) from %s unread (%d waiting from it)",
                             n, sender, waiting.get(key, 0))

    def burst_over(self) -> None:
        release_free_memory()
        log.debug("a burst of tf messages is over: freed memory released")

    def burst_tail(self) -> None:
        self.release_later()


class TransformListener:
    """TransformListener(buffer, node=None, *, static_only=False, future_tolerance=5.0): subscribes and
    inserts; never raises.

    Each message is msgpack-decoded and inserted with ``set_transforms_raw`` (no dataclasses); a
    malformed element is counted, logged (rate-limited, naming the sender) and skipped. The sender's
    node name (sample attachment) is the authority. A backwards jump of the node's clock clears the
    buffer (statics survive), as tf2 does.

    Beyond tf2: ``tf`` samples stamped more than ``future_tolerance`` seconds ahead of the node's clock
    (wall or sim; node parameter ``tf_future_tolerance``; None turns it off) are refused and logged.
    ``tf`` is read by one thread from a Zenoh ring buffer, one message per sender in turn, so a sender
    flooding the topic delays only its own data (docs/protocol.md, "Limits"); ``tf_static`` is handled
    in Zenoh's callback. When a burst has been handled, the memory it freed goes back to the OS.
    ``max_frames`` and ``max_frame_id_length`` (node parameters ``tf_max_frames``,
    ``tf_max_frame_id_length``), when given, set the buffer's bounds. Log lines are rate-limited per
    reason and sender, names escaped. Without a node, a hidden one is created from the env.
    """

    _UNSET: Any = object()

    def __init__(self, buffer: Any, node: Node | None = None, *, static_only: bool = False,
                 tf_topic: str = "tf", tf_static_topic: str = "tf_static", spin_thread: bool = True,
                 future_tolerance: Any = _UNSET, max_frames: Any = _UNSET,
                 max_frame_id_length: Any = _UNSET) -> None:
        import zenoh
        import zenoh.ext as zx

        self.buffer = buffer
        self._own_node = node is None
        self.node = node if node is not None else Node(f"transform_listener_impl_{uuid.uuid4().hex[:12]}",
                                                       check_unique=False)
        if getattr(buffer, "node", "missing") is None:
            buffer.node = self.node
        self._limiter = RateLimitedLogger(log)
        self._lock = threading.Lock()
        # counters: messages, transforms, rejected and malformed are kept by the topics' handlers (below),
        # bad and dropped messages by the events object they report to
        self._handlers: list[TfHandler] = []
        self._ingests: list[TfIngest] = []  # compiled ingests: told when the clock jumps back
        self._events = _Events(self._limiter, self._release_later)
        self._tail_timer: threading.Timer | None = None  # zentf.transport.heap release after a flood's tail
        self._tail_messages = 0
        self._tail_asked = False
        for name, value in (("max_frames", max_frames), ("max_frame_id_length", max_frame_id_length)):
            if value is self._UNSET:
                value = self.node.get_parameter_value(f"tf_{name}", self._UNSET)
            if value is not self._UNSET and hasattr(buffer, name):
                setattr(buffer, name, None if value is None or value == "" else int(value))
        if future_tolerance is self._UNSET:
            future_tolerance = self.node.get_parameter_value("tf_future_tolerance", DEFAULT_FUTURE_TOLERANCE)
        tol = _tolerance_ns(future_tolerance)
        self._guard = _FutureGuard(buffer, self.node.get_clock(), tol, self._limiter) if tol is not None else None
        self._tf_target = self._guard if self._guard is not None else buffer  # what tf samples go into
        self._subs: list[Any] = []
        self._tokens: list[Any] = []
        profile = self.node.wire  # zentf.transport.wire: key layout, payload format, authority
        self._tf_encoding = profile.encoding(TFMessage.TYPE_NAME)
        #: None where the wire carries the type in the key: the encoding is then not even read
        self._check_encoding = profile.check_tf_encoding
        #: where the wire carries no sender name (ROS 2): the one authority tf2_ros records for every transform
        self._senders = Senders(profile.authority, profile.fixed_authority, profile.sender_of, MAX_SENDER_KEY)
        self._authorities = self._senders.cache  # attachment bytes -> authority, shared by both topics
        self._thread: threading.Thread | None = None
        session = self.node.session
        static_key = self.node.topic_key(tf_static_topic, TFMessage.TYPE_NAME)
        self._subs.append(zx.declare_advanced_subscriber(
            session, static_key, self._handler(True, static_key),
            history=zx.HistoryConfig(detect_late_publishers=True)))
        self._declare_token(tf_static_topic, static_key, is_static=True)
        if not static_only:
            key = self.node.topic_key(tf_topic, TFMessage.TYPE_NAME)
            # Zenoh's thread fills a bounded ring; this listener's thread drains it into per-sender
            # queues and serves them in turn, so a flood delays only the flooder's own data
            sub = session.declare_subscriber(key, zenoh.handlers.RingChannel(RING_CAPACITY))
            self._subs.append(sub)
            self._declare_token(tf_topic, key)
            # the thread reads the ring through its handler object: undeclaring the subscriber while
            # the thread waits in sub.recv() fails ("Already borrowed") and leaves it blocked
            handler = self._handler(False, key)
            self._thread = threading.Thread(target=serve, args=(sub.handler, handler, _limits()), daemon=True,
                                            name=f"zentf-listener-{key}")
            self._thread.start()
            _LIVE.add(self)
        self._jump = self.node.get_clock().add_jump_callback(self._on_jump)
        self.node.add_on_shutdown(self.unregister)

    def _declare_token(self, topic: str, key: str, is_static: bool = False) -> None:
        if "*" not in topic:  # a liveliness token cannot hold a wildcard; '*/tf' listeners stay unlisted
            # depth 100 on both, as tf2_ros's DynamicListenerQoS / StaticListenerQoS
            self._tokens.append(self.node.declare_entity("sub", self.node.resolve_topic_name(topic),
                                                         TFMessage.TYPE_NAME, key=key, depth=100,
                                                         latched=is_static))

    def _release_later(self) -> None:
        """The ring ran empty in a flood's tail: release once no message came for TAIL_DELAY s."""
        with self._lock:
            if self._tail_timer is not None:
                self._tail_asked = True  # ran empty again: the timer looks once more if it was not quiet
            elif self._thread is not None:
                self._arm_tail()

    def _arm_tail(self) -> None:
        """(lock held)"""
        self._tail_messages = self.messages
        self._tail_asked = False
        self._tail_timer = threading.Timer(TAIL_DELAY, self._release_tail)
        self._tail_timer.daemon = True
        self._tail_timer.start()

    def _release_tail(self) -> None:
        with self._lock:
            if self._tail_timer is None:  # unregistered meanwhile
                return
            self._tail_timer = None
            if self._tail_messages != self.messages:  # not quiet: look again if the ring ran empty since
                if self._tail_asked and self._thread is not None:
                    self._arm_tail()
                return
        release_free_memory()
        log.debug("the tail of a burst of tf messages is over: freed memory released")

    def _handler(self, is_static: bool, key: str) -> TfHandler:
        """The object that decodes and inserts one message of a topic (compiled:
        zentf/transport/ingest/handler.pyx): ``handle(sample)``, True if something got into the buffer;
        never raises. It keeps this topic's counters (``messages``, ``transforms``, ``rejected``, ``malformed``)."""
        target = self.buffer if is_static else self._tf_target
        handler = TfHandler(self._ingest_of(target, is_static), self._senders, self._events, key,
                            self._check_encoding, self._tf_encoding)
        self._handlers.append(handler)
        return handler

    @property
    def messages(self) -> int:
        """TFMessages applied (fully or partly)."""
        return sum(h.messages for h in self._handlers)

    @property
    def transforms(self) -> int:
        """Transforms accepted by the buffer."""
        return sum(h.transforms for h in self._handlers)

    @property
    def rejected(self) -> int:
        """Well-formed transforms the buffer refused (NaN, bad quaternion, old data...)."""
        return sum(h.rejected for h in self._handlers)

    @property
    def malformed(self) -> int:
        """Transform elements with a bad shape."""
        return sum(h.malformed for h in self._handlers)

    def _ingest_of(self, target: Any, is_static: bool) -> Callable[[bytes, str], tuple]:
        """``ingest(payload, authority)`` of a topic: the wire's compiled ingest (zentf/transport/ingest/handler.pyx)
        into ``target``, with the future guard's check folded in."""
        guard = None if is_static else self._guard
        compiled = self.node.wire.tf_ingest(target, self.buffer, guard.now_ns if guard is not None else None,
                                            guard.tolerance_ns if guard is not None else 0, is_static)
        self._ingests.append(compiled)
        return compiled

    @property
    def bad_messages(self) -> int:
        """Payloads that were not a TFMessage at all."""
        return self._events.bad_messages

    @property
    def dropped(self) -> int:
        """tf messages dropped unread: a sender's backlog grew too big."""
        return self._events.dropped_messages

    def _on_jump(self, old: Any, new: Any) -> None:
        log.warning("Detected jump back in time of %.6fs. Clearing TF buffer.", (old - new).to_sec())
        for ingest in self._ingests:  # the future guard's last clock read is no longer "now"
            ingest.reset_clock()
        self.buffer.clear()

    def stats(self) -> dict[str, int]:
        with self._lock:
            return {"messages": self.messages, "transforms": self.transforms, "rejected": self.rejected,
                    "malformed": self.malformed, "bad_messages": self.bad_messages,
                    "future": self._guard.refused if self._guard is not None else 0, "dropped": self.dropped}

    def unregister(self) -> None:
        """Stop listening (the buffer keeps its data)."""
        self.node.get_clock().remove_jump_callback(self._jump)
        undeclare_all([*self._subs, *self._tokens])
        self._subs.clear()
        self._tokens.clear()
        thread, self._thread = self._thread, None
        with self._lock:
            timer, self._tail_timer = self._tail_timer, None
        if timer is not None:
            timer.cancel()
        _LIVE.discard(self)
        if thread is not None and thread is not threading.current_thread():
            thread.join(5)  # the undeclared ring wakes it at once
        if self._own_node and not self.node._closed:
            self.node.shutdown()

    close = unregister

    def __enter__(self) -> "TransformListener":
        return self

    def __exit__(self, *exc: object) -> None:
        self.unregister()


class StaticTransformListener(TransformListener):
    """Only ``tf_static`` (tf2_ros rolling)."""

    def __init__(self, buffer: Any, node: Node | None = None, **kw: Any) -> None:
        super().__init__(buffer, node, static_only=True, **kw)


def _limits() -> ServeLimits:
    """The tf thread's bounds: this module's constants (read when a listener starts)."""
    return ServeLimits(drain_batch=DRAIN_BATCH, max_pending=MAX_PENDING, max_pending_bytes=MAX_PENDING_BYTES,
                       suspect_after=SUSPECT_AFTER, suspect_queue=SUSPECT_QUEUE, max_senders=MAX_SENDERS,
                       release_after=RELEASE_AFTER, release_bytes=RELEASE_BYTES, tail_window=TAIL_WINDOW)


#: Listeners whose thread still runs. At exit they are stopped before the interpreter finalizes: a
#: daemon thread woken inside Zenoh during finalization would be unwound through Rust frames and
#: abort the process ("FATAL: exception not rethrown").
_LIVE: "weakref.WeakSet[TransformListener]" = weakref.WeakSet()


@atexit.register
def _stop_listeners() -> None:
    for listener in list(_LIVE):
        try:
            listener.unregister()
        except Exception:  # noqa: BLE001 - best effort on the way out
            pass
