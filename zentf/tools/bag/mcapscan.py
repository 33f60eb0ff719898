"""A fast, damage-tolerant MCAP record scanner shared by zentf's and ROS 2's MCAP files.

Reads the file front to back in records (never the whole file at once), parses chunk contents
with ``struct`` (the mcap package's StreamReader builds an object per record, ~5x slower), and
yields (channel, log_time, payload) in file order. A chunk that fails to decompress, fails its
CRC or holds garbled records is skipped (``skipped_chunks``); a record running past the end of
the file ends the reading (``problem`` says where). Channels and schemas are taken from the
summary too, so messages of a chunk whose channel record was lost are still attributed.
"""
from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, BinaryIO

__all__ = ["McapSchema", "McapChannel", "McapScan", "MAGIC"]

MAGIC = b"\x89MCAP0\r\n"
_HEADER, _FOOTER, _SCHEMA, _CHANNEL, _MESSAGE, _CHUNK, _DATA_END = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F
_REC = struct.Struct("<BQ")
_MSG = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, uncompressed crc
_MAX_RECORD = 1 << 31


@dataclass(slots=True)
class McapSchema:
    id: int
    name: str
    encoding: str
    data: bytes


@dataclass(slots=True)
class McapChannel:
    id: int
    schema_id: int
    topic: str
    message_encoding: str
    metadata: dict[str, str] = field(default_factory=dict)
    schema: McapSchema | None = None


def _string(buf: bytes | memoryview, i: int) -> tuple[str, int]:
    (n,) = _U32.unpack_from(buf, i)
    i += 4
    if n > len(buf) - i:
        raise ValueError("string runs past its record")
    return bytes(buf[i:i + n]).decode("utf-8"), i + n


def _schema(buf: bytes | memoryview) -> McapSchema:
    (sid,) = _U16.unpack_from(buf, 0)
    name, i = _string(buf, 2)
    enc, i = _string(buf, i)
    (n,) = _U32.unpack_from(buf, i)
    return McapSchema(sid, name, enc, bytes(buf[i + 4:i + 4 + n]))


def _channel(buf: bytes | memoryview, schemas: dict[int, McapSchema]) -> McapChannel:
    cid, sid = struct.unpack_from("<HH", buf, 0)
    topic, i = _string(buf, 4)
    enc, i = _string(buf, i)
    (n,) = _U32.unpack_from(buf, i)
    i += 4
    end = i + n
    meta = {}
    while i < end:
        k, i = _string(buf, i)
        v, i = _string(buf, i)
        meta[k] = v
    return McapChannel(cid, sid, topic, enc, meta, schemas.get(sid))


def _decompress(kind: str, data: bytes, size: int) -> bytes:
    if kind == "":
        return data
    if kind == "zstd":
        import zstandard

        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if kind == "lz4":
        import lz4.frame

        return lz4.frame.decompress(data)
    raise ValueError(f"unknown chunk compression {kind!r}")


def _salvage(kind: str, data: bytes) -> bytes:
    """As much of a damaged or cut chunk as decompresses, fed in pieces so the output before the
    damage is kept (zstd and lz4 emit whole blocks, so what comes out was checked block by block)."""
    if kind == "":
        return data
    if kind == "zstd":
        import zstandard

        dec: Any = zstandard.ZstdDecompressor().decompressobj()
    elif kind == "lz4":
        import lz4.frame

        dec = lz4.frame.LZ4FrameDecompressor()
    else:
        return b""
    out = []
    for i in range(0, len(data), 16384):
        try:
            out.append(dec.decompress(data[i:i + 16384]))
        except Exception:  # noqa: BLE001 - the damage: keep what came before it
            break
    return b"".join(out)


