"""Recording a node's topics into a bag and playing any bag back through a node with its timing.

Both go through the node's wire profile (raw subscriptions and publishers: zentf's wire, or ROS 2's
with ``--wire ros2``). ``Player`` plays every format zentf reads (see ``source.open_bag``): ROS names
become zentf topics (``/odom`` -> ``odom``), ROS payloads are re-encoded to zentf's msgpack wire form
(and, on a wire of other payloads, from it to the wire's; a rosbag2 bag's TFMessages go onto ROS 2's wire
as recorded, once the compiled reader has found them well-formed, other bags' from msgpack to CDR in C),
latched topics (``/tf_static``,
transient-local QoS, ROS 1 latching) go out through a cached advanced publisher. With ``clock_hz > 0``
it publishes ``/clock`` = the recorded (log) time, as ``ros2 bag play --clock`` does, in the time base
of the recording's tf stamps: a sim-time graph recorded by a wall-clock recorder (nav2 in Gazebo: stamps
~900 s, log times ~1.7e9 s) gets /clock in sim time, so nodes and tools on that clock see the data's time
and delays are delays.
"""
from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any

from ...core.messages import Clock, message_type
from ...core.text import printable
from ...transport.wire import codec as zentf_codec
from ...transport.ingest.tf_transcode import tf_msgpack_to_cdr
from ...transport.wire.ros2 import Ros2Profile
from ...transport.wire.zentf_wire import ZentfProfile
from .errors import BagError
from .native import BagMessage, rebase_key
from .source import CDR_TF, compiled_tf, open_bag

__all__ = ["Recorder", "Player", "PlayStats"]

log = logging.getLogger("zentf.tools.bag")

_NS = 1_000_000_000
_TF = "tf2_msgs/msg/TFMessage"
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
    """Records a node's topics (names, or patterns with '*' / '**' parts, of any type; latched history
    included) into a writer (BagWriter, or Ros2BagWriter for a ROS 2 graph's CDR), as the samples came."""

    def __init__(self, node: Any, writer: Any, topics: Sequence[str]) -> None:
        self.writer = writer
        self.errors = 0
        self._authority = node.wire.authority
        self._subs = [node.create_raw_subscription(t, self._on_sample, latched=True) for t in topics]

    def _on_sample(self, sample: Any) -> None:  # Zenoh thread: write, never raise
        try:
            sender = self._authority(sample.attachment, "") if sample.attachment is not None else ""
            self.writer.write(sample.key, sample.payload, sample.encoding, sender)
        except Exception as e:  # noqa: BLE001
            self.errors += 1
            log.debug("could not record a sample: %s", e)

    def close(self) -> None:
        for sub in self._subs:
            sub.destroy()
        self._subs.clear()


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

    def __init__(self, node: Any, path: str | os.PathLike, *, namespace: str = "", rate: float = 1.0,
                 clock_hz: float = 0.0, loop: bool = False, start: float = 0.0,
                 topics: Collection[str] | None = None,
                 on_skip: Callable[[str, str], None] | None = None,
                 stop: threading.Event | None = None) -> None:
        if not rate > 0:
            raise ValueError(f"rate must be > 0, got {rate}")
        if start < 0:
            raise ValueError(f"start must be >= 0, got {start}")
        self.node = node
        #: the bag's payloads are zentf's msgpack: sent as they are on zentf's wire, re-encoded on another
        self._as_recorded = node.wire.payload_format == ZentfProfile.payload_format
        #: on ROS 2's wire a rosbag2 bag's TFMessages go out as recorded (checked well-formed, not re-encoded),
        #: other bags' from their msgpack to CDR in C
        self._tf_as_cdr = node.wire.payload_format == Ros2Profile.payload_format
        self.compiled_tf_to_cdr = 0  # TFMessages written to CDR in C (tf_transcode.tf_msgpack_to_cdr)
        self.path = os.fspath(path)
        self.namespace = namespace.strip("/")
        self.rate = float(rate)
        self.clock_hz = float(clock_hz)
        self.loop = loop
        self.start = float(start)
        self.stop_event = stop or threading.Event()
        self.stats = PlayStats()
        self._pubs: dict[tuple[str, str], Any] = {}  # None: a channel the wire cannot carry (said once)
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

    def _pub_key(self, key: str, enc: str) -> tuple[str, str]:
        """A channel's publisher: per encoding when payloads go out as recorded, else one per key (a ROS 2
        bag's TFMessage goes out as its recorded CDR or, if doubtful, re-encoded: the same topic)."""
        return (key, enc if self._as_recorded else "")

    def _publisher(self, key: str, enc: str, type_name: str, latched: bool) -> Any:
        """The node's raw publisher of a channel (its topic is the key's, absolute); None when the wire
        cannot carry it (one line through on_skip)."""
        pk = self._pub_key(key, enc)
        if pk in self._pubs:
            return self._pubs[pk]
        try:
            pub = self.node.create_raw_publisher("/" + key, type_name, 1 if latched else 10, latched=latched,
                                                 encoding=enc if self._as_recorded else None)
        except ValueError as e:  # a name or a type the wire cannot carry
            pub = None
            self._skip(key, str(e))
        self._pubs[pk] = pub
        return pub

    def _skip(self, key: str, why: str) -> None:
        if self._on_skip is not None:
            self._on_skip("/" + key, why)
        else:
            log.warning("not played: /%s: %s", key, why)

    def _publish_clock(self, t_ns: int) -> None:
        if self._clock_pub is None:
            self._clock_pub = self.node.create_raw_publisher("/clock", Clock)
        sec, nsec = divmod(max(0, t_ns + self.clock_offset), _NS)
        self._clock_pub.publish_bytes(self.node.wire.encode({"clock": {"sec": sec, "nanosec": nsec}}, Clock.TYPE_NAME))
        self.stats.bag_time = t_ns

    def _send(self, m: BagMessage) -> None:
        key = rebase_key(m.key, m.namespace, self.namespace)
        pub = self._publisher(key, m.encoding, m.type_name, m.latched)
        if pub is None:
            return
        payload = m.payload
        if not self._as_recorded and m.encoding != CDR_TF:  # (a well-formed recorded CDR TFMessage goes as is)
            cdr = None
            if self._tf_as_cdr and m.type_name == _TF and compiled_tf():
                cdr = tf_msgpack_to_cdr(payload)  # in C; None: doubtful, re-encoded below (which says why)
            if cdr is not None:
                payload = cdr
                self.compiled_tf_to_cdr += 1
            else:
                try:
                    payload = self.node.wire.encode(zentf_codec.decode(payload, message_type(m.type_name)),
                                                    m.type_name)
                except (KeyError, ValueError, TypeError) as e:
                    self._pubs[self._pub_key(key, m.encoding)] = None
                    pub.destroy()
                    self._skip(key, f"cannot re-encode {m.type_name or 'an untyped message'} for this wire: {e}")
                    return
        if m.sender:
            pub.publish_as(payload, m.sender)
        else:
            pub.publish_bytes(payload)
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
            it = iter(reader.zentf(self.topics, self._on_skip, tf_as_cdr=self._tf_as_cdr))
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
        for pub in [*self._pubs.values(), self._clock_pub]:
            if pub is not None:
                pub.destroy()
        self._pubs.clear()
        self._clock_pub = None
