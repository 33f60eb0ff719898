"""rosbag2 SQLite storage (.db3), read with Python's sqlite3, messages decompressed in bounded pieces.

Why not rosbags' reader: it decompresses a message-compressed bag's rows whole (a 50 KB row that
expands to gigabytes is a decompression bomb) and a file-compressed one to a temporary file. Here
a row's zstd data is decompressed in pieces and refused past ``MAX_CHUNK``; file compression is
refused with one line. Rows come in receive-time order (as rosbags gives them).
"""
from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import BagError
from .mcapscan import MAX_CHUNK, ChunkRefused, _decompressor, mib

__all__ = ["SqliteTopic", "SqliteBag"]


@dataclass(slots=True)
class SqliteTopic:
    id: int
    file: int           # index of the .db3 file holding it
    name: str
    type: str
    qos: str
    msgdef: str
    msgdef_kind: str    # ros2msg | ros2idl | "" (none in the bag)


def _metadata(path: Path) -> dict[str, Any]:
    from ...core import safe_yaml

    if path.is_dir():
        with open(path / "metadata.yaml", encoding="utf-8") as f:
            text = f.read(safe_yaml.MAX_CHARS + 1)
    else:
        try:
            con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
            try:
                row = con.execute("SELECT metadata FROM metadata ORDER BY id DESC LIMIT 1").fetchone()
            finally:
                con.close()
        except sqlite3.Error:
            return {}
        text = row[0] if row else ""
    try:
        meta = safe_yaml.load(text) if text else {}
    except safe_yaml.YamlRefused as e:
        raise BagError(f"{path}: metadata refused: {e}") from None
    return (meta or {}).get("rosbag2_bagfile_information", {}) if isinstance(meta, dict) else {}


class SqliteBag:
    """The topics and rows of a rosbag2 SQLite bag (a folder with metadata.yaml, or one .db3 file)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            meta = _metadata(path)
        except BagError:
            raise
        except Exception as e:  # noqa: BLE001 - unreadable metadata: one line
            raise BagError(f"{path}: unreadable metadata ({type(e).__name__})") from None
        mode = str(meta.get("compression_mode", "") or "").upper()
        fmt = str(meta.get("compression_format", "") or "").lower()
        if mode == "FILE":
            raise BagError(f"{path}: compressed per file ({fmt or '?'}); not supported, decompress it first")
        if mode == "MESSAGE" and fmt not in ("zstd", ""):
            raise BagError(f"{path}: messages compressed with {fmt!r}; zentf reads zstd")
        self.compressed = mode == "MESSAGE"
        self.problems: list[str] = []
        if path.is_dir():
            rel = meta.get("relative_file_paths") or []
            self.files = [path / str(p) for p in rel] or sorted(path.glob("*.db3"))
        else:
            self.files = [path]
        self.topics: list[SqliteTopic] = []
        for i, file in enumerate(self.files):
            self.topics.extend(self._topics(i, file))

    def _connect(self, file: Path) -> sqlite3.Connection:
        if not file.is_file():
            raise BagError(f"{file}: missing")
        try:
            con = sqlite3.connect(f"file:{file}?mode=ro", uri=True)
            con.execute("SELECT 1 FROM messages LIMIT 1").fetchall()
        except sqlite3.Error as e:
            raise BagError(f"{file}: cannot open the rosbag2 SQLite bag ({type(e).__name__}: "
                           f"{' '.join(str(e).split())[:100]})") from None
        return con

    def _topics(self, i: int, file: Path) -> list[SqliteTopic]:
        con = self._connect(file)
        try:
            cols = {r[1] for r in con.execute("PRAGMA table_info(topics)")}
            qos = "offered_qos_profiles" if "offered_qos_profiles" in cols else "''"
            rows = con.execute(f"SELECT id, name, type, {qos} FROM topics").fetchall()
            defs: dict[str, tuple[str, str]] = {}
            if con.execute("SELECT 1 FROM sqlite_master WHERE name='message_definitions'").fetchone():
                for typ, enc, text in con.execute(
                        "SELECT topic_type, encoding, encoded_message_definition FROM message_definitions"):
                    defs[typ] = (text, enc if enc in ("ros2msg", "ros2idl") else "")
        except sqlite3.Error as e:
            raise BagError(f"{file}: unreadable topics table ({type(e).__name__})") from None
        finally:
            con.close()
        out = []
        for tid, name, typ, q in rows:
            text, kind = defs.get(typ, ("", ""))
            out.append(SqliteTopic(int(tid), i, str(name), str(typ), str(q or ""), text if kind else "", kind))
        return out

    def rows(self, topics: list[SqliteTopic] | None = None, start: int | None = None,
             end: int | None = None) -> Iterator[tuple[SqliteTopic, int, bytes]]:
        """(topic, receive time ns, payload) of the given topics (default all), within [start, end] of
        receive time when given. sqlite3.Error and BagError as raised; a row that does not decompress
        (or expands past the cap) is skipped and named in ``problems``."""
        chosen = self.topics if topics is None else topics
        for i, file in enumerate(self.files):
            mine = {t.id: t for t in chosen if t.file == i}
            if not mine:
                continue
            con = self._connect(file)
            try:
                where = [f"topic_id IN ({','.join(str(k) for k in mine)})"]
                args: list[int] = []
                if start is not None:
                    where.append("timestamp >= ?")
                    args.append(start)
                if end is not None:
                    where.append("timestamp <= ?")
                    args.append(end)
                cur = con.execute(f"SELECT id, topic_id, timestamp, data FROM messages WHERE {' AND '.join(where)} "
                                  "ORDER BY timestamp, id", args)
                for rid, tid, t, data in cur:
                    if self.compressed:
                        try:
                            data = _bounded_zstd(data, f"row {rid} of {file.name}")
                        except ChunkRefused as e:
                            self.problems.append(str(e))
                            continue
                        except Exception as e:  # noqa: BLE001 - a damaged row costs itself
                            self.problems.append(f"row {rid} of {file.name} does not decompress ({type(e).__name__})")
                            continue
                    yield mine[tid], t, data
            finally:
                con.close()


def _bounded_zstd(data: bytes, what: str) -> bytes:
    out = []
    total = 0
    for piece in _decompressor("zstd")(data):
        total += len(piece)
        if total > MAX_CHUNK:
            raise ChunkRefused(f"{what} expands past the {mib(MAX_CHUNK)} cap; refused")
        out.append(piece)
    return b"".join(out)
