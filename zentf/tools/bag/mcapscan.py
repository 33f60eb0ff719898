"""A fast, damage-tolerant, bounded MCAP record scanner shared by zentf's and ROS 2's MCAP files.

Reads the file front to back in records (never the whole file at once), parses chunk contents
with ``struct`` (the mcap package's StreamReader builds an object per record, which would dominate
a load), and yields (channel, log_time, payload) in file order. Channels and schemas are taken from the
summary too, so messages of a chunk whose channel record was lost are still attributed.

Bounded: a chunk declaring more than ``MAX_CHUNK`` bytes uncompressed is refused before anything is
decompressed, and decompression runs in pieces of at most ``PIECE`` bytes that stop at the declared
size (a chunk that expands past it is refused): a decompression bomb costs at most ``MAX_CHUNK``.
Damage: a chunk that fails to decompress keeps the messages before the damage, one that fails its
CRC is skipped (``skipped_chunks``); a record whose length runs past the end of the file is either a
damaged length (reading resumes at the next chunk, found from the summary's chunk index or by its
shape) or the file's cut end (the whole messages of a cut chunk are kept). ``problem`` says what and
where in one line, with how many messages were read.
"""
from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, BinaryIO

__all__ = ["McapSchema", "McapChannel", "McapChunk", "McapScan", "MAGIC", "MAX_CHUNK", "PIECE", "ChunkRefused",
           "decompress_bounded", "mib"]

MAGIC = b"\x89MCAP0\r\n"
_HEADER, _FOOTER, _SCHEMA, _CHANNEL, _MESSAGE, _CHUNK, _MSG_INDEX, _CHUNK_INDEX, _DATA_END = (
    0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x0F)
_REC = struct.Struct("<BQ")
_MSG = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_U16, _U32, _U64 = struct.Struct("<H"), struct.Struct("<I"), struct.Struct("<Q")
_CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, uncompressed crc
#: The largest chunk (uncompressed) or record read: real writers use 1-4 MiB chunks; a larger one is refused.
MAX_CHUNK = 64 << 20
#: Decompression output per step: a chunk's data grows by at most this much between size checks.
PIECE = 1 << 20
_KINDS = ("", "zstd", "lz4")


def mib(n: int) -> str:
    """A byte count for a one-line report."""
    return f"{n / (1 << 20):,.1f} MiB" if n >= 1 << 20 else f"{n:,} bytes"


class ChunkRefused(ValueError):
    """A chunk or record over the size cap, or expanding past its declared size: not decompressed."""


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


@dataclass(slots=True)
class McapChunk:
    """One entry of the summary's chunk index: where a chunk is and what log times it covers."""

    start: int          # first message's log time (ns)
    end: int            # last message's log time (ns)
    offset: int         # of the chunk record in the file
    length: int         # of the chunk record
    channels: frozenset  # channel ids with messages in it (its message index offsets)


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


def _chunk_index(buf: bytes) -> McapChunk:
    start, end, offset, length = struct.unpack_from("<QQQQ", buf, 0)
    (n,) = _U32.unpack_from(buf, 32)
    if n > len(buf) - 36:
        raise ValueError("chunk index runs past its record")
    channels = frozenset(_U16.unpack_from(buf, 36 + i)[0] for i in range(0, n - n % 10, 10))
    return McapChunk(start, end, offset, length, channels)


def _decompressor(kind: str) -> Callable[[bytes], Iterator[bytes]]:
    """A function compressed bytes -> pieces of at most PIECE decompressed bytes."""
    if kind == "zstd":
        import zstandard

        def zstd(data: bytes) -> Iterator[bytes]:
            reader = zstandard.ZstdDecompressor().stream_reader(data, read_across_frames=True)
            while True:
                piece = reader.read(PIECE)
                if not piece:
                    return
                yield piece
        return zstd
    if kind == "lz4":
        import lz4.frame

        def lz4f(data: bytes) -> Iterator[bytes]:
            dec = lz4.frame.LZ4FrameDecompressor()
            piece = dec.decompress(data, max_length=PIECE)
            while True:
                if piece:
                    yield piece
                if dec.eof or dec.needs_input:
                    return
                piece = dec.decompress(b"", max_length=PIECE)
        return lz4f
    raise ValueError(f"unknown chunk compression {kind!r}")


