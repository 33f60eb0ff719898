"""Bags: record Zenoh topics to MCAP and play them back with their timing and an optional /clock.

File layout (MCAP, profile ``zentf``): one channel per (key expression, sending node); channel
``topic`` = the key expression, ``message_encoding`` = ``msgpack``; schema ``name`` = the carried
type (``tf2_msgs/msg/TFMessage``), encoding ``msgpack``, empty data; channel metadata holds
``encoding`` (the full Zenoh encoding), ``sender`` (the attachment = tf authority), ``latched``
(``true`` for ``tf_static``: played back through a cached advanced publisher so late joiners get it)
and ``namespace`` (the recorder's namespace, so a bag can be replayed under another one).
``log_time`` is the wall time of reception. Reading tolerates a truncated or corrupt file: bad
chunks are skipped, reading stops at the first unreadable record, and the problem is reported.
"""
from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, BinaryIO

__all__ = ["BagError", "BagMessage", "BagWriter", "BagReader", "Recorder", "Player", "bag_info",
           "rebase_key", "write_drones_demo", "PROFILE"]

log = logging.getLogger("zentf.tools.bag")

PROFILE = "zentf"
MESSAGE_ENCODING = "msgpack"
LATCHED_TOPICS = ("tf_static",)
_NS = 1_000_000_000


class BagError(Exception):
    """A bag file that cannot be opened or written; one line naming the file and the reason."""


@dataclass(slots=True)
class BagMessage:
    key: str
    type_name: str
    encoding: str
    sender: str
    latched: bool
    namespace: str
    log_time: int
    payload: bytes
    channel_id: int = 0


def is_latched_key(key: str) -> bool:
    return key.rsplit("/", 1)[-1] in LATCHED_TOPICS


def rebase_key(key: str, recorded_ns: str, play_ns: str) -> str:
    """A recorded key under the recorder's namespace moved under the player's; other keys unchanged."""
    rec = recorded_ns.strip("/")
    new = play_ns.strip("/")
    if rec == new:
        return key
    if rec:
        if key == rec or not key.startswith(rec + "/"):
            return key
        rest = key[len(rec) + 1:]
    else:
        if key == "clock":  # absolute topics recorded in the root namespace stay absolute
            return key
        rest = key
    return f"{new}/{rest}" if new else rest


