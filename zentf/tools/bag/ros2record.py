"""Recording a ROS 2 graph (``zentf bag record --wire ros2``) into a rosbag2-style MCAP file.

The samples are already CDR, so they are written as they came: channel topic = the ROS topic, message
encoding ``cdr``, schema = the type's ``ros2msg`` definition text (from zentf.ros) and the channel
metadata ``topic_type_hash`` rosbag2 writes. ROS 2 tools (``ros2 bag``, rosbags, mcap-ros2-support) read
such files; a type zentf has no definition for is recorded with an empty schema.
"""
from __future__ import annotations

import os
from typing import Any

from zentf.ros import UnknownTypeError, schema_text, type_hash

from .mcapwrite import McapFileWriter

__all__ = ["Ros2BagWriter"]


class Ros2BagWriter(McapFileWriter):
    """Same interface as zentf.tools.bag.BagWriter (``write``, ``flush``, ``close``, counters) for CDR samples
    of a ROS 2 graph; ``profile`` (the ros2 wire profile) maps data keys to (topic, type)."""

    def __init__(self, path: str | os.PathLike, profile: Any, *, compression: str = "zstd",
                 chunk_size: int = 64 * 1024) -> None:
        super().__init__(path, profile="ros2", chunk_size=chunk_size, compression=compression)
        self._profile = profile

    def _register_channel(self, key: str) -> int:
        topic, type_name = self._profile.topic_of_key(key)
        type_name = type_name or ""
        try:
            data = schema_text(type_name).encode()
        except UnknownTypeError:
            data = b""
        sid = self._schema(type_name, "ros2msg", data)
        try:
            meta = {"topic_type_hash": type_hash(type_name)}
        except UnknownTypeError:
            meta = {"topic_type_hash": key.rsplit("/", 1)[-1]}
        return self._writer.register_channel(topic=topic, message_encoding="cdr", schema_id=sid, metadata=meta)

    def write(self, key: str, payload: bytes, encoding: str = "", sender: str = "", log_time: int | None = None,
              latched: bool | None = None) -> None:
        self._append(key, payload, log_time)

    def __enter__(self) -> "Ros2BagWriter":
        return self
