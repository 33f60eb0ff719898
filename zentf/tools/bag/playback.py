"""Recording Zenoh topics into a bag and playing any bag back over Zenoh with its timing.

``Player`` plays every format zentf reads (see ``source.open_bag``): ROS names become zentf topics
(``/odom`` -> ``odom``), ROS payloads are re-encoded to zentf's msgpack wire form, latched
topics (``/tf_static``, transient-local QoS, ROS 1 latching) go out through a cached advanced
publisher. With ``clock_hz > 0`` it publishes ``/clock`` = the recorded (log) time, as
``ros2 bag play --clock`` does, in the time base of the recording's tf stamps: a sim-time graph recorded
by a wall-clock recorder (nav2 in Gazebo: stamps ~900 s, log times ~1.7e9 s) gets /clock in sim time,
so nodes and tools on that clock see the data's time and delays are delays.
"""
from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any

from ...core.text import printable
from ...transport.entities import undeclare_all
from .errors import BagError
from .native import BagMessage, BagWriter, rebase_key
from .source import open_bag

__all__ = ["Recorder", "Player", "PlayStats"]

log = logging.getLogger("zentf.tools.bag")

_NS = 1_000_000_000
#: the longest single wait (a wait past ``threading.TIMEOUT_MAX`` raises OverflowError)
_MAX_WAIT = 3600.0
#: a message due further into the play than this (seconds of wall time) is refused, not waited for
_MAX_PLAY = 100 * 365.25 * 86400.0
#: tf stamps this far from their log times are in another time base (sim time recorded with a wall
#: clock), not late: network and recorder delays are milliseconds, clock skew seconds.
CLOCK_BASE_GAP = 60 * _NS
#: How many messages from the start are searched for a tf message to compare stamps with log times.
_CLOCK_BASE_SCAN = 5000


class Recorder:
    """Subscribes to key expressions (advanced subscribers: latched history included) into a BagWriter."""

    def __init__(self, session: Any, writer: BagWriter, keys: Sequence[str],
                 declare_token: Callable[[str], Any] | None = None) -> None:
        import zenoh.ext as zx

        self.writer = writer
        self.errors = 0
        self._subs: list[Any] = []
        self._tokens: list[Any] = []
        for key in keys:
            self._subs.append(zx.declare_advanced_subscriber(
                session, key, self._on_sample, history=zx.HistoryConfig(detect_late_publishers=True)))
            if declare_token is not None:
                self._tokens.append(declare_token(key))

    def _on_sample(self, sample: Any) -> None:  # Zenoh thread: copy and write, never raise
        try:
            key = str(sample.key_expr)
            att = sample.attachment
            sender = ""
            if att is not None:
                from zentf.transport.wire.codec import authority_of

                sender = authority_of(att, "")
            self.writer.write(key, sample.payload.to_bytes(), str(sample.encoding), sender)
        except Exception as e:  # noqa: BLE001
            self.errors += 1
            log.debug("could not record a sample: %s", e)

    def close(self) -> None:
        undeclare_all([*self._subs, *self._tokens])
        self._subs.clear()
        self._tokens.clear()


@dataclass
class PlayStats:
    messages: int = 0
    loops: int = 0
    bag_start: int | None = None
    bag_time: int | None = None
    problem: str | None = None


