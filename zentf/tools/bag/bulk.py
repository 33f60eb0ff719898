"""A recording's tf straight into a BufferCore: each format's chunks through the compiled ``TfLoader``.

The containers are read here (MCAP chunks and ROS 1 chunks through the bounded scanners, SQLite rows),
the records and TFMessages in C (``tfload.pyx``; a rosbag2 .db3's rows are stepped there with SQLite's C
API). A message the compiled decoders doubt is decoded by the same Python decoders ``Bag.tf()`` uses
(``fallback``), so the result is the one a sample-by-sample load gives. A time window (stamps in
[start, end]; static transforms always) reads only the chunks that can hold it when the file has an
index (MCAP chunk index, ROS 1 chunk infos, a .db3's timestamp index: slices of receive time stand in
for chunks): the chunks are ordered by receive time, the window by stamp, so the first chunk is found
by bisection on the stamps its messages carry, then chunks are read until one starts past the window.
"""
from __future__ import annotations

import logging
import struct
from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

from .formats import BagFormat
from .mcapscan import _CHUNK, _MESSAGE, MAGIC, ChunkRefused, McapChannel, McapScan, _REC
from .tfdecode import TF_TYPE
from .tfload import KIND_CDR, KIND_MSGPACK, KIND_OTHER, KIND_ROS1, KIND_SKIP, MCAP, ROS1, TfLoader

__all__ = ["load_into", "TF_MD5"]

log = logging.getLogger("zentf.tools.bag")

#: tf2_msgs/TFMessage's ROS 1 md5sum: connections with it have the layout the compiled decoder reads
TF_MD5 = "94810edda583a504dfda3829e70d7eec"
_MAX_NS = (1 << 63) - 1


class _Load:
    """One load: the loader, each channel's Python decoder, the window, the problems."""

    def __init__(self, bag: Any, core: Any, topics: Collection[str] | None, start: int | None,
                 end: int | None, framing: int) -> None:
        self.bag = bag
        self.core = core
        self.want = None if topics is None else {t.strip("/") for t in topics}
        self.start = 0 if start is None else max(0, start)
        self.end = _MAX_NS if end is None else end
        self.windowed = start is not None or end is not None
        self.loader = TfLoader(core, self._fallback, None, framing, self.start, self.end)
        self.decoders: dict[int, tuple[Callable[[bytes], list], str, bool]] = {}
        self.problems: list[str] = []

    def is_tf(self, name: str) -> bool:
        return name.strip("/") in self.want if self.want is not None else name.rsplit("/", 1)[-1] in ("tf", "tf_static")

    def channel(self, cid: int, topic: str, kind: int, decode: Callable[[bytes], list] | None, authority: str) -> None:
        static = topic.rsplit("/", 1)[-1] == "tf_static"
        if kind == KIND_SKIP or decode is None:
            self.loader.set_channel(cid, KIND_SKIP, None, False)
            return
        self.decoders[cid] = (decode, authority, static)
        self.loader.set_channel(cid, kind, authority, static)

    def _fallback(self, cid: int, payload: bytes) -> None:
        decode, authority, static = self.decoders[cid]
        try:
            rows = decode(payload)
        except Exception as e:  # noqa: BLE001 - one bad message costs itself
            log.debug("%s: undecodable TFMessage (%s)", self.bag.display, e)
            return
        if not rows:
            return
        if not static:
            lo = min(r[2] for r in rows if type(r[2]) is int) if any(type(r[2]) is int for r in rows) else None
            if lo is not None:
                hi = max(r[2] for r in rows if type(r[2]) is int)
                self.loader.stamp_min = min(self.loader.stamp_min, lo)
                self.loader.stamp_max = max(self.loader.stamp_max, hi)
            if self.windowed:
                rows = [r for r in rows if not (type(r[2]) is int and (r[2] < self.start or r[2] > self.end))]
        if rows and not self.loader.dry:
            self.core.set_transforms_raw(rows, authority, static)


