"""One reading interface over every bag zentf reads: ``open_bag(path)``.

``Bag.raw()`` gives (topic, type, latched, sender, log_time, payload) without decoding; ``Bag.zentf()``
gives zentf BagMessages (ROS names mapped to zentf topics, ``/odom`` -> ``odom``; payloads
re-encoded to zentf's msgpack wire form); ``Bag.tf()`` gives /tf and /tf_static as rows for a
BufferCore. A topic whose type cannot be decoded is skipped and reported once through ``on_skip``.
"""
from __future__ import annotations

import functools
import logging
import os
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import BagError
from .formats import BagFormat, detect_format
from .native import BagMessage, BagReader, rebase_key

__all__ = ["Bag", "RawMessage", "open_bag", "zentf_topic", "TF_TOPICS", "CDR_TF"]

log = logging.getLogger("zentf.tools.bag")

#: topic base names that carry transforms (dynamic, static)
TF_TOPICS = ("tf", "tf_static")
#: the encoding of a BagMessage that carries a rosbag2 TFMessage's recorded CDR (``zentf(tf_as_cdr=True)``)
CDR_TF = "cdr;tf2_msgs/msg/TFMessage"
#: TFMessages of ROS bags go to msgpack through the compiled writers (tests switch it off for the reference)
COMPILED_TF = True


def compiled_tf() -> bool:
    """Whether TFMessages take the compiled writers (``COMPILED_TF``, read when asked)."""
    return COMPILED_TF


def zentf_topic(ros_name: str) -> str:
    """ROS topic name -> zentf topic (key expression relative to the root): '/odom' -> 'odom'."""
    return ros_name.strip("/")


@dataclass(slots=True)
class RawMessage:
    topic: str       # as the bag names it ('/tf' in ROS bags, 'tf' in zentf bags)
    type_name: str
    latched: bool
    sender: str
    log_time: int
    payload: bytes   # in the bag's own encoding
    conn: Any = None


def _matches(name: str, want: set[str] | None) -> bool:
    return want is None or name.strip("/") in want


