"""A linear, damage-tolerant, bounded reader of ROS 1 bags (v2.0): every ROS 1 bag zentf reads goes here.

Reads records front to back (never the whole file at once): connections and messages, inside chunks
or not, in file order. Works without the index at the end of the file (a killed recorder or a cut
copy has none); with it, ``read_index`` gives the chunk infos (where each chunk is, what times and
connections it holds) so a time window reads only its chunks. Bounded: a chunk declaring more than
``MAX_CHUNK`` bytes uncompressed is refused before anything is decompressed, and bz2/lz4 run in pieces
that stop at the declared size. A damaged chunk keeps the messages before the damage and is named
with what was wrong; a record running past the end of the file ends the reading there. Payloads stay
raw (ROS 1 serialization): rosbags' typestore or the compiled loader decodes them.
"""
from __future__ import annotations

import bz2
import os
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import BinaryIO

from .mcapscan import MAX_CHUNK, PIECE, ChunkRefused, decompress_bounded, mib

__all__ = ["Ros1Connection", "Ros1Chunk", "Ros1Scan", "fields", "MAGIC"]

MAGIC = b"#ROSBAG V2.0\n"
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")
_TIME = struct.Struct("<II")
_OP_MSG, _OP_HEADER, _OP_INDEX, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONN = 0x02, 0x03, 0x04, 0x05, 0x06, 0x07
_MAX_HEADER = 1 << 20


@dataclass(slots=True)
class Ros1Connection:
    id: int
    topic: str
    msgtype: str
    msgdef: str
    md5sum: str
    callerid: str
    latching: bool


@dataclass(slots=True)
class Ros1Chunk:
    """A chunk info record of the index: where a chunk is and what it holds."""

    offset: int
    start: int       # receive times (ns) of its first and last message
    end: int
    channels: frozenset  # connection ids with messages in it


def fields(buf: bytes | memoryview) -> dict[str, bytes]:
    """A record header's name=value fields; ValueError names what is malformed."""
    out: dict[str, bytes] = {}
    i, n = 0, len(buf)
    while i < n:
        if i + 4 > n:
            raise ValueError("header field length cut")
        (k,) = _U32.unpack_from(buf, i)
        i += 4
        if k > n - i:
            raise ValueError("header field longer than its header")
        name, sep, value = bytes(buf[i:i + k]).partition(b"=")
        if not sep:
            raise ValueError("header field without '='")
        out[name.decode("ascii", "replace")] = value
        i += k
    return out


_fields = fields


def _time(v: bytes | None) -> int:
    if v is None or len(v) != 8:
        raise ValueError("time field is not 8 bytes")
    sec, nsec = _TIME.unpack(v)  # ROS 1 time is unsigned
    return sec * 1_000_000_000 + nsec


def _bz2_pieces(data: bytes) -> Iterator[bytes]:
    dec = bz2.BZ2Decompressor()
    piece = dec.decompress(data, max_length=PIECE)
    while True:
        if piece:
            yield piece
        if dec.eof or dec.needs_input:
            return
        piece = dec.decompress(b"", max_length=PIECE)


def chunk_records(head: dict[str, bytes], data: bytes) -> tuple[bytes, str | None]:
    """(records, damage) of a chunk: all of them, or those before the damage (``damage`` says what).
    ChunkRefused (nothing decompressed) over the cap or past the declared size."""
    kind = head.get("compression", b"none")
    if "size" not in head or len(head["size"]) != 4:
        raise ValueError("chunk header without its size")
    (size,) = _U32.unpack(head["size"])
    if kind == b"none":
        if size > MAX_CHUNK:
            raise ChunkRefused(f"declares {mib(size)}, over the {mib(MAX_CHUNK)} cap")
        return data, (None if len(data) == size else f"holds {len(data)} bytes, not the {size} it declares")
    if kind == b"bz2":
        pieces: Callable[[bytes], Iterator[bytes]] | None = _bz2_pieces
        name = "bz2"
    elif kind == b"lz4":
        pieces, name = None, "lz4"
    else:
        raise ValueError(f"unknown chunk compression {kind[:20].decode('ascii', 'replace')!r}")
    out: list[bytes] = []
    try:
        for piece in decompress_bounded(name, data, size, pieces=pieces):
            out.append(piece)
    except ChunkRefused:
        raise
    except Exception as e:  # noqa: BLE001 - damaged compressed data: keep what came out before it
        got = b"".join(out)
        return got, f"{_one(e)} after {len(got)} of its {size} bytes"
    return (out[0] if len(out) == 1 else b"".join(out)), None


