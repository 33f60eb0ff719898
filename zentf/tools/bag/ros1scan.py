"""A linear, damage-tolerant reader of ROS 1 bags (v2.0), for files rosbags' indexed reader refuses.

rosbags needs the index at the end of the file; a recorder that was killed or a cut copy has
none. This reads records front to back: connections and messages, inside chunks or not. A chunk
that fails to decompress is skipped; a broken record frame ends the reading there. Payloads stay
raw (ROS 1 serialization): rosbags' typestore decodes them.
"""
from __future__ import annotations

import bz2
import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass

__all__ = ["Ros1Connection", "Ros1Scan"]

_U32 = struct.Struct("<I")
_OP_MSG, _OP_CHUNK, _OP_CONN = 0x02, 0x05, 0x07


@dataclass(slots=True)
class Ros1Connection:
    id: int
    topic: str
    msgtype: str
    msgdef: str
    md5sum: str
    callerid: str
    latching: bool


def _fields(buf: bytes | memoryview) -> dict[str, bytes]:
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


def _records(buf: memoryview, base: int, partial_chunk: bool = False
             ) -> Iterator[tuple[int, dict[str, bytes], memoryview]]:
    """(offset, header fields, data) of each record; raises ValueError at a broken frame and
    EOFError(offset) at one running past the end (with ``partial_chunk``, a chunk cut by the end is
    still yielded with the bytes there are, then EOFError)."""
    i, n = 0, len(buf)
    while i < n:
        if i + 4 > n:
            raise EOFError(base + i)
        (hl,) = _U32.unpack_from(buf, i)
        if hl > n - i - 8:
            raise EOFError(base + i)
        head = _fields(buf[i + 4:i + 4 + hl])
        (dl,) = _U32.unpack_from(buf, i + 4 + hl)
        start = i + 8 + hl
        if dl > n - start:
            if partial_chunk and head.get("op", b"\x00")[0] == _OP_CHUNK:
                yield base + i, head, buf[start:]
            raise EOFError(base + i)
        yield base + i, head, buf[start:start + dl]
        i = start + dl


def _decompress(kind: bytes, data: memoryview, size: int) -> bytes:
    """The chunk's records; of a chunk cut short, as much as its compressed prefix gives."""
    if kind == b"none":
        return bytes(data)
    if kind == b"bz2":
        return bz2.BZ2Decompressor().decompress(data)
    if kind == b"lz4":
        import lz4.frame

        return lz4.frame.LZ4FrameDecompressor().decompress(bytes(data))
    raise ValueError(f"unknown chunk compression {kind.decode('ascii', 'replace')!r}")


class Ros1Scan:
    """Iterates (connection, log_time_ns, raw) in file order; ``problem`` says where it stopped."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self.connections: dict[int, Ros1Connection] = {}
        self.problem: str | None = None
        self.skipped_chunks = 0

    def _connection(self, head: dict[str, bytes], data: memoryview) -> None:
        cid = _U32.unpack(head["conn"])[0]
        f = _fields(data)
        text = lambda k: f.get(k, b"").decode("utf-8", "replace")  # noqa: E731
        typ = text("type")
        if "/" in typ and "/msg/" not in typ:
            pkg, _, name = typ.partition("/")
            typ = f"{pkg}/msg/{name}"
        self.connections[cid] = Ros1Connection(cid, head.get("topic", b"").decode("utf-8", "replace") or text("topic"),
                                               typ, text("message_definition"), text("md5sum"), text("callerid"),
                                               text("latching") == "1")

    def __iter__(self) -> Iterator[tuple[Ros1Connection, int, bytes]]:
        self.problem = None
        with open(self.path, "rb") as f:
            data = memoryview(f.read())
        size = len(data)
        pos = 13  # after the magic line
        try:
            for off, head, body in _records(data[pos:], pos, partial_chunk=True):
                op = head.get("op", b"\x00")[0]
                if op == _OP_CONN:
                    self._connection(head, body)
                elif op == _OP_MSG:
                    yield from self._message(head, body)
                elif op == _OP_CHUNK:
                    try:
                        inner = _decompress(head.get("compression", b"none"), body,
                                            _U32.unpack(head["size"])[0] if "size" in head else 0)
                    except Exception as e:  # noqa: BLE001 - a damaged chunk: skip it, go on
                        self.skipped_chunks += 1
                        self.problem = f"skipped a damaged chunk at byte {off} ({type(e).__name__})"
                        continue
                    records = []
                    try:
                        records.extend(_records(memoryview(inner), 0))
                    except EOFError:  # a chunk cut by the end of the file: its whole records count
                        pass
                    except (ValueError, KeyError, struct.error) as e:
                        self.skipped_chunks += 1
                        self.problem = f"skipped a damaged chunk at byte {off} ({type(e).__name__})"
                        continue
                    for _, h2, b2 in records:
                        op2 = h2.get("op", b"\x00")[0]
                        if op2 == _OP_CONN:
                            self._connection(h2, b2)
                        elif op2 == _OP_MSG:
                            yield from self._message(h2, b2)
        except EOFError as e:
            self.problem = f"stopped at byte {e.args[0]} (a record runs past the end): truncated at byte {size}"
        except (ValueError, KeyError, struct.error) as e:
            self.problem = f"corrupt record ({type(e).__name__}: {str(e)[:60]})"

    def _message(self, head: dict[str, bytes], body: memoryview) -> Iterator[tuple[Ros1Connection, int, bytes]]:
        conn = self.connections.get(_U32.unpack(head["conn"])[0])
        if conn is None:
            return
        sec, nsec = struct.unpack("<II", head["time"])
        yield conn, sec * 1_000_000_000 + nsec, bytes(body)
