"""zentf's own bags: MCAP files with msgpack payloads, one channel per (key expression, sender).

File layout (MCAP, profile ``zentf``): channel ``topic`` = the key expression,
``message_encoding`` = ``msgpack``; schema ``name`` = the carried type (``tf2_msgs/msg/TFMessage``),
encoding ``msgpack``, empty data; channel metadata holds ``encoding`` (the full Zenoh encoding),
``sender`` (the attachment = tf authority), ``latched`` (``true`` for ``tf_static``: played back
through a cached advanced publisher so late joiners get it) and ``namespace`` (the recorder's
namespace, so a bag can be replayed under another one). ``log_time`` is the wall time of
reception. Reading tolerates a truncated or corrupt file (see ``mcapscan``).
"""
from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass

from .errors import BagError
from .mcapscan import MAGIC, McapChannel, McapScan
from .mcapwrite import McapFileWriter

__all__ = ["BagMessage", "BagWriter", "BagReader", "rebase_key", "is_latched_key", "PROFILE",
           "MESSAGE_ENCODING", "LATCHED_TOPICS"]

PROFILE = "zentf"
MESSAGE_ENCODING = "msgpack"
LATCHED_TOPICS = ("tf_static",)


@dataclass(slots=True)
class BagMessage:
    key: str
    type_name: str
    encoding: str
    sender: str
    latched: bool
    namespace: str
    log_time: int
    payload: bytes
    channel_id: int = 0


def is_latched_key(key: str) -> bool:
    return key.rsplit("/", 1)[-1] in LATCHED_TOPICS


def rebase_key(key: str, recorded_ns: str, play_ns: str) -> str:
    """A recorded key under the recorder's namespace moved under the player's; other keys unchanged."""
    rec = recorded_ns.strip("/")
    new = play_ns.strip("/")
    if rec == new:
        return key
    if rec:
        if key == rec or not key.startswith(rec + "/"):
            return key
        rest = key[len(rec) + 1:]
    else:
        if key == "clock":  # absolute topics recorded in the root namespace stay absolute
            return key
        rest = key
    return f"{new}/{rest}" if new else rest


class BagWriter(McapFileWriter):
    """Appends messages to an MCAP file; thread-safe; ``close()`` writes the summary (index + stats)."""

    def __init__(self, path: str | os.PathLike, *, namespace: str = "", chunk_size: int = 64 * 1024,
                 compression: str = "zstd") -> None:
        super().__init__(path, profile=PROFILE, chunk_size=chunk_size, compression=compression)
        self.namespace = namespace.strip("/")

    def _register_channel(self, ck: tuple[str, str, str], latched: bool | None) -> int:
        from zentf.transport.wire.codec import type_name_from_encoding

        key, encoding, sender = ck
        type_name = type_name_from_encoding(encoding) or ""
        sid = self._schema(type_name, MESSAGE_ENCODING, b"") if type_name else 0
        meta = {"encoding": encoding, "sender": sender,
                "latched": "true" if (is_latched_key(key) if latched is None else latched) else "false",
                "namespace": self.namespace}
        return self._writer.register_channel(topic=key, message_encoding=MESSAGE_ENCODING, schema_id=sid,
                                             metadata=meta)

    def write(self, key: str, payload: bytes, encoding: str, sender: str = "", log_time: int | None = None,
              latched: bool | None = None) -> None:
        self._append((key, encoding, sender), payload, log_time, latched)

    def __enter__(self) -> "BagWriter":
        return self


class BagReader:
    """Iterates the messages of a zentf bag in file order; ``problem`` says what was unreadable.

    Works on files without a summary (recorder killed) and on damaged files: a chunk that fails to
    decompress or whose records are garbled is skipped (``skipped_chunks``); a broken record frame
    ends the reading there.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = os.fspath(path)
        self.problem: str | None = None
        self.skipped_chunks = 0
        self.messages_read = 0
        self.has_summary = False
        try:
            with open(self.path, "rb") as f:
                head = f.read(8)
        except OSError as e:
            raise BagError(f"cannot read {self.path}: {e.strerror}") from None
        if head != MAGIC:
            raise BagError(f"{self.path} is not an MCAP bag (bad magic bytes)")

    def __iter__(self) -> Iterator[BagMessage]:
        scan = McapScan(self.path)
        self.messages_read = 0
        tuples: dict[int, tuple[str, str, str, str, bool, str]] = {}
        for ch, log_time, data in scan:
            t = tuples.get(ch.id)
            if t is None:
                t = tuples[ch.id] = _channel_tuple(ch)
            self.messages_read += 1
            yield BagMessage(t[0], t[1], t[2], t[3], t[4], t[5], log_time, data, ch.id)
        self.problem = scan.problem
        self.skipped_chunks = scan.skipped_chunks
        self.has_summary = scan.has_summary


def _channel_tuple(ch: McapChannel) -> tuple[str, str, str, str, bool, str]:
    md = ch.metadata
    tn = ch.schema.name if ch.schema else ""
    enc = md.get("encoding") or (f"application/msgpack;{tn}" if tn else "application/msgpack")
    return (ch.topic, tn, enc, md.get("sender", ""), md.get("latched", "false") == "true", md.get("namespace", ""))