def decompress_bounded(kind: str, data: bytes, size: int, cap: int = MAX_CHUNK, *,
                       pieces: Callable[[bytes], Iterator[bytes]] | None = None) -> Iterator[bytes]:
    """The decompressed pieces of ``data`` (at most PIECE bytes each), which must come to ``size``
    bytes. ChunkRefused before anything is decompressed if ``size`` is over ``cap``, and as soon as the
    output passes ``size``; ValueError if it ends short of it, any decoder error as raised."""
    if size > cap:
        raise ChunkRefused(f"declares {mib(size)} uncompressed, over the {mib(cap)} cap; not decompressed")
    if kind == "":
        if len(data) != size:
            raise ValueError(f"holds {len(data)} bytes, not the {size} it declares")
        yield data
        return
    total = 0
    for piece in (pieces or _decompressor(kind))(data):
        total += len(piece)
        if total > size:
            raise ChunkRefused(f"expands past the {mib(size)} it declares; refused at {mib(total)}")
        yield piece
    if total != size:
        raise ValueError(f"decompresses to {total} bytes, not the {size} it declares")


class McapScan:
    """Iterates (channel, log_time, payload) of an MCAP file in file order, tolerating damage."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self.problems: list[str] = []
        self.skipped_chunks = 0
        self.messages_read = 0
        self.has_summary = False
        self.profile = ""
        self.schemas: dict[int, McapSchema] = {}
        self.channels: dict[int, McapChannel] = {}
        self.chunks: list[McapChunk] = []     # the summary's chunk index (empty without one)
        self.summary_start = 0
        self.size = os.path.getsize(self.path)
        self.on_definition: Callable[[McapChannel], None] | None = None
        self.unit = "messages"  # what messages_read counts, for ``problem``

    @property
    def problem(self) -> str | None:
        """One line: the first damage found (and how many more), and how much was read."""
        if not self.problems:
            return None
        more = f" (and {len(self.problems) - 1} more problem{'s' if len(self.problems) > 2 else ''})" \
            if len(self.problems) > 1 else ""
        return f"{self.problems[0]}{more}; read {self.messages_read} {self.unit}"

    def _note(self, what: str) -> None:
        if len(self.problems) < 1000:
            self.problems.append(what)

    # ------------------------------------------------------------------ summary

    def read_summary(self) -> None:
        """Schemas, channels and the chunk index of the summary section (nothing if there is no readable one)."""
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
                chunks = []
                pos = start
                while pos < self.size - 8:
                    head = f.read(9)
                    if len(head) < 9:
                        return
                    op, n = _REC.unpack(head)
                    if n > self.size - pos - 9 or n > MAX_CHUNK:
                        return
                    body = f.read(n)
                    if op == _FOOTER:
                        break
                    if op == _CHUNK_INDEX:
                        chunks.append(_chunk_index(body))
                    else:
                        self._definition(op, body)
                    pos += 9 + n
                self.chunks = sorted(chunks, key=lambda c: c.offset)
                self.summary_start = start
        except (ValueError, struct.error, EOFError, UnicodeDecodeError):
            return

    def _definition(self, op: int, body: bytes | memoryview) -> None:
        if op == _SCHEMA:
            s = _schema(body)
            self.schemas[s.id] = s
            for ch in self.channels.values():
                if ch.schema_id == s.id:
                    ch.schema = s
                    if self.on_definition is not None:
                        self.on_definition(ch)
        elif op == _CHANNEL:
            ch = _channel(body, self.schemas)
            known = self.channels.get(ch.id)
            if known is None or known.topic != ch.topic or known.schema is None:
                self.channels[ch.id] = ch
                if self.on_definition is not None:
                    self.on_definition(ch)
        elif op == _HEADER:
            self.profile, _ = _string(body, 0)

    # ------------------------------------------------------------------ top-level records

    def units(self, f: BinaryIO, start: int = 8, stop: int | None = None,
              want: Callable[[int], bool] | None = None) -> Iterator[tuple[int, int, bytes]]:
        """(opcode, offset, body) of the top-level records from ``start``, in file order, bodies read
        only for the opcodes ``want`` (default: definitions, messages, chunks); ends at the data end, the
        footer or ``stop``. A length past the end of the file resumes at the next chunk, or ends the
        reading at a cut chunk (whose whole messages come as a ``-1`` unit: the bytes there are)."""
        end = self.size if stop is None else min(stop, self.size)
        if want is None:
            want = _WANTED.__contains__
        pos = start
        f.seek(pos)
        while pos < end:
            head = f.read(9)
            if len(head) < 9:
                self._note(f"the file ends inside the record at byte {pos} (truncated at byte {self.size})")
                return
            op, n = _REC.unpack(head)
            if n > self.size - pos - 9:
                nxt = self._resync(f, pos)
                if nxt is None:
                    if op == _CHUNK:
                        self._note(f"the chunk at byte {pos} is cut by the end of the file (truncated at byte "
                                   f"{self.size})")
                        f.seek(pos + 9)
                        yield -1, pos, f.read(min(self.size - pos - 9, MAX_CHUNK + 1024))
                    else:
                        self._note(f"the record at byte {pos} runs past the end of the file "
                                   f"(truncated at byte {self.size})")
                    return
                self._note(f"the record at byte {pos} has a damaged length ({n:,} bytes, past the end of the "
                           f"file); resumed at the next record, byte {nxt}")
                self.skipped_chunks += 1
                pos = nxt
                f.seek(pos)
                continue
            if op in (_DATA_END, _FOOTER):
                self.has_summary = True
                return
            if want(op):
                if n > MAX_CHUNK + 1024:
                    self._note(f"the record at byte {pos} is {mib(n)} long, over the {mib(MAX_CHUNK)} cap; skipped")
                    if op == _CHUNK:
                        self.skipped_chunks += 1
                    f.seek(pos + 9 + n)
                else:
                    body = f.read(n)
                    yield op, pos, body
            else:
                f.seek(pos + 9 + n)
            pos += 9 + n

    def _resync(self, f: BinaryIO, pos: int) -> int | None:
        """The offset of the next chunk (or message index) after a damaged record at ``pos``; None if
        there is none (the file is cut there)."""
        for c in self.chunks:
            if c.offset > pos:
                return c.offset
        if self.chunks:  # the last chunk: the summary is intact, the file is not cut
            return self.summary_start if self.summary_start > pos else None
        window = 4 << 20
        at = pos + 1
        while at < self.size - 9:
            f.seek(at)
            buf = f.read(window + 64)
            i = 0
            while True:
                i = _next_candidate(buf, i)
                if i < 0 or i >= window:
                    break
                if _plausible(buf, i, self.size - at - i):
                    return at + i
                i += 1
            at += window
        return None

    # ------------------------------------------------------------------ chunks

    def chunk_data(self, body: bytes, where: int, cut: bool = False) -> tuple[bytes, str | None]:
        """(records, problem) of a chunk record's body: all of them, or those before the damage
        (``problem`` says what it was). ChunkRefused (nothing decompressed) over the caps."""
        _, _, size, crc = _CHUNK_HEAD.unpack_from(body, 0)
        kind, i = _string(body, 28)
        (n,) = _U64.unpack_from(body, i)
        i += 8
        data = body[i:i + n]
        if not cut and n > len(body) - i:
            raise ValueError("its records run past the chunk")
        if kind not in _KINDS:
            raise ValueError(f"unknown compression {kind[:20]!r}")
        out: list[bytes] = []
        try:
            for piece in decompress_bounded(kind, data, size):
                out.append(piece)
        except ChunkRefused:
            raise
        except Exception as e:  # noqa: BLE001 - damaged compressed data: keep what came out before it
            got = b"".join(out)
            return got, f"{_one(e)} after {len(got)} of its {size} bytes"
        got = out[0] if len(out) == 1 else b"".join(out)
        if crc and zlib.crc32(got) != crc:
            return b"", "CRC mismatch (no telling which records are wrong: none is kept)"
        return got, None

    # ------------------------------------------------------------------ messages

    def __iter__(self) -> Iterator[tuple[McapChannel, int, bytes]]:
        self.problems = []
        self.skipped_chunks = 0
        self.messages_read = 0
        self.read_summary()
        channels = self.channels
        with open(self.path, "rb") as f:
            if f.read(8) != MAGIC:
                self._note("bad magic bytes")
                return
            for op, where, body in self.units(f):
                if op == _MESSAGE:
                    if len(body) < 22:
                        continue
                    cid, _, log_time, _ = _MSG.unpack_from(body, 0)
                    ch = channels.get(cid)
                    if ch is not None:
                        self.messages_read += 1
                        yield ch, log_time, body[22:]
                elif op in (_CHUNK, -1):
                    yield from self._chunk(body, where, op == -1)
                else:
                    try:
                        self._definition(op, body)
                    except (ValueError, struct.error, UnicodeDecodeError) as e:
                        self._note(f"the record at byte {where} is corrupt ({type(e).__name__})")
        if not self.problems and not self.has_summary:
            self._note("no summary (the recorder did not close the file)")

    def _chunk(self, body: bytes, where: int, cut: bool) -> Iterator[tuple[McapChannel, int, bytes]]:
        try:
            data, damage = self.chunk_data(body, where, cut)
        except ChunkRefused as e:
            self.skipped_chunks += 1
            self._note(f"the chunk at byte {where} {e}")
            return
        except (ValueError, struct.error, UnicodeDecodeError) as e:
            self.skipped_chunks += 1
            self._note(f"skipped a damaged chunk at byte {where} ({_one(e)})")
            return
        kept = 0
        for item in self._records(data, damage is None and not cut):
            if item is None:
                damage = damage or "a record runs past the end of the chunk"
                break
            kept += 1
            self.messages_read += 1
            yield item
        if damage is not None and not cut:
            self.skipped_chunks += 1
            self._note(f"skipped a damaged chunk at byte {where} ({damage}; kept {kept} messages before it)")
        elif cut:
            self.problems[-1] += f"; kept its first {kept} messages"

    def _records(self, data: bytes, strict: bool) -> Iterator[Any]:
        """(channel, log_time, payload) of a chunk's records; a None item where a bad record ends them."""
        j, end = 0, len(data)
        channels = self.channels
        unpack = _REC.unpack_from
        msg = _MSG.unpack_from
        mv = memoryview(data)
        while j + 9 <= end:
            op, m = unpack(data, j)
            j += 9
            if m > end - j or (op == _MESSAGE and m < 22):
                yield None
                return
            if op == _MESSAGE:
                cid, _, log_time, _ = msg(data, j)
                ch = channels.get(cid)
                if ch is not None:
                    yield ch, log_time, bytes(mv[j + 22:j + m])
            elif op in (_SCHEMA, _CHANNEL):
                try:
                    self._definition(op, mv[j:j + m])
                except (ValueError, struct.error, UnicodeDecodeError):
                    yield None
                    return
            j += m
        if strict and j != end:
            yield None