def _zentf_decoder() -> Callable[[bytes], list]:
    from zentf.transport.wire.codec import RowCapture, ingest_tf

    def decode(payload: bytes) -> list:
        cap = RowCapture()
        ingest_tf(payload, cap, "", False)
        return cap.rows
    return decode


# ---------------------------------------------------------------- MCAP


def _mcap(load: _Load, path: Path, zentf: bool) -> str | None:
    from .tfdecode import cdr_tf_decoder

    scan = McapScan(path)
    scan.read_summary()
    cdr = cdr_tf_decoder()[1]
    msgpack = _zentf_decoder() if zentf else None
    bag = load.bag

    def classify(ch: McapChannel) -> None:
        if not load.is_tf(ch.topic):
            load.channel(ch.id, ch.topic, KIND_SKIP, None, "")
            return
        if zentf:
            load.channel(ch.id, ch.topic, KIND_MSGPACK, msgpack, ch.metadata.get("sender", "") or "bag")
            return
        name = ch.schema.name if ch.schema else ""
        if name != TF_TYPE:
            bag._skip(ch.topic, f"type {name} is not {TF_TYPE}", None)
            load.channel(ch.id, ch.topic, KIND_SKIP, None, "")
            return
        load.channel(ch.id, ch.topic, KIND_CDR, cdr, "bag")

    for ch in list(scan.channels.values()):
        classify(ch)
    scan.on_definition = classify
    loader = load.loader

    def chunk(body: bytes, where: int, cut: bool) -> None:
        try:
            data, damage = scan.chunk_data(body, where, cut)
        except ChunkRefused as e:
            scan.skipped_chunks += 1
            scan._note(f"the chunk at byte {where} {e}")
            return
        except (ValueError, struct.error, UnicodeDecodeError) as e:
            scan.skipped_chunks += 1
            scan._note(f"skipped a damaged chunk at byte {where} ({type(e).__name__}: {str(e)[:80]})")
            return
        before = loader.messages
        loader.feed(data)
        whole = loader.end_chunk()
        if cut:
            scan.problems[-1] += f"; kept its first {loader.messages - before} tf messages"
        elif damage is not None or not whole:
            scan.skipped_chunks += 1
            scan._note(f"skipped a damaged chunk at byte {where} ({damage or 'a record runs past the chunk'}; kept "
                       f"{loader.messages - before} tf messages before it)")

    loader.on_definition = lambda op, head, _body: scan._definition(op, head)
    with open(path, "rb") as f:
        if f.read(8) != MAGIC:
            return "bad magic bytes"
        if load.windowed and scan.chunks:
            for c in _window_chunks(load, scan.chunks, {cid for cid, (_, _, s) in load.decoders.items() if s},
                                    lambda c: _mcap_chunk_at(f, scan, c.offset, chunk)):
                loader.dry = False
                _mcap_chunk_at(f, scan, c.offset, chunk)
            scan.has_summary = True
        else:
            for op, where, body in scan.units(f):
                if op == _MESSAGE:
                    if len(body) >= 22:
                        loader.message(struct.unpack_from("<H", body, 0)[0], body[22:])
                elif op in (_CHUNK, -1):
                    chunk(body, where, op == -1)
                else:
                    try:
                        scan._definition(op, body)
                    except (ValueError, struct.error, UnicodeDecodeError) as e:
                        scan._note(f"the record at byte {where} is corrupt ({type(e).__name__})")
    if not scan.problems and not scan.has_summary:
        scan._note("no summary (the recorder did not close the file)")
    scan.messages_read = loader.messages
    scan.unit = "tf messages"
    return scan.problem


def _mcap_chunk_at(f: Any, scan: McapScan, offset: int, chunk: Callable[[bytes, int, bool], None]) -> None:
    f.seek(offset)
    head = f.read(9)
    if len(head) < 9:
        return
    op, n = _REC.unpack(head)
    if op != _CHUNK or n > scan.size - offset - 9:
        scan._note(f"the chunk index points at byte {offset}, where there is no chunk")
        return
    chunk(f.read(n), offset, False)