class Bag:
    """A recording of any supported format; see the module docstring."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.format, self.path = detect_format(path)
        self.display = os.fspath(path)
        self.problem: str | None = None
        self.skipped_chunks = 0
        self.skipped: dict[str, str] = {}  # topic -> why it is not decoded
        self._ros: Any = None
        self._tf_layout: bool | None = None  # the bag's TFMessage is laid out as ROS's (None: not looked yet)
        self.compiled_tf = 0  # TFMessages zentf() wrote through the compiled path
        if self.format is BagFormat.ZENTF:
            BagReader(self.path)  # fails early on a missing or non-MCAP file
        else:
            from .ros import RosBag

            self._ros = RosBag(self.path, self.format)

    @property
    def ros(self) -> Any:
        """The RosBag (rosbags typestore) of a ROS recording; None for a zentf bag."""
        return self._ros

    # ------------------------------------------------------------------ raw

    def raw(self, topics: Collection[str] | None = None) -> Iterator[RawMessage]:
        """Every message undecoded, in file order; ``topics`` match with or without a leading '/'."""
        want = None if topics is None else {t.strip("/") for t in topics}
        if self._ros is None:
            reader = BagReader(self.path)
            for m in reader:  # a name matches the key or the key relative to the recorder's namespace
                if _matches(m.key, want) or (m.namespace and _matches(rebase_key(m.key, m.namespace, ""), want)):
                    yield RawMessage(m.key, m.type_name, m.latched, m.sender, m.log_time, m.payload, m)
            self.problem, self.skipped_chunks = reader.problem, reader.skipped_chunks
            return
        ros = self._ros
        for conn, t, raw in ros.messages():
            if _matches(conn.topic, want):
                yield RawMessage(conn.topic, conn.msgtype, conn.latched, conn.callerid, t, raw, conn)
        self.problem, self.skipped_chunks = ros.problem, ros.skipped_chunks

    # ------------------------------------------------------------------ decoded

    def _skip(self, topic: str, why: str, on_skip: Callable[[str, str], None] | None) -> None:
        if topic in self.skipped:
            return
        self.skipped[topic] = why
        if on_skip is not None:
            on_skip(topic, why)
        else:
            log.warning("skipping %s: %s", topic, why)

    def decode(self, m: RawMessage) -> Any:
        """A ROS message as zentf's plain dict; ValueError says why it cannot be decoded."""
        from .plain import to_plain

        why = self._ros.ensure_type(m.conn)
        if why:
            raise ValueError(why)
        try:
            return to_plain(self._ros.deserialize(m.payload, m.type_name), self._ros.ros1)
        except Exception as e:  # noqa: BLE001
            raise ValueError(f"payload does not decode ({type(e).__name__})") from None

    def _tf_transcoder(self, m: RawMessage, as_cdr: bool) -> Callable[[bytes], bytes | None] | None:
        """The compiled TFMessage -> msgpack writer for m's topic (None if its type is not TFMessage as ROS
        lays it out: that topic goes through rosbags); ``as_cdr`` (a rosbag2 bag): the recorded CDR itself
        where that writer would write it (checked, not written)."""
        from .tfdecode import TF_TYPE, standard_tf_layout

        if not COMPILED_TF or m.type_name != TF_TYPE or self._ros.ensure_type(m.conn):
            return None
        if self._tf_layout is None:
            self._tf_layout = standard_tf_layout(self._ros)
        if not self._tf_layout:
            return None
        from zentf.transport.ingest.tf_transcode import tf_cdr_to_msgpack, tf_cdr_transcodes, tf_ros1_to_msgpack

        if self._ros.ros1:
            return tf_ros1_to_msgpack
        if as_cdr:
            return lambda raw: raw if tf_cdr_transcodes(raw) else None
        return functools.partial(tf_cdr_to_msgpack, packb=True)

    def zentf(self, topics: Collection[str] | None = None,
              on_skip: Callable[[str, str], None] | None = None, *, tf_as_cdr: bool = False) -> Iterator[BagMessage]:
        """zentf BagMessages: ROS names mapped to zentf topics, payloads re-encoded to msgpack.

        TFMessages go from the bag's bytes to msgpack in C (tf_transcode.pyx; ``compiled_tf`` counts them),
        as the Python path (rosbags' decoder, to_plain, msgpack) would write them; a message the compiled
        path doubts takes the Python path, which says what is wrong. ``tf_as_cdr``: a rosbag2 bag's
        well-formed TFMessages keep their recorded CDR (encoding ``CDR_TF``), for a ROS 2 wire."""
        if self._ros is None:
            for m in self.raw(topics):
                yield m.conn
            return
        from zentf.transport.wire.codec import pack

        decoded: set[str] = set()  # topics with at least one decoded message
        fast: dict[tuple[str, str], Any] = {}  # (topic, type) -> its compiled TFMessage writer, or None
        bad = 0
        as_cdr = tf_as_cdr and not self._ros.ros1
        for m in self.raw(topics):
            if m.topic in self.skipped:
                continue
            kind = (m.topic, m.type_name)
            if kind not in fast:
                fast[kind] = self._tf_transcoder(m, as_cdr)
            write = fast[kind]
            payload = write(m.payload) if write is not None else None
            encoding = f"application/msgpack;{m.type_name}"
            if payload is not None:
                self.compiled_tf += 1
                if as_cdr:
                    encoding = CDR_TF
            else:
                try:
                    payload = pack(self.decode(m))
                except ValueError as e:
                    if m.topic in decoded:  # one damaged message of a good topic costs itself
                        bad += 1
                        if bad == 1:
                            log.warning("%s: a %s message does not decode (%s); skipping such messages",
                                        m.topic, m.type_name, e)
                        continue
                    self._skip(m.topic, f"type {m.type_name or '?'} cannot be carried: {e}", on_skip)
                    continue
            decoded.add(m.topic)
            yield BagMessage(zentf_topic(m.topic), m.type_name, encoding, m.sender, m.latched, "", m.log_time,
                             payload)

    def tf(self, topics: Collection[str] | None = None) -> Iterator[tuple[bool, str, Any, list]]:
        """(is_static, authority, raw payload, rows) per transform message; rows is None for zentf
        bags (their msgpack payload goes to wire.ingest_tf as is). ``topics`` default: any topic
        whose last name is tf or tf_static."""
        from .tfdecode import TF_TYPE, tf_decoder_for

        want = None if topics is None else {t.strip("/") for t in topics}

        def is_tf(name: str) -> bool:
            return name.strip("/") in want if want is not None else name.rsplit("/", 1)[-1] in TF_TOPICS

        if self._ros is None:
            for m in self.raw():
                if is_tf(m.topic):
                    yield m.topic.rsplit("/", 1)[-1] == "tf_static", m.sender or "bag", m.payload, None
            return
        decode = tf_decoder_for(self._ros)
        for conn, t, raw in self._ros.messages():
            if not is_tf(conn.topic):
                continue
            if conn.msgtype != TF_TYPE:
                self._skip(conn.topic, f"type {conn.msgtype} is not {TF_TYPE}", None)
                continue
            why = self._ros.ensure_type(conn) if self._ros.ros1 else None  # ROS 1: the bag's own definition
            if why:
                self._skip(conn.topic, why, None)
                continue
            try:
                rows = decode(raw)
            except Exception as e:  # noqa: BLE001 - one bad message costs itself
                log.debug("%s: undecodable TFMessage at %d (%s)", conn.topic, t, e)
                continue
            yield conn.topic.rsplit("/", 1)[-1] == "tf_static", conn.callerid or "bag", raw, rows
        self.problem, self.skipped_chunks = self._ros.problem, self._ros.skipped_chunks


def open_bag(path: str | os.PathLike) -> Bag:
    """Open any supported recording; BagError (UnknownFormatError) names what was wrong or found."""
    p = Path(path)
    if not p.exists():
        raise BagError(f"{p}: no such file or folder")
    return Bag(p)
