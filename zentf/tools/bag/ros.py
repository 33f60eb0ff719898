"""ROS recordings (ROS 1 .bag, rosbag2 .db3 and .mcap) read through rosbags' readers and typestores.

``RosBag`` yields (connection, log_time, raw payload) in file order and decodes payloads with a
typestore built from the bag's own message definitions (types a bag does not define come from
rosbags' ROS 2 Humble store). ROS 2 MCAP files are scanned by zentf's tolerant MCAP scanner; ROS 1
bags without an index (killed recorder, cut copy) by the linear ROS 1 scanner; SQLite by rosbags.
Reading never raises past the first message: what stops it is kept in ``problem``.
"""
from __future__ import annotations

import logging
import os
from collections.abc import Collection, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import BagError, MissingDependencyError
from .formats import BagFormat

__all__ = ["RosConnection", "RosBag", "latched_qos"]

log = logging.getLogger("zentf.tools.bag")

LATCHED_TOPICS = ("tf_static",)


@dataclass(slots=True)
class RosConnection:
    """One topic of a ROS bag as zentf needs it."""

    topic: str
    msgtype: str
    latched: bool = False
    callerid: str = ""
    msgdef: str = ""
    msgdef_kind: str = "ros2msg"  # ros2msg | ros2idl | ros1msg | "" (none in the bag)


def latched_qos(profiles: Any) -> bool:
    """True if rosbag2 offered-QoS profiles (YAML text or rosbags Qos objects) say transient local."""
    if not profiles:
        return False
    if isinstance(profiles, str):
        text = profiles.lower()
        return "transient_local" in text or "durability: 1\n" in text + "\n"
    return any(getattr(getattr(q, "durability", None), "name", "") == "TRANSIENT_LOCAL" for q in profiles)


def _is_latched(topic: str, flag: bool) -> bool:
    return flag or topic.rsplit("/", 1)[-1] in LATCHED_TOPICS


def _rosbags() -> Any:
    try:
        import rosbags.typesys as typesys
    except ImportError:
        raise MissingDependencyError("reading ROS bags") from None
    return typesys