def _window_chunks(load: _Load, chunks: list, static_ids: set[int], read: Callable[[Any], None]) -> list:
    """The chunks a stamp window needs: every chunk with static transforms, and the run of chunks with
    dynamic ones whose stamps can fall in [start, end] (found by bisection, a chunk of margin each side)."""
    loader = load.loader
    dynamic_ids = {cid for cid, (_, _, s) in load.decoders.items() if not s}
    dyn = [c for c in chunks if c.channels & dynamic_ids]
    cache: dict[int, tuple[int, int]] = {}

    def stamps(i: int) -> tuple[int, int]:
        if i not in cache:
            loader.dry = True
            loader.reset_stamps()
            read(dyn[i])
            loader.dry = False
            cache[i] = (loader.stamp_min, loader.stamp_max)
        return cache[i]

    lo, hi = 0, len(dyn)
    while lo < hi:  # the first chunk whose newest stamp reaches the window's start
        mid = (lo + hi) // 2
        smin, smax = stamps(mid)
        if smax < smin or smax < load.start:  # nothing decodable, or all before the window
            lo = mid + 1
        else:
            hi = mid
    first = max(0, lo - 1)
    last = first
    while last + 1 < len(dyn):
        last += 1
        smin, smax = stamps(last)
        if smax >= smin and smin > load.end:
            break
    chosen = {id(c) for c in dyn[first:last + 1]}
    chosen |= {id(c) for c in chunks if c.channels & static_ids}
    return [c for c in chunks if id(c) in chosen]


# ---------------------------------------------------------------- ROS 1


def _ros1(load: _Load) -> str | None:
    from .ros1scan import Ros1Connection, Ros1Scan, _U32, chunk_records, fields
    from .tfdecode import tf_decoder_for

    ros = load.bag.ros
    scan = Ros1Scan(load.bag.path)
    decode = tf_decoder_for(ros)
    bag = load.bag
    loader = load.loader

    def classify(c: Ros1Connection) -> None:
        from .ros import RosConnection, _is_latched

        conn = RosConnection(c.topic, c.msgtype, _is_latched(c.topic, c.latching), c.callerid, c.msgdef, "ros1msg")
        ros.connections[c.id] = conn
        if not load.is_tf(c.topic):
            load.channel(c.id, c.topic, KIND_SKIP, None, "")
            return
        if c.msgtype != TF_TYPE:
            bag._skip(c.topic, f"type {c.msgtype} is not {TF_TYPE}", None)
            load.channel(c.id, c.topic, KIND_SKIP, None, "")
            return
        why = ros.ensure_type(conn)
        if why:
            bag._skip(c.topic, why, None)
            load.channel(c.id, c.topic, KIND_SKIP, None, "")
            return
        load.channel(c.id, c.topic, KIND_ROS1 if c.md5sum == TF_MD5 else KIND_OTHER, decode, c.callerid or "bag")

    scan.on_connection = classify
    scan.read_index()

    def on_definition(op: int, head: bytes, body: bytes) -> None:
        try:
            scan._connection(fields(head), body)
        except (ValueError, KeyError, struct.error):
            pass

    loader.on_definition = on_definition

    def chunk(head: dict, data: bytes, off: int, cut: bool) -> None:
        try:
            inner, damage = chunk_records(head, data)
        except ChunkRefused as e:
            scan.skipped_chunks += 1
            scan._note(f"the chunk at byte {off} {e}")
            return
        except ValueError as e:
            scan.skipped_chunks += 1
            scan._note(f"skipped a damaged chunk at byte {off} ({type(e).__name__}: {str(e)[:80]})")
            return
        before = loader.messages
        loader.feed(inner)
        whole = loader.end_chunk()
        if cut:
            scan.problems[-1] += f"; kept the first {loader.messages - before} tf messages of that chunk"
        elif damage is not None or not whole:
            scan.skipped_chunks += 1
            scan._note(f"skipped a damaged chunk at byte {off} ({damage or 'a record runs past the chunk'}; "
                       f"kept {loader.messages - before} tf messages before it)")

    with open(load.bag.path, "rb") as f:
        if f.read(13) != b"#ROSBAG V2.0\n":
            return "bad magic line"

        def chunk_at(c: Any) -> None:
            for op, off, head, data in scan.records(f, c.offset, c.offset + 1):
                if op == 0x05:
                    chunk(head, data, off, False)

        if load.windowed and scan.has_index:
            static_ids = {cid for cid, (_, _, s) in load.decoders.items() if s}
            for c in _window_chunks(load, scan.chunks, static_ids, chunk_at):
                chunk_at(c)
        else:
            stop = scan.index_pos if scan.has_index else None
            for op, off, head, data in scan.records(f, 13, stop):
                try:
                    if op == 0x07:
                        scan._connection(head, data)
                    elif op == 0x02:
                        loader.message(_U32.unpack(head["conn"])[0], data)
                    elif op in (0x05, -1):
                        chunk(head, data, off, op == -1)
                except (ValueError, KeyError, struct.error) as e:
                    scan._note(f"skipped a damaged record at byte {off} ({type(e).__name__})")
    if not scan.has_index and not scan.problems:
        scan._note("no index (the recorder did not close the file); read linearly")
    scan.messages_read = loader.messages
    scan.unit = "tf messages"
    return scan.problem


