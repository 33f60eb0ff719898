"""Writing ROS 2 bags: rosbag2 MCAP files with CDR payloads, ``ros2msg`` schemas and rosbag2 metadata.

``Ros2Writer`` takes zentf messages (msgpack payloads, the ``BagWriter.write`` signature, so the
Recorder feeds either) and writes them through rosbags' rosbag2 writer: topic ``tf`` becomes
``/tf``, transient-local QoS for latched topics (``/tf_static``). An output path ending in
``.mcap`` gets a single MCAP file (its rosbag2 metadata travels inside, as an MCAP metadata
record); any other path a rosbag2 folder (``metadata.yaml`` + ``<name>.mcap``), as
``ros2 bag record -s mcap`` makes. A type rosbags' ROS 2 store does not know is skipped, once,
with one line.
"""
from __future__ import annotations

import logging
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .errors import BagError, MissingDependencyError
from .mcapwrite import WriterBase

__all__ = ["Ros2Writer", "ROSBAG2_VERSION"]

log = logging.getLogger("zentf.tools.bag")

#: rosbag2 metadata version written (8: ROS 2 Jazzy's; rosbags writes 8 or 9)
ROSBAG2_VERSION = 8
_FOREVER = (9223372036, 854775807)


def _qos(latched: bool) -> Any:
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    forever = QosTime(*_FOREVER)
    return Qos(QosHistory.KEEP_LAST, 1 if latched else 10, QosReliability.RELIABLE,
               QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE, forever, forever,
               QosLiveliness.AUTOMATIC, forever, False)


class Ros2Writer(WriterBase):
    """rosbag2 MCAP writer fed with zentf messages; thread-safe; ``close()`` finishes the file."""

    def __init__(self, path: str | os.PathLike, *, namespace: str = "",
                 on_skip: Callable[[str, str], None] | None = None) -> None:
        try:
            from rosbags.rosbag2 import StoragePlugin, Writer
            from rosbags.typesys import Stores, get_typestore
        except ImportError:
            raise MissingDependencyError("writing ROS 2 bags") from None
        super().__init__(path)
        self.namespace = namespace.strip("/")
        self.bare = self.path.endswith(".mcap")
        target = Path(self.path)
        if target.exists():
            raise BagError(f"cannot write {self.path}: it exists already")
        self._dir = target.with_name(target.name + ".rosbag2-partial") if self.bare else target
        if self._dir.exists():
            shutil.rmtree(self._dir)
        self.store = get_typestore(Stores.ROS2_HUMBLE)
        try:
            self._writer = Writer(self._dir, version=ROSBAG2_VERSION, storage_plugin=StoragePlugin.MCAP)
            self._writer.open()
        except Exception as e:  # noqa: BLE001 - rosbags' WriterError, OSError
            raise BagError(f"cannot write {self.path}: {e}") from None
        self._on_skip = on_skip
        self._conns: dict[tuple[str, str], Any] = {}
        self.skipped: dict[str, str] = {}

    def _skip(self, topic: str, why: str) -> None:
        if topic in self.skipped:
            return
        self.skipped[topic] = why
        if self._on_skip is not None:
            self._on_skip(topic, why)
        else:
            log.warning("skipping %s: %s", topic, why)

    def write(self, key: str, payload: bytes, encoding: str, sender: str = "", log_time: int | None = None,
              latched: bool | None = None) -> None:
        """One zentf message (msgpack payload of the type its encoding names), as CDR on /<key>."""
        from zentf.transport.wire.codec import type_name_from_encoding, unpack

        from .native import is_latched_key
        from .plain import from_plain

        topic = "/" + key.strip("/")
        type_name = type_name_from_encoding(encoding) or ""
        if topic in self.skipped:
            return
        if type_name not in self.store.fielddefs:
            self._skip(topic, f"type {type_name or '(none)'} is not a ROS 2 type rosbags knows")
            return
        try:
            raw = self.store.serialize_cdr(from_plain(self.store, type_name, unpack(payload)), type_name)
        except Exception as e:  # noqa: BLE001 - one bad message costs itself
            log.debug("%s: message not convertible to %s (%s)", topic, type_name, e)
            return
        t = time.time_ns() if log_time is None else int(log_time)
        with self._lock:
            if self._closed:
                return
            conn = self._conns.get((topic, type_name))
            if conn is None:
                lat = is_latched_key(key) if latched is None else latched
                conn = self._conns[(topic, type_name)] = self._writer.add_connection(
                    topic, type_name, typestore=self.store, offered_qos_profiles=[_qos(lat)])
            self._writer.write(conn, t, raw)
            self._count(t, len(raw))

    def flush(self) -> None:
        """rosbags' writer closes its chunk on its own; nothing to force."""

    @property
    def file_size(self) -> int:
        try:
            return sum(f.stat().st_size for f in self._dir.iterdir())
        except OSError:
            return 0

    def _finish(self) -> None:
        try:
            self._writer.close()
        finally:
            if self.bare:
                found = sorted(self._dir.glob("*.mcap"))
                if found:
                    os.replace(found[0], self.path)
                shutil.rmtree(self._dir, ignore_errors=True)

    def __enter__(self) -> "Ros2Writer":
        return self
