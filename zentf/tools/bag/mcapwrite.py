"""What zentf's bag writers share: counters, the write lock, close-once, and the MCAP file writer.

``WriterBase`` is the interface the Recorder feeds (``write``, ``flush``, ``close``, ``messages``,
``payload_bytes``, ``duration``, ``file_size``); ``McapFileWriter`` adds the MCAP file itself
(compression, chunking, schema and channel registration, per-channel sequence numbers) for the
writers that talk to the ``mcap`` package directly (``native.BagWriter``, ``ros2record.Ros2BagWriter``).
"""
from __future__ import annotations

import os
import threading
import time
from collections.abc import Hashable
from typing import Any, BinaryIO

from .errors import BagError

__all__ = ["WriterBase", "McapFileWriter", "COMPRESSIONS"]

#: compression names the writers and ``zentf bag record --compression`` accept
COMPRESSIONS = ("zstd", "lz4", "none")


class WriterBase:
    """Counters, lock and close-once for a bag writer; subclasses write, ``_finish`` ends the file."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self._lock = threading.Lock()
        self._closed = False
        self.messages = 0
        self.payload_bytes = 0
        self.first_time: int | None = None
        self.last_time: int | None = None

    def _count(self, t: int, size: int) -> None:
        """Account one written message (call with the lock held)."""
        self.messages += 1
        self.payload_bytes += size
        if self.first_time is None:
            self.first_time = t
        self.last_time = t

    @property
    def duration(self) -> float:
        if self.first_time is None or self.last_time is None:
            return 0.0
        return (self.last_time - self.first_time) / 1e9

    def flush(self) -> None:
        """Nothing to force by default."""

    def _finish(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._finish()

    def __enter__(self) -> Any:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class McapFileWriter(WriterBase):
    """An MCAP file written through ``mcap.writer.Writer``; subclasses map a message to a channel.

    A subclass implements ``_register_channel(channel_key, *args) -> channel id`` (using ``_schema``)
    and calls ``_append(channel_key, payload, log_time, *args)``, which registers the channel once.
    """

    def __init__(self, path: str | os.PathLike, *, profile: str, chunk_size: int = 64 * 1024,
                 compression: str = "zstd") -> None:
        from mcap.writer import CompressionType, Writer

        super().__init__(path)
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[compression]
        try:
            self._file: BinaryIO = open(self.path, "wb")
        except OSError as e:
            raise BagError(f"cannot write {self.path}: {e.strerror}") from None
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=comp)
        self._writer.start(profile=profile, library="zentf")
        self._schemas: dict[str, int] = {}
        self._channels: dict[Hashable, int] = {}
        self._seq: dict[int, int] = {}

    def _schema(self, name: str, encoding: str, data: bytes) -> int:
        """The id of schema ``name``, registered on first use."""
        sid = self._schemas.get(name)
        if sid is None:
            sid = self._schemas[name] = self._writer.register_schema(name=name, encoding=encoding, data=data)
        return sid

    def _register_channel(self, channel_key: Any, *args: Any) -> int:
        raise NotImplementedError

    def _append(self, channel_key: Hashable, payload: bytes, log_time: int | None, *args: Any) -> None:
        """Write ``payload`` on the channel of ``channel_key`` (registered once from ``args``)."""
        t = time.time_ns() if log_time is None else int(log_time)
        with self._lock:
            if self._closed:
                return
            cid = self._channels.get(channel_key)
            if cid is None:
                cid = self._channels[channel_key] = self._register_channel(channel_key, *args)
            seq = self._seq.get(cid, 0)
            self._seq[cid] = seq + 1
            self._writer.add_message(channel_id=cid, log_time=t, data=payload, publish_time=t, sequence=seq)
            self._count(t, len(payload))

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

    def _finish(self) -> None:
        try:
            self._writer.finish()
        finally:
            self._file.close()