class Player:
    """Republishes a bag (any format) with the original inter-message timing (scaled by ``rate``).

    With ``clock_hz > 0`` it also publishes ``/clock`` = bag time, so sim-time nodes follow the
    recording (recorded ``/clock`` messages are then not replayed). Latched channels go out through a
    cached advanced publisher and so still reach subscribers that join later.
    """

    def __init__(self, session: Any, path: str | os.PathLike, *, namespace: str = "", rate: float = 1.0,
                 clock_hz: float = 0.0, loop: bool = False, start: float = 0.0,
                 topics: Collection[str] | None = None,
                 on_skip: Callable[[str, str], None] | None = None,
                 declare_token: Callable[[str, str], Any] | None = None,
                 stop: threading.Event | None = None) -> None:
        if not rate > 0:
            raise ValueError(f"rate must be > 0, got {rate}")
        if start < 0:
            raise ValueError(f"start must be >= 0, got {start}")
        self.session = session
        self.path = os.fspath(path)
        self.namespace = namespace.strip("/")
        self.rate = float(rate)
        self.clock_hz = float(clock_hz)
        self.loop = loop
        self.start = float(start)
        self._declare_token = declare_token
        self.stop_event = stop or threading.Event()
        self.stats = PlayStats()
        self._pubs: dict[tuple[str, str], Any] = {}
        self._tokens: list[Any] = []
        self._clock_pub: Any = None
        self.topics = topics
        self._on_skip = on_skip
        self.bag = open_bag(self.path)  # fails early on a missing file or an unknown format
        #: ns added to log times for /clock (0, or the distance to the tf stamps' time base)
        self.clock_offset = self._stamp_base_offset() if self.clock_hz > 0 else 0

    def _stamp_base_offset(self) -> int:
        """0, or (tf header stamp - log time) of the first tf message when that is more than CLOCK_BASE_GAP."""
        from zentf.transport.wire.codec import unpack

        for i, m in enumerate(self.bag.zentf(None, None)):
            if i >= _CLOCK_BASE_SCAN:
                break
            if m.latched or m.type_name != "tf2_msgs/msg/TFMessage" or m.key.rsplit("/", 1)[-1] != "tf":
                continue
            try:
                stamps = [t["header"]["stamp"] for t in unpack(m.payload)["transforms"]]
                stamp = max(st["sec"] * _NS + st["nanosec"] for st in stamps)
            except (ValueError, KeyError, TypeError):
                continue
            gap = stamp - m.log_time
            return gap if abs(gap) > CLOCK_BASE_GAP else 0
        return 0

    def _publisher(self, key: str, enc: str, type_name: str, latched: bool) -> Any:
        pk = (key, enc)
        pub = self._pubs.get(pk)
        if pub is not None:
            return pub
        import zenoh
        import zenoh.ext as zx

        encoding = zenoh.Encoding(enc)
        if latched:
            pub = zx.declare_advanced_publisher(self.session, key, encoding=encoding,
                                                cache=zx.CacheConfig(max_samples=1), publisher_detection=True)
        else:
            pub = self.session.declare_publisher(key, encoding=encoding,
                                                 congestion_control=zenoh.CongestionControl.BLOCK)
        self._pubs[pk] = pub
        if self._declare_token is not None:
            self._tokens.append(self._declare_token(type_name, key))
        return pub

    def _publish_clock(self, t_ns: int) -> None:
        import zenoh

        from zentf.transport.wire import codec as wire
        from zentf.core.messages import Clock

        if self._clock_pub is None:
            self._clock_pub = self.session.declare_publisher(
                "clock", encoding=wire.encoding_for(Clock.TYPE_NAME), congestion_control=zenoh.CongestionControl.BLOCK)
            if self._declare_token is not None:
                self._tokens.append(self._declare_token(Clock.TYPE_NAME, "clock"))
        sec, nsec = divmod(max(0, t_ns + self.clock_offset), _NS)
        self._clock_pub.put(wire.pack({"clock": {"sec": sec, "nanosec": nsec}}))
        self.stats.bag_time = t_ns

    def _send(self, m: BagMessage) -> None:
        key = rebase_key(m.key, m.namespace, self.namespace)
        pub = self._publisher(key, m.encoding, m.type_name, m.latched)
        if m.sender:
            pub.put(m.payload, attachment=m.sender.encode())
        else:
            pub.put(m.payload)
        self.stats.messages += 1

    def _wait_until(self, deadline: float, clock_base: tuple[float, int]) -> bool:
        """Sleep until the monotonic ``deadline``, publishing /clock ticks meanwhile; False if stopped."""
        wall0, bag0 = clock_base
        period = 1.0 / self.clock_hz if self.clock_hz > 0 else None
        while True:
            now = time.monotonic()
            if self.stop_event.is_set():
                return False
            if now >= deadline:
                return True
            nxt = deadline
            if period is not None:
                self._publish_clock(bag0 + int((now - wall0) * self.rate * _NS))
                nxt = min(deadline, now + period)
            if self.stop_event.wait(min(max(0.0, nxt - time.monotonic()), _MAX_WAIT)):
                return False

    def play(self, progress: Callable[[PlayStats], None] | None = None) -> PlayStats:
        """Play once (or until stopped with ``loop``); returns the counts and any file problem."""
        skip_clock = self.clock_hz > 0
        last_report = time.monotonic()
        while not self.stop_event.is_set():
            reader = self.bag
            it = iter(reader.zentf(self.topics, self._on_skip))
            first: BagMessage | None = next(it, None)
            if first is None:
                self.stats.problem = reader.problem
                break
            begin = first.log_time + int(self.start * _NS)
            self.stats.bag_start = begin
            latched_before: dict[tuple[str, str], BagMessage] = {}
            pending: BagMessage | None = first
            # Messages before --start are skipped, except the last of each latched channel.
            while pending is not None and pending.log_time < begin:
                if pending.latched:
                    latched_before[(pending.key, pending.sender)] = pending
                pending = next(it, None)
            if skip_clock:
                self._publish_clock(begin)
            for m in latched_before.values():
                self._send(m)
            wall0 = time.monotonic()
            base = (wall0, begin)
            index = 0
            while pending is not None:
                m = pending
                index += 1
                if not (skip_clock and m.key == "clock"):
                    after = (m.log_time - begin) / _NS / self.rate
                    if after > _MAX_PLAY:
                        raise BagError(f"{printable(self.path)}: message {index} of the play (/{printable(m.key, 200)}, logged "
                                       f"at {m.log_time} ns) is due {after:.4g} s after the first at rate "
                                       f"{self.rate:g}: more than a century (a damaged or forged log time?)")
                    due = wall0 + after
                    if not self._wait_until(due, base):
                        break
                    if skip_clock:
                        self._publish_clock(max(m.log_time, self.stats.bag_time or 0))
                    self._send(m)
                    self.stats.bag_time = m.log_time
                if progress is not None and time.monotonic() - last_report >= 1.0:
                    last_report = time.monotonic()
                    progress(self.stats)
                pending = next(it, None)
            self.stats.problem = reader.problem
            if not self.loop or self.stop_event.is_set():
                break
            self.stats.loops += 1
        return self.stats

    def close(self) -> None:
        undeclare_all([*self._pubs.values(), *self._tokens, self._clock_pub])
        self._pubs.clear()
        self._tokens.clear()
        self._clock_pub = None
