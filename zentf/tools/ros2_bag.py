"""Recording a ROS 2 graph (``zentf bag record --wire ros2``) into a rosbag2-style MCAP file.

The samples are already CDR, so they are written as they came: channel topic = the ROS topic, message
encoding ``cdr``, schema = the type's ``ros2msg`` definition text (from zentf.ros) and the channel
metadata ``topic_type_hash`` rosbag2 writes. ROS 2 tools (``ros2 bag``, rosbags, mcap-ros2-support) read
such files; a type zentf has no definition for is recorded with an empty schema.
"""
from __future__ import annotations

import os
import threading
import time
from typing import Any, BinaryIO

from ..ros import UnknownTypeError, schema_text, type_hash

__all__ = ["Ros2BagWriter"]


class Ros2BagWriter:
    """Same interface as zentf.tools.bag.BagWriter (``write``, ``flush``, ``close``, counters) for CDR samples
    of a ROS 2 graph; ``profile`` (the ros2 wire profile) maps data keys to (topic, type)."""

    def __init__(self, path: str | os.PathLike, profile: Any, *, compression: str = "zstd",
                 chunk_size: int = 64 * 1024) -> None:
        from mcap.writer import CompressionType, Writer

        from .bag import BagError

        self.path = os.fspath(path)
        self._profile = profile
        try:
            self._file: BinaryIO = open(self.path, "wb")
        except OSError as e:
            raise BagError(f"cannot write {self.path}: {e.strerror}") from None
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[compression]
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=comp)
        self._writer.start(profile="ros2", library="zentf")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._seq: dict[int, int] = {}
        self._lock = threading.Lock()
        self._closed = False
        self.messages = 0
        self.payload_bytes = 0
        self.first_time: int | None = None
        self.last_time: int | None = None

    def _channel(self, key: str) -> int:
        cid = self._channels.get(key)
        if cid is not None:
            return cid
        topic, type_name = self._profile.topic_of_key(key)
        type_name = type_name or ""
        sid = self._schemas.get(type_name)
        meta = {}
        if sid is None:
            try:
                data = schema_text(type_name).encode()
            except UnknownTypeError:
                data = b""
            sid = self._writer.register_schema(name=type_name, encoding="ros2msg", data=data)
            self._schemas[type_name] = sid
        try:
            meta["topic_type_hash"] = type_hash(type_name)
        except UnknownTypeError:
            meta["topic_type_hash"] = key.rsplit("/", 1)[-1]
        cid = self._writer.register_channel(topic=topic, message_encoding="cdr", schema_id=sid, metadata=meta)
        self._channels[key] = cid
        return cid

    def write(self, key: str, payload: bytes, encoding: str = "", sender: str = "", log_time: int | None = None,
              latched: bool | None = None) -> None:
        t = time.time_ns() if log_time is None else int(log_time)
        with self._lock:
            if self._closed:
                return
            cid = self._channel(key)
            seq = self._seq.get(cid, 0)
            self._seq[cid] = seq + 1
            self._writer.add_message(channel_id=cid, log_time=t, data=payload, publish_time=t, sequence=seq)
            self.messages += 1
            self.payload_bytes += len(payload)
            if self.first_time is None:
                self.first_time = t
            self.last_time = t

    def flush(self) -> None:
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