# ---------------------------------------------------------------- SQLite


def _sqlite(load: _Load) -> str | None:
    from .ros import _one_line
    from .ros2sqlite import SqliteBag
    from .sqliteapi import unavailable
    from .tfdecode import cdr_tf_decoder

    sq = SqliteBag(load.bag.path)
    cdr = cdr_tf_decoder()[1]
    ids: dict[tuple[int, int], int] = {}
    chosen = []
    for t in sq.topics:
        cid = ids[(t.file, t.id)] = len(ids)
        if not load.is_tf(t.name):
            continue
        if t.type != TF_TYPE:
            load.bag._skip(t.name, f"type {t.type} is not {TF_TYPE}", None)
            continue
        load.channel(cid, t.name, KIND_CDR, cdr, "bag")
        chosen.append(t)
    if not sq.compressed and len(chosen) <= 64 and unavailable() is None:
        return _sqlite_compiled(load, sq, chosen, ids)
    message = load.loader.message
    n = 0
    try:
        for t, _, raw in sq.rows(chosen):
            n += 1
            message(ids[(t.file, t.id)], raw)
    except Exception as e:  # noqa: BLE001 - damage inside the database: stop, say where
        return f"stopped after {n} tf messages ({_one_line(e)})"
    if sq.problems:
        more = f" (and {len(sq.problems) - 1} more)" if len(sq.problems) > 1 else ""
        return f"{sq.problems[0]}{more}; read {n} tf messages"
    return None


def _sqlite_compiled(load: _Load, sq: Any, chosen: list, ids: dict[tuple[int, int], int]) -> str | None:
    """SqliteBag.rows' query, stepped in C (TfLoader.sqlite): no tuple or bytes object per row; the same
    rows in the same order, and the same line when the database is damaged."""
    import os

    from .ros import _one_line

    n = 0
    for i, file in enumerate(sq.files):
        mine = [t for t in chosen if t.file == i]
        if not mine:
            continue
        try:
            con = sq._connect(file)  # missing, not a database, no messages table: its one line
            try:
                span = _timestamp_span(con) if load.windowed else None
            finally:
                con.close()
        except Exception as e:  # noqa: BLE001 - as the Python path reports it
            return f"stopped after {n} tf messages ({_one_line(e)})"
        uri = b"file:" + os.fsencode(file) + b"?mode=ro"
        error = None

        def read(topics: list, lo: int | None = None, hi: int | None = None) -> None:
            nonlocal n, error
            if error is not None or not topics:
                return
            where = f"topic_id IN ({','.join(str(t.id) for t in topics)})"
            if lo is not None:
                where += f" AND timestamp >= {int(lo)} AND timestamp < {int(hi)}"
            rows, err = load.loader.sqlite(uri, f"SELECT topic_id, data FROM messages WHERE {where} "
                                                "ORDER BY timestamp, id".encode(),
                                           [t.id for t in topics], [ids[(i, t.id)] for t in topics])
            n += rows
            error = error or err

        if span is None:
            read(mine)
        else:  # receive-time slices stand in for chunks: the statics whole, the dynamic slices the window needs
            statics = [t for t in mine if load.decoders[ids[(i, t.id)]][2]]
            dynamic = [t for t in mine if t not in statics]
            read(statics)
            slices = _time_slices(span, {ids[(i, t.id)] for t in dynamic})
            for sl in _window_chunks(load, slices, set(), lambda sl: read(dynamic, sl.lo, sl.hi)):
                load.loader.dry = False
                read(dynamic, sl.lo, sl.hi)
        if error is not None:
            return f"stopped after {n} tf messages ({_one_line(_sqlite_exception(*error))})"
    return None