class McapScan:
    """Iterates (channel, log_time, payload) of an MCAP file in file order, tolerating damage."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self.problem: str | None = None
        self.skipped_chunks = 0
        self.has_summary = False
        self.profile = ""
        self.schemas: dict[int, McapSchema] = {}
        self.channels: dict[int, McapChannel] = {}
        self.size = os.path.getsize(self.path)

    # ------------------------------------------------------------------ summary

    def read_summary(self) -> None:
        """Schemas and channels of the summary section (nothing if there is no readable one)."""
        try:
            with open(self.path, "rb") as f:
                if self.size < 8 + 9 + 20 + 8:
                    return
                f.seek(self.size - 8 - 29)
                foot = f.read(29)
                if foot[0] != _FOOTER:
                    return
                (start,) = _U64.unpack_from(foot, 9)
                if not 8 < start < self.size:
                    return
                f.seek(start)
                for op, body in self._frames(f, self.size - 8):
                    self._definition(op, body)
        except (ValueError, struct.error, EOFError, UnicodeDecodeError):
            return

    def _definition(self, op: int, body: bytes | memoryview) -> None:
        if op == _SCHEMA:
            s = _schema(body)
            self.schemas[s.id] = s
            for ch in self.channels.values():
                if ch.schema_id == s.id:
                    ch.schema = s
        elif op == _CHANNEL:
            ch = _channel(body, self.schemas)
            self.channels[ch.id] = ch
        elif op == _HEADER:
            self.profile, _ = _string(body, 0)

    @staticmethod
    def _frames(f: BinaryIO, end: int) -> Iterator[tuple[int, bytes]]:
        """(opcode, content) of each record from f's position to ``end``; EOFError past the end."""
        pos = f.tell()
        while pos < end:
            head = f.read(9)
            if len(head) < 9:
                raise EOFError(pos)
            op, n = _REC.unpack(head)
            if n > end - pos - 9 or n > _MAX_RECORD:
                raise EOFError(pos)
            body = f.read(n)
            if len(body) < n:
                raise EOFError(pos)
            yield op, body
            pos += 9 + n
            if op == _FOOTER:
                return

    # ------------------------------------------------------------------ messages

    def __iter__(self) -> Iterator[tuple[McapChannel, int, bytes]]:
        self.problem = None
        self.skipped_chunks = 0
        self.read_summary()
        channels = self.channels
        with open(self.path, "rb") as f:
            if f.read(8) != MAGIC:
                self.problem = "bad magic bytes"
                return
            pos = 8
            try:
                for op, body in self._frames(f, self.size):
                    start = pos
                    pos += 9 + len(body)
                    if op == _MESSAGE:
                        cid, _, log_time, _ = _MSG.unpack_from(body, 0)
                        ch = channels.get(cid)
                        if ch is not None:
                            yield ch, log_time, body[22:]
                    elif op == _CHUNK:
                        yield from self._chunk(body, start)
                    elif op in (_SCHEMA, _CHANNEL, _HEADER):
                        try:
                            self._definition(op, body)
                        except (ValueError, struct.error, UnicodeDecodeError) as e:
                            self.problem = f"corrupt record near byte {start} ({type(e).__name__})"
                            return
                    elif op in (_DATA_END, _FOOTER):
                        self.has_summary = True
                        return
            except EOFError as e:
                where = e.args[0] if e.args else pos
                yield from self._cut_chunk(f, where)
                self.problem = f"stopped at byte {where} (a record runs past the end): truncated at byte {self.size}"
                return
        if self.problem is None:
            self.problem = "no summary (the recorder did not close the file)"

    def _records(self, data: bytes, out: list, strict: bool) -> None:
        """Messages of a chunk's records into ``out``; a bad record raises (strict) or ends it."""
        j, end = 0, len(data)
        channels = self.channels
        while j + 9 <= end:
            op, m = _REC.unpack_from(data, j)
            j += 9
            if m > end - j or (op == _MESSAGE and m < 22):
                if strict:
                    raise ValueError("record runs past the chunk")
                return
            if op == _MESSAGE:
                cid, _, log_time, _ = _MSG.unpack_from(data, j)
                ch = channels.get(cid)
                if ch is not None:
                    out.append((ch, log_time, data[j + 22:j + m]))
            elif op in (_SCHEMA, _CHANNEL):
                self._definition(op, data[j:j + m])
            j += m
        if strict and j != end:
            raise ValueError("record runs past the chunk")

    def _chunk(self, body: bytes, where: int) -> Iterator[tuple[McapChannel, int, bytes]]:
        out: list = []
        try:
            _, _, size, crc = _CHUNK_HEAD.unpack_from(body, 0)
            kind, i = _string(body, 28)
            (n,) = _U64.unpack_from(body, i)
            i += 8
            if n > len(body) - i:
                raise ValueError("chunk records run past the chunk")
            try:
                data = _decompress(kind, body[i:i + n], size)
            except Exception:  # noqa: BLE001 - damaged compressed data: keep what decodes before it
                self._records(_salvage(kind, body[i:i + n]), out, strict=False)
                raise
            if crc and zlib.crc32(data) != crc:
                raise ValueError("CRC mismatch")  # no telling which records are wrong: none is kept
            self._records(data, out, strict=True)
        except Exception as e:  # noqa: BLE001 - a damaged chunk: skip (the rest of) it, go on
            self.skipped_chunks += 1
            kept = f", kept {len(out)} messages before the damage" if out else ""
            self.problem = f"skipped a damaged chunk at byte {where} ({type(e).__name__}: {str(e)[:60]}{kept})"
            if not out:
                return
        yield from out

    def _cut_chunk(self, f: BinaryIO, where: int) -> Iterator[tuple[McapChannel, int, bytes]]:
        """The whole messages of a chunk cut by the end of the file."""
        try:
            f.seek(where)
            head = f.read(9)
            if len(head) < 9 or head[0] != _CHUNK:
                return
            body = f.read()
            kind, i = _string(body, 28)
            i += 8
            out: list = []
            self._records(_salvage(kind, body[i:]), out, strict=False)
        except (ValueError, struct.error, UnicodeDecodeError, OSError):
            return
        yield from out