_WANTED = frozenset((_HEADER, _SCHEMA, _CHANNEL, _MESSAGE, _CHUNK))


def _one(e: BaseException) -> str:
    text = " ".join(str(e).split())[:100]
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


def _next_candidate(buf: bytes, i: int) -> int:
    """The next offset at or after i holding a chunk, message index or data end opcode; -1 if none."""
    found = [k for k in (buf.find(b"\x06", i), buf.find(b"\x07", i), buf.find(b"\x0f", i)) if k >= 0]
    return min(found) if found else -1


def _plausible(buf: bytes, i: int, left: int) -> bool:
    """Whether a record starting at buf[i] looks whole and well-formed (for resynchronizing)."""
    if len(buf) - i < 9:
        return False
    op, n = _REC.unpack_from(buf, i)
    if n > left - 9:
        return False
    if op == _DATA_END:
        return n == 4
    if op == _MSG_INDEX:
        if n < 6 or len(buf) - i < 15:
            return False
        (rl,) = _U32.unpack_from(buf, i + 11)
        return rl == n - 6 and rl % 16 == 0
    if op != _CHUNK or n < 40 or len(buf) - i < 9 + 40:
        return False
    start, stop, size, _ = _CHUNK_HEAD.unpack_from(buf, i + 9)
    (kl,) = _U32.unpack_from(buf, i + 37)
    if stop < start or kl > 4 or len(buf) - i < 9 + 32 + kl + 8:
        return False
    kind = buf[i + 41:i + 41 + kl]
    if kind not in (b"", b"zstd", b"lz4"):
        return False
    (rn,) = _U64.unpack_from(buf, i + 41 + kl)
    return rn == n - 32 - kl - 8 and (kind != b"" or size == rn)