class BagWriter:
    """Appends messages to an MCAP file; thread-safe; ``close()`` writes the summary (index + stats)."""

    def __init__(self, path: str | os.PathLike, *, namespace: str = "", chunk_size: int = 64 * 1024,
                 compression: str = "zstd") -> None:
        from mcap.writer import CompressionType, Writer

        self.path = os.fspath(path)
        self.namespace = namespace.strip("/")
        try:
            self._file: BinaryIO = open(self.path, "wb")
        except OSError as e:
            raise BagError(f"cannot write {self.path}: {e.strerror}") from None
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[compression]
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=comp)
        self._writer.start(profile=PROFILE, library="zentf")
        self._schemas: dict[str, int] = {}
        self._channels: dict[tuple[str, str, str], int] = {}
        self._seq: dict[int, int] = {}
        self._lock = threading.Lock()
        self._closed = False
        self.messages = 0
        self.payload_bytes = 0
        self.first_time: int | None = None
        self.last_time: int | None = None

    def _channel(self, key: str, encoding: str, sender: str, latched: bool | None) -> int:
        from zentf.wire import type_name_from_encoding

        ck = (key, encoding, sender)
        cid = self._channels.get(ck)
        if cid is not None:
            return cid
        type_name = type_name_from_encoding(encoding) or ""
        sid = self._schemas.get(type_name)
        if sid is None:
            sid = self._writer.register_schema(name=type_name, encoding=MESSAGE_ENCODING, data=b"") if type_name else 0
            self._schemas[type_name] = sid
        meta = {"encoding": encoding, "sender": sender,
                "latched": "true" if (is_latched_key(key) if latched is None else latched) else "false",
                "namespace": self.namespace}
        cid = self._writer.register_channel(topic=key, message_encoding=MESSAGE_ENCODING, schema_id=sid,
                                            metadata=meta)
        self._channels[ck] = cid
        return cid

    def write(self, key: str, payload: bytes, encoding: str, sender: str = "", log_time: int | None = None,
              latched: bool | None = None) -> None:
        t = time.time_ns() if log_time is None else int(log_time)
        with self._lock:
            if self._closed:
                return
            cid = self._channel(key, encoding, sender, latched)
            seq = self._seq.get(cid, 0)
            self._seq[cid] = seq + 1
            self._writer.add_message(channel_id=cid, log_time=t, data=payload, publish_time=t, sequence=seq)
            self.messages += 1
            self.payload_bytes += len(payload)
            if self.first_time is None:
                self.first_time = t
            self.last_time = t

    def flush(self) -> None:
        """Close the chunk in progress so a killed recorder loses at most what came after this call."""
        with self._lock:
            if not self._closed:
                self._writer.flush()

    @property
    def file_size(self) -> int:
        try:
            return self._file.tell()
        except (OSError, ValueError):
            return 0

    @property
    def duration(self) -> float:
        if self.first_time is None or self.last_time is None:
            return 0.0
        return (self.last_time - self.first_time) / 1e9

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                self._writer.finish()
            finally:
                self._file.close()

    def __enter__(self) -> "BagWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BagReader:
    """Iterates the messages of a bag in file order; ``problem`` says what was unreadable, if anything.

    Works on files without a summary (recorder killed) and on damaged files: a chunk that fails to
    decompress or whose records are garbled is skipped (``skipped_chunks``); a broken record frame
    ends the reading there.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self.problem: str | None = None
        self.skipped_chunks = 0
        self.messages_read = 0
        self.has_summary = False
        try:
            with open(self.path, "rb") as f:
                head = f.read(8)
        except OSError as e:
            raise BagError(f"cannot read {self.path}: {e.strerror}") from None
        if head != b"\x89MCAP0\r\n":
            raise BagError(f"{self.path} is not an MCAP bag (bad magic bytes)")

    def __iter__(self) -> Iterator[BagMessage]:
        from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
        from mcap.stream_reader import StreamReader, breakup_chunk

        self.problem = None
        self.skipped_chunks = 0
        self.messages_read = 0
        schemas: dict[int, str] = {}
        channels: dict[int, tuple[str, str, str, str, bool, str]] = {}
        for r in self._summary_records():  # channels of a damaged chunk are still known from the summary
            if isinstance(r, Schema):
                schemas[r.id] = r.name
        for r in self._summary_records():
            if isinstance(r, Channel):
                channels[r.id] = _channel_tuple(r, schemas)
        with open(self.path, "rb") as f:
            reader = StreamReader(f, emit_chunks=True, record_size_limit=1 << 31)
            records = reader.records
            while True:
                try:
                    rec = next(records)
                except StopIteration:
                    break
                except Exception as e:  # noqa: BLE001 - any parse failure ends the readable part
                    self.problem = _describe(e, f.tell(), os.path.getsize(self.path))
                    break
                inner: list[Any]
                if isinstance(rec, Chunk):
                    try:
                        inner = breakup_chunk(rec, validate_crc=True)
                    except Exception as e:  # noqa: BLE001 - a damaged chunk: skip it, go on
                        self.skipped_chunks += 1
                        self.problem = f"skipped a damaged chunk ({_short(e)})"
                        continue
                else:
                    inner = [rec]
                for r in inner:
                    if isinstance(r, Message):
                        ch = channels.get(r.channel_id)
                        if ch is None:
                            continue
                        self.messages_read += 1
                        yield BagMessage(ch[0], ch[1], ch[2], ch[3], ch[4], ch[5], r.log_time, bytes(r.data),
                                         r.channel_id)
                    elif isinstance(r, Channel):
                        channels[r.id] = _channel_tuple(r, schemas)
                    elif isinstance(r, Schema):
                        schemas[r.id] = r.name
                    elif isinstance(r, (DataEnd, Footer)):
                        self.has_summary = True
                if isinstance(rec, (DataEnd, Footer)):
                    break
        if not self.has_summary and self.problem is None:
            self.problem = "no summary (the recorder did not close the file)"


    def _summary_records(self) -> list[Any]:
        """Schema and channel records of the summary section; [] without a (readable) summary."""
        from mcap.records import Channel, Schema
        from mcap.stream_reader import StreamReader

        try:
            size = os.path.getsize(self.path)
            with open(self.path, "rb") as f:
                if size < 8 + 37:
                    return []
                f.seek(size - 8 - 37)
                footer = f.read(37)
                if footer[0] != 0x02:  # Footer opcode
                    return []
                summary_start = int.from_bytes(footer[9:17], "little")
                if not 0 < summary_start < size:
                    return []
                f.seek(summary_start)
                out = []
                for r in StreamReader(f, skip_magic=True, record_size_limit=1 << 28).records:
                    if isinstance(r, (Schema, Channel)):
                        out.append(r)
                    elif not out and type(r).__name__ not in ("Schema", "Channel"):
                        continue
                    if type(r).__name__ == "Footer":
                        break
                return out
        except Exception:  # noqa: BLE001 - no usable summary
            return []


def _channel_tuple(r: Any, schemas: dict[int, str]) -> tuple[str, str, str, str, bool, str]:
    md = dict(r.metadata or {})
    tn = schemas.get(r.schema_id, "")
    enc = md.get("encoding") or (f"application/msgpack;{tn}" if tn else "application/msgpack")
    return (r.topic, tn, enc, md.get("sender", ""), md.get("latched", "false") == "true", md.get("namespace", ""))


def _short(e: BaseException) -> str:
    text = str(e).strip().splitlines()[0] if str(e).strip() else ""
    return f"{type(e).__name__}: {text}"[:120] if text else type(e).__name__


def _describe(e: BaseException, pos: int, size: int) -> str:
    from mcap.exceptions import EndOfFile

    if isinstance(e, EndOfFile) or pos >= size:
        return f"truncated at byte {size}"
    return f"corrupt record near byte {pos} ({_short(e)})"


@dataclass
class TopicInfo:
    key: str
    type_name: str
    count: int = 0
    latched: bool = False
    first: int = 0
    last: int = 0
    senders: set[str] = field(default_factory=set)


def bag_info(path: str | os.PathLike) -> dict[str, Any]:
    """Counts per topic, time span, size and any problem, by reading the whole file."""
    reader = BagReader(path)
    topics: dict[str, TopicInfo] = {}
    first = last = None
    total = 0
    for m in reader:
        t = topics.get(m.key)
        if t is None:
            t = topics[m.key] = TopicInfo(m.key, m.type_name, latched=m.latched, first=m.log_time)
        t.count += 1
        t.first = min(t.first, m.log_time)
        t.last = max(t.last, m.log_time)
        t.senders.add(m.sender)
        total += 1
        first = m.log_time if first is None else min(first, m.log_time)
        last = m.log_time if last is None else max(last, m.log_time)
    duration = (last - first) / 1e9 if first is not None and last is not None else 0.0
    return {
        "path": reader.path, "size": os.path.getsize(reader.path), "messages": total,
        "start": first / 1e9 if first is not None else None, "end": last / 1e9 if last is not None else None,
        "duration": duration, "complete": reader.problem is None, "problem": reader.problem,
        "skipped_chunks": reader.skipped_chunks,
        "topics": [{"key": t.key, "type": t.type_name, "count": t.count, "latched": t.latched,
                    "frequency": ((t.count - 1) * 1e9 / (t.last - t.first)
                                  if t.last > t.first and not t.latched else None),
                    "senders": sorted(s for s in t.senders if s)}
                   for t in sorted(topics.values(), key=lambda t: t.key)],
    }


# ---------------------------------------------------------------- transport (Zenoh) side

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
                from zentf.wire import authority_of

                sender = authority_of(att, "")
            self.writer.write(key, sample.payload.to_bytes(), str(sample.encoding), sender)
        except Exception as e:  # noqa: BLE001
            self.errors += 1
            log.debug("could not record a sample: %s", e)

    def close(self) -> None:
        for obj in [*self._subs, *self._tokens]:
            try:
                obj.undeclare()
            except Exception:  # noqa: BLE001
                pass
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
    """Republishes a bag with the original inter-message timing (scaled by ``rate``).

    With ``clock_hz > 0`` it also publishes ``/clock`` = bag time, so sim-time nodes follow the
    recording (recorded ``/clock`` messages are then not replayed). Latched channels go out through a
    cached advanced publisher and so still reach subscribers that join later.
    """

    def __init__(self, session: Any, path: str | os.PathLike, *, namespace: str = "", rate: float = 1.0,
                 clock_hz: float = 0.0, loop: bool = False, start: float = 0.0,
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
        BagReader(self.path)  # fail early on a missing or non-MCAP file

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

        from zentf import wire
        from zentf.core.messages import Clock

        if self._clock_pub is None:
            self._clock_pub = self.session.declare_publisher(
                "clock", encoding=wire.encoding_for(Clock.TYPE_NAME), congestion_control=zenoh.CongestionControl.BLOCK)
            if self._declare_token is not None:
                self._tokens.append(self._declare_token(Clock.TYPE_NAME, "clock"))
        sec, nsec = divmod(max(0, t_ns), _NS)
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
            if self.stop_event.wait(max(0.0, nxt - time.monotonic())):
                return False

    def play(self, progress: Callable[[PlayStats], None] | None = None) -> PlayStats:
        """Play once (or until stopped with ``loop``); returns the counts and any file problem."""
        skip_clock = self.clock_hz > 0
        last_report = time.monotonic()
        while not self.stop_event.is_set():
            reader = BagReader(self.path)
            it = iter(reader)
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
            while pending is not None:
                m = pending
                if not (skip_clock and m.key == "clock"):
                    due = wall0 + (m.log_time - begin) / _NS / self.rate
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
        for obj in [*self._pubs.values(), *self._tokens, self._clock_pub]:
            if obj is None:
                continue
            try:
                obj.undeclare()
            except Exception:  # noqa: BLE001
                pass
        self._pubs.clear()
        self._tokens.clear()
        self._clock_pub = None


# ---------------------------------------------------------------- demo recording (no Zenoh needed)

def write_drones_demo(path: str | os.PathLike, duration: float = 10.0, *, tf_rate: float = 50.0,
                      marker_rate: float = 5.0, trail_length: int = 50, start: float = 1_700_000_000.0) -> dict[str, Any]:
    """A recording of the drones demo, computed from its closed-form model (same messages, same topics).

    tf at ``tf_rate`` (av1, av2 in world, stamped t), ``visual_markers`` trails at ``marker_rate``
    (as plots_publisher draws them) and a latched tf_static ``world -> ground``; root namespace.
    """
    from nodes.frames_publisher import av2_in_av1, drone_poses
    from zentf import wire
    from zentf.core.messages import (ColorRGBA, Header, Marker, MarkerArray, Point, Quaternion, TFMessage, Transform,
                                TransformStamped, Vector3)
    from zentf.core.time import Time

    def tf_msg(t_ns: int, poses: list) -> bytes:
        stamp = Time(nanoseconds=t_ns)
        return wire.encode_tf([TransformStamped(header=Header(stamp=stamp, frame_id=p), child_frame_id=c,
                                                transform=Transform(Vector3(*tr), Quaternion(*q)))
                               for p, c, tr, q in poses])

    tf_enc = f"application/msgpack;{TFMessage.TYPE_NAME}"
    mk_enc = f"application/msgpack;{MarkerArray.TYPE_NAME}"
    colors = ((1.0, 0.2, 0.2, 1.0), (0.2, 0.4, 1.0, 1.0), (0.2, 0.9, 0.2, 1.0))
    names = (("world", "av1"), ("world", "av2"), ("av1", "av2"))
    trails: list[list[Point]] = [[], [], []]
    t0 = int(start * _NS)
    n_tf = int(duration * tf_rate) + 1
    tf_step = int(_NS / tf_rate)
    mk_every = max(1, round(tf_rate / marker_rate))
    with BagWriter(path, chunk_size=16 * 1024) as w:
        w.write("tf_static", tf_msg(t0, [("world", "ground", (0.0, 0.0, -0.5), (0.0, 0.0, 0.0, 1.0))]),
                tf_enc, "/demo_static", t0)
        for i in range(n_tf):
            t_ns = t0 + i * tf_step
            ts = t_ns / _NS
            poses = drone_poses(ts)
            w.write("tf", tf_msg(t_ns, poses), tf_enc, "/frames_publisher", t_ns + 200_000)
            if i % mk_every:
                continue
            rel = av2_in_av1(ts)
            pts = [poses[0][2], poses[1][2], rel]
            markers = []
            for k in range(3):
                trails[k].append(Point(*pts[k]))
                del trails[k][:-trail_length]
                markers.append(Marker(header=Header(stamp=Time(nanoseconds=t_ns), frame_id=names[k][0]), ns="trails",
                                      id=k, type=Marker.LINE_STRIP, action=Marker.ADD, scale=Vector3(0.02, 0.0, 0.0),
                                      color=ColorRGBA(*colors[k]), points=list(trails[k]),
                                      text=f"{names[k][1]} in {names[k][0]}"))
            w.write("visual_markers", wire.encode(MarkerArray(markers=markers)), mk_enc, "/plots_publisher",
                    t_ns + 500_000)
    return bag_info(path)