class _Slice:
    """A span of receive times [lo, hi) of a .db3, read as one chunk is by a time window."""

    __slots__ = ("lo", "hi", "channels")

    def __init__(self, lo: int, hi: int, channels: set[int]) -> None:
        self.lo, self.hi, self.channels = lo, hi, channels


_SLICES = 256  # a window reads ~3 of them (and ~8 probed while bisecting): ~1/20 of a long recording


def _timestamp_span(con: Any) -> tuple[int, int] | None:
    """(first, last) receive time of the messages table if it has an index on timestamp (rosbag2's
    timestamp_idx: a slice is then a range search, not a scan), else None (read it whole)."""
    indexed = False
    for row in con.execute("PRAGMA index_list(messages)").fetchall():
        cols = con.execute(f"PRAGMA index_info({_quote(str(row[1]))})").fetchall()
        indexed = indexed or (bool(cols) and cols[0][2] == "timestamp")
    if not indexed:
        return None
    lo, hi = con.execute("SELECT MIN(timestamp), MAX(timestamp) FROM messages").fetchone()
    return (lo, hi) if type(lo) is int and type(hi) is int else None


def _quote(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def _time_slices(span: tuple[int, int], channels: set[int]) -> list[_Slice]:
    lo, hi = span
    width = max(1, (hi - lo) // _SLICES + 1)
    return [_Slice(a, min(a + width, hi + 1), channels) for a in range(lo, hi + 1, width)]


def _sqlite_exception(code: int, message: str) -> Exception:
    """The exception Python's sqlite3 raises for a primary SQLite result code (its _pysqlite_seterror)."""
    import sqlite3

    if code in (2, 12):
        cls: type[Exception] = sqlite3.InternalError
    elif code == 7:
        cls = MemoryError
    elif code in (1, 3, 4, 5, 6, 8, 9, 10, 13, 14, 15, 16, 17):
        cls = sqlite3.OperationalError
    elif code == 18:
        cls = sqlite3.DataError
    elif code in (19, 20):
        cls = sqlite3.IntegrityError
    elif code in (21, 25):
        cls = sqlite3.InterfaceError
    else:  # SQLITE_CORRUPT, SQLITE_NOTADB, ...
        cls = sqlite3.DatabaseError
    return cls(message)


def load_into(bag: Any, core: Any, topics: Collection[str] | None = None, start: int | None = None,
              end: int | None = None) -> tuple[str | None, int]:
    """Insert the bag's transforms (stamps in [start, end], statics always) into ``core`` in file order;
    (one line saying what was unreadable or None, transform messages read)."""
    fmt = bag.format
    load = _Load(bag, core, topics, start, end, ROS1 if fmt is BagFormat.ROS1 else MCAP)
    if fmt is BagFormat.ZENTF:
        problem = _mcap(load, bag.path, True)
    elif fmt is BagFormat.ROS2_MCAP:
        files = bag.ros._mcap_files()
        problem = None
        for file in files:
            if file.suffix == ".zstd" or not file.exists():
                problem = f"{file.name}: missing or compressed per file (not supported)"
                break
            p = _mcap(load, file, False)
            if p:
                problem = p if len(files) == 1 else f"{file.name}: {p}"
    elif fmt is BagFormat.ROS1:
        problem = _ros1(load)
    else:
        problem = _sqlite(load)
    return problem, load.loader.messages