class RosBag:
    """A ROS 1 or ROS 2 recording: connections, raw messages and a typestore to decode them."""

    def __init__(self, path: str | os.PathLike, fmt: BagFormat) -> None:
        typesys = _rosbags()
        self.path = Path(path)
        self.format = fmt
        self.ros1 = fmt is BagFormat.ROS1
        self.problem: str | None = None
        self.skipped_chunks = 0
        self.typestore = typesys.get_typestore(typesys.Stores.EMPTY)
        self._fallback: Any = None
        self._types_ok: dict[str, str | None] = {}  # msgtype -> None if decodable, else why not
        self.connections: dict[Any, RosConnection] = {}

    # ------------------------------------------------------------------ types

    def ensure_type(self, conn: RosConnection) -> str | None:
        """Register conn's type in the typestore; None if it decodes, else one line saying why not."""
        known = self._types_ok.get(conn.msgtype, "")
        if known != "":
            return known
        typesys = _rosbags()
        why: str | None = None
        try:
            if conn.msgtype in self.typestore.fielddefs:
                pass
            elif conn.msgdef and conn.msgdef_kind in ("ros2msg", "ros1msg"):
                self.typestore.register(typesys.get_types_from_msg(conn.msgdef, conn.msgtype))
            elif conn.msgdef and conn.msgdef_kind == "ros2idl":
                sep = "=" * 80 + "\n"
                for part in (conn.msgdef.split(sep)[1:] if conn.msgdef.startswith(sep + "IDL: ") else [conn.msgdef]):
                    idl = part.split("\n", 1)[1] if part.startswith("IDL: ") else part
                    self.typestore.register(typesys.get_types_from_idl(idl))
            else:
                if self._fallback is None:
                    self._fallback = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
                if conn.msgtype not in self._fallback.fielddefs:
                    why = "no definition in the bag nor in rosbags' ROS 2 Humble types"
                else:
                    self.typestore.register(_closure(self._fallback, conn.msgtype))
        except Exception as e:  # noqa: BLE001 - a bad definition costs its topic only
            why = f"its definition does not parse ({type(e).__name__}: {str(e).splitlines()[0][:80] if str(e) else ''})"
        self._types_ok[conn.msgtype] = why
        return why

    def deserialize(self, raw: bytes | memoryview, msgtype: str) -> Any:
        if self.ros1:
            return self.typestore.deserialize_ros1(raw, msgtype)
        return self.typestore.deserialize_cdr(raw, msgtype)

    # ------------------------------------------------------------------ messages

    def messages(self, topics: Collection[str] | None = None) -> Iterator[tuple[RosConnection, int, bytes]]:
        """(connection, log_time ns, raw) in file order, of ``topics`` (ROS names) or all."""
        self.problem = None
        want = None if topics is None else set(topics)
        if self.format is BagFormat.ROS2_MCAP:
            yield from self._mcap(want)
        elif self.format is BagFormat.ROS1:
            yield from self._ros1(want)
        else:
            yield from self._sqlite(want)

    def _mcap_files(self) -> list[Path]:
        if not self.path.is_dir():
            return [self.path]
        from ...core import safe_yaml

        meta = safe_yaml.load_file(self.path / "metadata.yaml")["rosbag2_bagfile_information"]
        return [self.path / p for p in meta.get("relative_file_paths", [])] or sorted(self.path.glob("*.mcap"))

    def _mcap(self, want: set[str] | None) -> Iterator[tuple[RosConnection, int, bytes]]:
        from .mcapscan import McapScan

        for file in self._mcap_files():
            if file.suffix == ".zstd" or not file.exists():
                self.problem = f"{file.name}: missing or compressed per file (not supported)"
                return
            scan = McapScan(file)
            conns: dict[int, RosConnection] = {}
            for ch, t, raw in scan:
                conn = conns.get(ch.id)
                if conn is None:
                    s = ch.schema
                    conn = conns[ch.id] = RosConnection(
                        ch.topic, s.name if s else "", _is_latched(ch.topic, latched_qos(ch.metadata.get(
                            "offered_qos_profiles"))), "", s.data.decode("utf-8", "replace") if s else "",
                        s.encoding if s else "")
                    self.connections[(file, ch.id)] = conn
                if want is None or conn.topic in want:
                    yield conn, t, raw
            self.skipped_chunks += scan.skipped_chunks
            if scan.problem:
                self.problem = scan.problem if len(self._mcap_files()) == 1 else f"{file.name}: {scan.problem}"
                if not scan.has_summary:
                    return

    def _ros1(self, want: set[str] | None) -> Iterator[tuple[RosConnection, int, bytes]]:
        from .ros1scan import Ros1Scan

        scan = Ros1Scan(self.path)
        conns: dict[int, RosConnection] = {}
        try:
            for c, t, raw in scan:
                conn = conns.get(c.id)
                if conn is None or conn.topic != c.topic:
                    conn = conns[c.id] = self.connections[c.id] = RosConnection(
                        c.topic, c.msgtype, _is_latched(c.topic, c.latching), c.callerid, c.msgdef, "ros1msg")
                if want is None or conn.topic in want:
                    yield conn, t, raw
        finally:
            self.skipped_chunks = scan.skipped_chunks
            self.problem = scan.problem

    def _sqlite(self, want: set[str] | None) -> Iterator[tuple[RosConnection, int, bytes]]:
        from .ros2sqlite import SqliteBag

        bag = SqliteBag(self.path)
        conns = {}
        for t in bag.topics:
            conns[(t.file, t.id)] = self.connections[(t.file, t.id)] = RosConnection(
                t.name, t.type, _is_latched(t.name, latched_qos(t.qos)), "", t.msgdef, t.msgdef_kind)
        sel = [t for t in bag.topics if want is None or t.name in want]
        n = 0
        try:
            for t, stamp, raw in bag.rows(sel):
                n += 1
                yield conns[(t.file, t.id)], stamp, raw
        except Exception as e:  # noqa: BLE001 - damage inside the database: stop, say where
            self.problem = f"stopped after {n} messages ({_one_line(e)})"
            return
        if bag.problems:
            more = f" (and {len(bag.problems) - 1} more)" if len(bag.problems) > 1 else ""
            self.problem = f"{bag.problems[0]}{more}; read {n} messages"


def _one_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()[0] if str(e).strip() else ""
    return f"{type(e).__name__}: {text}"[:120] if text else type(e).__name__


def _closure(store: Any, name: str) -> dict[str, Any]:
    """``name``'s field definitions and those of every type it uses, from ``store``."""
    out: dict[str, Any] = {}
    todo = [name]
    while todo:
        n = todo.pop()
        if n in out:
            continue
        out[n] = store.fielddefs[n]
        for _, (node, detail) in out[n][1]:
            if node == 2:
                todo.append(detail)
            elif node in (3, 4) and detail[0][0] == 2:
                todo.append(detail[0][1])
    return out
