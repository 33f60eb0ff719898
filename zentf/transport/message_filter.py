"""MessageFilter: hold stamped messages until they can be transformed into the target frame(s)."""
from __future__ import annotations

import enum
import logging
import threading
import time as _time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from .node import Node, Subscription
from ..core.text import printable
from ..core.time import Time, to_duration

__all__ = ["MessageFilter", "FilterFailureReason"]

log = logging.getLogger("zentf.transport.message_filter")


class FilterFailureReason(enum.Enum):
    """tf2_ros names and texts of why a message was dropped."""

    Unknown = "unknown"
    OutTheBack = "the timestamp on the message is earlier than all the data in the transform cache"
    EmptyFrameID = "the frame id of the message is empty"
    NoTransformFound = ("did not find a valid transform, this usually happens at startup or when a "
                        "transform is not published (timed out)")
    QueueFull = "discarding message because the queue is full"


class _Pending:
    __slots__ = ("msg", "frame", "stamp", "deadline")

    def __init__(self, msg: Any, frame: str, stamp: Time, deadline: float | None) -> None:
        self.msg, self.frame, self.stamp, self.deadline = msg, frame, stamp, deadline


class MessageFilter:
    """MessageFilter(source, buffer, target_frame, queue_size=10, timeout=None).

    ``source`` is a Subscription (the filter takes over its callback), a topic name (with ``node=``
    and ``msg_type=``), or None (call ``add(msg)`` yourself). ``MessageFilter(node, topic, msg_type,
    buffer, target_frame, ...)`` works too. Messages wait without polling: every buffer insert
    re-checks them. Each is delivered to the callbacks once transformable into every target frame,
    or dropped with a FilterFailureReason (failure callbacks get ``(msg, reason)``; a log line says why).
    ``timeout`` (seconds, wall clock) bounds the wait; None waits until the queue pushes it out.
    Callbacks run on the node's executor thread when there is a node.
    """

    def __init__(self, source: Any = None, buffer: Any = None, target_frame: str | Sequence[str] | None = None,
                 queue_size: int = 10, timeout: Any = None, *args: Any, node: Node | None = None,
                 msg_type: Any = None, callback: Callable[[Any], None] | None = None,
                 failure_callback: Callable[[Any, FilterFailureReason], None] | None = None,
                 tolerance: float = 0.0) -> None:
        if isinstance(source, Node):  # MessageFilter(node, topic, msg_type, buffer, target, ...)
            node, topic, msg_type, buffer, target_frame = source, buffer, target_frame, queue_size, timeout
            rest = list(args)
            queue_size = rest.pop(0) if rest else 10
            timeout = rest.pop(0) if rest else None
            source = topic
        if buffer is None or target_frame is None:
            raise TypeError("MessageFilter needs a buffer and a target frame")
        self.buffer = buffer
        self.set_target_frames(target_frame)
        self.queue_size = int(queue_size)
        self.timeout = None if timeout is None else to_duration(timeout).to_sec()
        self.tolerance_ns = to_duration(tolerance).nanoseconds
        self._callbacks: list[Callable[[Any], None]] = [callback] if callback else []
        self._failure_callbacks: list[Callable[[Any, FilterFailureReason], None]] = (
            [failure_callback] if failure_callback else [])
        self.delivered = 0
        self.dropped: dict[FilterFailureReason, int] = {r: 0 for r in FilterFailureReason}
        self._pending: deque[_Pending] = deque()
        self._cond = threading.Condition()
        self._kicked = False
        self._closed = False
        self.subscription: Subscription | None = None
        if isinstance(source, Subscription):
            self.subscription = source
            node = node or source.node
            source.callback = self.add
        elif isinstance(source, str):
            if node is None or msg_type is None:
                raise TypeError("MessageFilter on a topic name needs node= and msg_type=")
            self.subscription = node.create_subscription(source, msg_type, self.add)
        elif source is not None:
            raise TypeError(f"MessageFilter source must be a Subscription, a topic name or None, "
                            f"got {type(source).__name__}")
        self.node = node
        if node is not None:
            node.add_on_shutdown(self.close)
        buffer.add_insert_callback(self._kick)
        self._worker = threading.Thread(target=self._run, name="zentf-message-filter", daemon=True)
        self._worker.start()

    # ---- configuration (tf2_ros names)
    def set_target_frames(self, frames: str | Sequence[str]) -> None:
        names = [frames] if isinstance(frames, str) else list(frames)
        self.target_frames = [f[1:] if f.startswith("/") else f for f in names]

    set_target_frame = set_target_frames

    def set_tolerance(self, tolerance: Any) -> None:
        self.tolerance_ns = to_duration(tolerance).nanoseconds

    def set_queue_size(self, n: int) -> None:
        self.queue_size = int(n)

    def register_callback(self, cb: Callable[[Any], None]) -> None:
        self._callbacks.append(cb)

    def register_failure_callback(self, cb: Callable[[Any, FilterFailureReason], None]) -> None:
        self._failure_callbacks.append(cb)

    registerCallback = register_callback
    registerFailureCallback = register_failure_callback

    # ---- flow
    def add(self, msg: Any) -> None:
        """Offer a stamped message (anything with ``header.frame_id`` and ``header.stamp``)."""
        try:
            frame = msg.header.frame_id
            stamp = msg.header.stamp
        except AttributeError:
            self._drop(msg, "?", Time(), FilterFailureReason.Unknown)
            return
        frame = frame[1:] if frame.startswith("/") else frame
        if not frame:
            self._drop(msg, frame, stamp, FilterFailureReason.EmptyFrameID)
            return
        deadline = None if self.timeout is None else _time.monotonic() + self.timeout
        overflow: list[_Pending] = []
        with self._cond:
            self._pending.append(_Pending(msg, frame, stamp, deadline))
            while self.queue_size > 0 and len(self._pending) > self.queue_size:
                overflow.append(self._pending.popleft())
            self._kicked = True
            self._cond.notify()
        for p in overflow:
            self._drop(p.msg, p.frame, p.stamp, FilterFailureReason.QueueFull)

    def clear(self) -> None:
        with self._cond:
            self._pending.clear()

    def _kick(self) -> None:  # buffer insert callback: keep it tiny (runs on the listener thread)
        with self._cond:
            if self._pending:
                self._kicked = True
                self._cond.notify()

    def _status(self, p: _Pending) -> bool | FilterFailureReason:
        """True if transformable; a reason if it never will be; False to keep waiting."""
        times = [p.stamp] if not self.tolerance_ns else [p.stamp, Time(nanoseconds=p.stamp.nanoseconds
                                                                          + self.tolerance_ns)]
        for target in self.target_frames:
            for t in times:
                ok, why = self.buffer.can_transform(target, p.frame, t, return_debug_tuple=True)
                if not ok:
                    if "into the past" in why:
                        return FilterFailureReason.OutTheBack
                    return False
        return True

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._kicked and not self._closed:
                    deadlines = [p.deadline for p in self._pending if p.deadline is not None]
                    wait = None if not deadlines else max(0.0, min(deadlines) - _time.monotonic())
                    if wait == 0.0:
                        break
                    if not self._cond.wait(wait) and wait is not None:
                        break
                if self._closed:
                    return
                self._kicked = False
                pending = list(self._pending)
            ready: list[_Pending] = []
            failed: list[tuple[_Pending, FilterFailureReason]] = []
            now = _time.monotonic()
            for p in pending:
                try:
                    st = self._status(p)
                except Exception:
                    st = FilterFailureReason.Unknown
                if st is True:
                    ready.append(p)
                elif st is not False:
                    failed.append((p, st))
                elif p.deadline is not None and now >= p.deadline:
                    failed.append((p, FilterFailureReason.NoTransformFound))
            if ready or failed:
                done = {id(p) for p in ready} | {id(p) for p, _ in failed}
                with self._cond:
                    self._pending = deque(p for p in self._pending if id(p) not in done)
                for p in ready:
                    self._deliver(p.msg)
                for p, why in failed:
                    self._drop(p.msg, p.frame, p.stamp, why)

    def _dispatch(self, fn: Callable[[], None]) -> None:
        if self.node is not None and not self.node._closed:
            self.node._post(fn)
        else:
            fn()

    def _deliver(self, msg: Any) -> None:
        self.delivered += 1
        for cb in list(self._callbacks):
            self._dispatch(lambda cb=cb: cb(msg))

    def _drop(self, msg: Any, frame: str, stamp: Any, reason: FilterFailureReason) -> None:
        self.dropped[reason] += 1
        secs = stamp.to_sec() if hasattr(stamp, "to_sec") else stamp
        log.info("Message Filter dropping message: frame '%s' at time %.3f for reason '%s'",
                 printable(frame), secs, reason.name)
        for cb in list(self._failure_callbacks):
            self._dispatch(lambda cb=cb: cb(msg, reason))

    def close(self) -> None:
        """Stop the filter (pending messages are discarded)."""
        self.buffer.remove_insert_callback(self._kick)
        with self._cond:
            self._closed = True
            self._pending.clear()
            self._cond.notify()
        if threading.current_thread() is not self._worker:
            self._worker.join(timeout=2)

    def __enter__(self) -> "MessageFilter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