def _one(e: BaseException) -> str:
    text = " ".join(str(e).split())[:100]
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


class Ros1Scan:
    """Iterates (connection, log_time_ns, raw) in file order; ``problem`` says what was unreadable."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self.size = os.path.getsize(self.path)
        self.connections: dict[int, Ros1Connection] = {}
        self.problems: list[str] = []
        self.skipped_chunks = 0
        self.messages_read = 0
        self.chunks: list[Ros1Chunk] = []   # the index's chunk infos (empty without an index)
        self.index_pos = 0
        self.has_index = False
        self.on_connection: Callable[[Ros1Connection], None] | None = None
        self.unit = "messages"  # what messages_read counts, for ``problem``

    @property
    def problem(self) -> str | None:
        if not self.problems:
            return None
        more = f" (and {len(self.problems) - 1} more)" if len(self.problems) > 1 else ""
        return f"{self.problems[0]}{more}; read {self.messages_read} {self.unit}"

    def _note(self, what: str) -> None:
        if len(self.problems) < 1000:
            self.problems.append(what)

    # ------------------------------------------------------------------ records

    def records(self, f: BinaryIO, start: int, stop: int | None = None,
                want: frozenset = frozenset((_OP_MSG, _OP_CHUNK, _OP_CONN, _OP_CHUNK_INFO)),
                ) -> Iterator[tuple[int, int, dict[str, bytes], bytes]]:
        """(op, offset, header fields, data) of the records from ``start`` (data read only for the ops in
        ``want``); a record past the end of the file, or a broken header, ends them (noted)."""
        end = self.size if stop is None else min(stop, self.size)
        pos = start
        f.seek(pos)
        while pos < end:
            raw = f.read(4)
            if len(raw) < 4:
                self._note(f"stopped at byte {pos} where the file ends inside a record (truncated at byte {self.size})")
                return
            (hl,) = _U32.unpack(raw)
            if hl > _MAX_HEADER or hl > self.size - pos - 8:
                self._note(f"stopped at byte {pos} where a record header of {hl:,} bytes runs past the end of the file "
                           f"(truncated at byte {self.size})" if hl <= _MAX_HEADER else
                           f"stopped at byte {pos} where a record header claims {mib(hl)} (damaged)")
                return
            try:
                head = _fields(f.read(hl))
                (dl,) = _U32.unpack(f.read(4))
            except (ValueError, struct.error) as e:
                self._note(f"stopped at byte {pos} where a record header is damaged ({_one(e)})")
                return
            op = head.get("op", b"\x00")[:1]
            op = op[0] if op else 0
            if dl > self.size - pos - 8 - hl:
                if op == _OP_CHUNK:
                    self._note(f"stopped at byte {pos} where a chunk is cut by the end of the file "
                               f"(truncated at byte {self.size})")
                    yield -1, pos, head, f.read(min(dl, MAX_CHUNK + 1024))
                else:
                    self._note(f"stopped at byte {pos} where a record runs past the end of the file "
                               f"(truncated at byte {self.size})")
                return
            if op in want:
                if dl > MAX_CHUNK + 1024:
                    self._note(f"the record at byte {pos} is {mib(dl)} long, over the {mib(MAX_CHUNK)} cap; skipped")
                    self.skipped_chunks += op == _OP_CHUNK
                    f.seek(pos + 8 + hl + dl)
                else:
                    yield op, pos, head, f.read(dl)
            else:
                f.seek(pos + 8 + hl + dl)
            pos += 8 + hl + dl

    def read_index(self) -> bool:
        """The bag header's index: connections and chunk infos; False if there is no usable one."""
        try:
            with open(self.path, "rb") as f:
                if f.read(13) != MAGIC:
                    return False
                (hl,) = _U32.unpack(f.read(4))
                if hl > 4096:
                    return False
                head = _fields(f.read(hl))
                if head.get("op") != bytes([_OP_HEADER]) or len(head.get("index_pos", b"")) != 8:
                    return False
                (pos,) = _U64.unpack(head["index_pos"])
                if not 13 < pos < self.size:
                    return False
                chunks = []
                saved, self.problems = self.problems, []
                for op, _, h, data in self.records(f, pos, want=frozenset((_OP_CONN, _OP_CHUNK_INFO))):
                    if op == _OP_CONN:
                        self._connection(h, data)
                    elif op == _OP_CHUNK_INFO:
                        (at,) = _U64.unpack(h["chunk_pos"])
                        conns = frozenset(_U32.unpack_from(data, i)[0] for i in range(0, len(data) - 7, 8))
                        chunks.append(Ros1Chunk(at, _time(h.get("start_time")), _time(h.get("end_time")), conns))
                bad, self.problems = self.problems, saved
                if bad:
                    return False
                self.chunks = sorted(chunks, key=lambda c: c.offset)
                self.index_pos = pos
                self.has_index = True
                return True
        except (OSError, ValueError, KeyError, struct.error):
            return False

    def _connection(self, head: dict[str, bytes], data: bytes) -> None:
        cid = _U32.unpack(head["conn"])[0]
        f = _fields(data)
        text = lambda k: f.get(k, b"").decode("utf-8", "replace")  # noqa: E731
        typ = text("type")
        if "/" in typ and "/msg/" not in typ:
            pkg, _, name = typ.partition("/")
            typ = f"{pkg}/msg/{name}"
        known = self.connections.get(cid)
        conn = Ros1Connection(cid, head.get("topic", b"").decode("utf-8", "replace") or text("topic"),
                              typ, text("message_definition"), text("md5sum"), text("callerid"),
                              text("latching") == "1")
        if known != conn:
            self.connections[cid] = conn
            if self.on_connection is not None:
                self.on_connection(conn)

    # ------------------------------------------------------------------ messages

    def __iter__(self) -> Iterator[tuple[Ros1Connection, int, bytes]]:
        self.problems = []
        self.messages_read = 0
        self.skipped_chunks = 0
        self.read_index()
        with open(self.path, "rb") as f:
            if f.read(13) != MAGIC:
                self._note("bad magic line")
                return
            stop = self.index_pos if self.has_index else None
            for op, off, head, data in self.records(f, 13, stop):
                try:
                    if op == _OP_CONN:
                        self._connection(head, data)
                    elif op == _OP_MSG:
                        item = self._message(head, data)
                        if item is not None:
                            yield item
                    elif op in (_OP_CHUNK, -1):
                        yield from self._chunk(head, data, off, op == -1)
                except (ValueError, KeyError, struct.error) as e:
                    self._note(f"skipped a damaged record at byte {off} ({_one(e)})")
        if not self.has_index and not self.problems:
            self._note("no index (the recorder did not close the file); read linearly")

    def _chunk(self, head: dict[str, bytes], data: bytes, off: int, cut: bool) -> Iterator[tuple]:
        try:
            inner, damage = chunk_records(head, data)
        except ChunkRefused as e:
            self.skipped_chunks += 1
            self._note(f"the chunk at byte {off} {e}")
            return
        except ValueError as e:
            self.skipped_chunks += 1
            self._note(f"skipped a damaged chunk at byte {off} ({_one(e)})")
            return
        kept = 0
        i, n = 0, len(inner)
        mv = memoryview(inner)
        while i < n:
            try:
                if n - i < 8:
                    raise ValueError("a record is cut short")
                (hl,) = _U32.unpack_from(inner, i)
                if hl > n - i - 8:
                    raise ValueError("a record header runs past the chunk")
                h2 = _fields(mv[i + 4:i + 4 + hl])
                (dl,) = _U32.unpack_from(inner, i + 4 + hl)
                start = i + 8 + hl
                if dl > n - start:
                    raise ValueError("a record runs past the chunk")
                op2 = h2.get("op", b"\x00")[:1]
                if op2 == b"\x07":
                    self._connection(h2, inner[start:start + dl])
                elif op2 == b"\x02":
                    item = self._message(h2, inner[start:start + dl])
                    if item is not None:
                        kept += 1
                        yield item
                i = start + dl
            except (ValueError, KeyError, struct.error) as e:
                damage = damage or _one(e)
                break
        if cut:
            self.problems[-1] += f"; kept the first {kept} messages of that chunk"
        elif damage is not None:
            self.skipped_chunks += 1
            self._note(f"skipped a damaged chunk at byte {off} ({damage}; kept {kept} messages before it)")

    def _message(self, head: dict[str, bytes], body: bytes) -> tuple[Ros1Connection, int, bytes] | None:
        conn = self.connections.get(_U32.unpack(head["conn"])[0])
        if conn is None:
            return None
        self.messages_read += 1
        return conn, _time(head.get("time")), bytes(body)
