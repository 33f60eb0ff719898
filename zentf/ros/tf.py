"""tf2_msgs/msg/TFMessage in CDR, hand-laid for speed: the hot path of a listener on a ROS 2 graph.

One TransformStamped in XCDR1 little-endian is: int32 sec, uint32 nanosec, string frame_id, string
child_frame_id (each a uint32 length counting the NUL, the bytes, the NUL, then padding to 4), padding
to 8 (counted from the end of the encapsulation header), 7 float64 (translation x y z, rotation x y z w).
``tf_samples`` reads that into the tuples ``BufferCore.set_transforms_raw`` takes and names what is wrong
in a malformed message (a listener's compiled decoder, zentf/transport/ingest, reads the well-formed ones);
``encode_tf`` writes it from TransformStamped objects or plain dicts. Values are checked only as far as
the layout needs: the buffer validates the rest.
"""
from __future__ import annotations

import struct
from collections.abc import Callable, Iterable
from typing import Any

from ..core.constants import DEFAULT_MAX_FRAME_ID_LENGTH
from .errors import CdrError

__all__ = ["tf_samples", "encode_tf", "MAX_PAYLOAD"]

#: Payloads larger than this are refused before decoding.
MAX_PAYLOAD = 64 * 1024 * 1024
_NS = 1_000_000_000
_HEAD = struct.Struct("<4sI")          # encapsulation, transform count
_U32 = struct.Struct("<I")
_STAMP_LEN = struct.Struct("<iII")     # sec, nanosec, frame_id length
_SEVEN = struct.Struct("<7d")
#: Frame names decoded once, by their UTF-8 bytes. The one cache of every TFMessage decoder (this
#: module's, zentf.transport.wire.codec's, the compiled ones in zentf/transport/ingest and the bag loader):
#: bounded in names and in bytes, started over when either bound is reached, names longer than the buffer
#: takes not kept. The names bound is above what a buffer holds (DEFAULT_MAX_FRAMES): a fleet's trees in
#: one listener (100 robots x 51 frames) must not start it over on every message; the bytes bound keeps
#: forged long names to ~FRAME_CACHE_BYTES, whatever number of distinct names a peer sends.
FRAME_CACHE_SIZE = 16384
FRAME_CACHE_BYTES = 2_500_000
_ENTRY_BYTES = 200  # a kept name's cost beyond twice its length: the bytes and str headers, its dict slot
_FRAMES: dict[bytes, str] = {}
_FRAMES_HELD = [0]  # estimated bytes held by _FRAMES (2 x length + _ENTRY_BYTES an entry)
#: memos in front of _FRAMES (zentf/ros/frame_names.pyx): forgotten whenever _FRAMES starts over, or a name
#: a memo still held would come back as a second str once the memo lets it go
_FRAMES_FORGET: list[Callable[[], None]] = []


def bounded_put(cache: dict, held: list, key: Any, value: Any, cost: int) -> bool:
    """``cache[key] = value`` within FRAME_CACHE_SIZE entries and FRAME_CACHE_BYTES (``held[0]``: the
    estimated bytes already in it; ``cost``: this entry's); a full cache starts over (then True)."""
    full = len(cache) >= FRAME_CACHE_SIZE or held[0] + cost > FRAME_CACHE_BYTES
    if full:
        cache.clear()
        held[0] = 0
    cache[key] = value
    held[0] += cost
    return full


def forget_frame_names() -> None:
    """Start the frame-name cache over, with the memos in front of it."""
    _FRAMES.clear()
    _FRAMES_HELD[0] = 0
    for forget in _FRAMES_FORGET:
        forget()


def keep_frame_name(raw: bytes, name: str) -> None:
    """Remember a decoded frame name (zentf/ros/frame_names.pyx does the same inline, in C)."""
    if len(raw) <= DEFAULT_MAX_FRAME_ID_LENGTH:  # a longer one the buffer refuses anyway
        if bounded_put(_FRAMES, _FRAMES_HELD, raw, name, 2 * len(raw) + _ENTRY_BYTES):
            for forget in _FRAMES_FORGET:
                forget()


def frame_name(raw: bytes) -> str:
    """Frame id bytes -> str through the shared cache; UnicodeDecodeError if not UTF-8."""
    name = _FRAMES.get(raw)
    if name is None:
        name = raw.decode("utf-8")
        keep_frame_name(raw, name)
    return name


def tf_samples(payload: bytes) -> tuple[list[tuple], int, str | None]:
    """(samples, malformed, first problem) of a CDR TFMessage.

    A sample is ``(parent, child, stamp_ns, x, y, z, qx, qy, qz, qw)``. An element with a stamp out of
    range, a frame name that is not UTF-8 or a string without its closing NUL is skipped and counted; a
    layout error (truncated payload, impossible length) stops the decoding there: the elements read so
    far are kept, the rest counted malformed. CdrError only if the payload is not a little-endian CDR
    TFMessage at all. Nothing is kept between calls but frame names (the bounded cache above): a
    listener runs this only for payloads its compiled decoder doubted, which any peer can forge.
    """
    end = len(payload)
    if end > MAX_PAYLOAD:
        raise CdrError(f"payload of {end} bytes exceeds the {MAX_PAYLOAD} byte limit")
    if end < 8:
        raise CdrError(f"payload of {end} bytes is too short for a CDR TFMessage")
    header, n = _HEAD.unpack_from(payload, 0)
    if header[:2] != b"\x00\x01":
        raise CdrError(f"not little-endian CDR (encapsulation {header[:2].hex()}, expected 0001)")
    if n * 72 > end - 8:  # no element is smaller than 72 bytes
        raise CdrError(f"TFMessage claims {n} transforms but has only {end - 8} bytes")
    samples: list[tuple] = []
    append = samples.append
    frames = _FRAMES
    stamp_len = _STAMP_LEN.unpack_from
    u32 = _U32.unpack_from
    seven = _SEVEN.unpack_from
    malformed = 0
    problem = None
    off = 8
    i = 0
    try:
        for i in range(n):
            # off is 4-aligned here (start, or after 7 doubles)
            sec, nsec, ln = stamp_len(payload, off)
            off += 12
            a = off + ln - 1             # where frame_id's NUL is
            pb = payload[off:a]
            off = (a + 4) & ~3          # skip the NUL, pad to 4 (the header is 4 bytes: same grid)
            (ln2,) = u32(payload, off)
            off += 4
            b = off + ln2 - 1
            cb = payload[off:b]
            off = b + 1
            off += (4 - off) & 7         # pad to 8, counted from the end of the header
            x, y, z, qx, qy, qz, qw = seven(payload, off)
            off += 56
            if b >= end or a >= end:
                raise struct.error("string overruns the payload")
            bad = None
            if not (0 <= sec and nsec < _NS):
                bad = f"bad stamp sec={sec} nanosec={nsec}"
            elif ln == 0 or payload[a] != 0:
                bad = "frame_id has no closing NUL"
            elif ln2 == 0 or payload[b] != 0:
                bad = "child_frame_id has no closing NUL"
            else:
                try:
                    append((frames.get(pb) or frame_name(pb), frames.get(cb) or frame_name(cb),
                            sec * _NS + nsec, x, y, z, qx, qy, qz, qw))
                except UnicodeDecodeError:
                    bad = "frame id is not UTF-8"
            if bad is not None:
                malformed += 1
                if problem is None:
                    problem = f"transforms[{i}]: {bad}"
    except struct.error:
        bad_count = n - i
        malformed += bad_count
        if problem is None:
            problem = f"transforms[{i}]: truncated payload ({bad_count} transform(s) unreadable)"
    return samples, malformed, problem


# ---- encoding

_FRAME_BYTES: dict[str, bytes] = {}
_FRAME_BYTES_HELD = [0]


def _frame_bytes(name: Any) -> bytes:
    """uint32 length + UTF-8 + NUL (not padded)."""
    raw = _FRAME_BYTES.get(name)
    if raw is None:
        if type(name) is not str:
            raise CdrError(f"frame ids must be strings, got {type(name).__name__}")
        b = name.encode("utf-8")
        raw = _U32.pack(len(b) + 1) + b + b"\x00"
        if len(b) <= DEFAULT_MAX_FRAME_ID_LENGTH:  # (a relay encodes names any peer sent: bounded as _FRAMES)
            bounded_put(_FRAME_BYTES, _FRAME_BYTES_HELD, name, raw, 2 * len(raw) + _ENTRY_BYTES)
    return raw


_PAD = (b"", b"\x00", b"\x00\x00", b"\x00\x00\x00", b"\x00\x00\x00\x00", b"\x00" * 5, b"\x00" * 6, b"\x00" * 7)
_STAMP = struct.Struct("<iI")


def _fields(t: Any) -> tuple:
    """(sec, nanosec, parent, child, x, y, z, qx, qy, qz, qw) of a TransformStamped or plain dict."""
    if isinstance(t, dict):
        h = t["header"]
        st = h["stamp"]
        sec, nsec = (st["sec"], st["nanosec"]) if isinstance(st, dict) else (st.sec, st.nanosec)
        tr = t["transform"]
        p = tr["translation"]
        q = tr["rotation"]
        return (sec, nsec, h["frame_id"], t["child_frame_id"], p["x"], p["y"], p["z"],
                q["x"], q["y"], q["z"], q["w"])
    h = t.header
    st = h.stamp
    ns = getattr(st, "_ns", None)
    if type(ns) is int:
        sec, nsec = divmod(ns, _NS)
    else:
        sec, nsec = st.sec, st.nanosec
    tr = t.transform
    p = tr.translation
    q = tr.rotation
    return sec, nsec, h.frame_id, t.child_frame_id, p.x, p.y, p.z, q.x, q.y, q.z, q.w


_MIDS: dict[tuple[Any, Any, int], bytes] = {}
_MIDS_HELD = [0]


def frames_between(parent: Any, child: Any, off: int) -> bytes:
    """frame_id, padding to 4, child_frame_id, padding to 8: the bytes between a stamp (ending at
    ``off``) and the 7 doubles; they depend only on the names and on off % 8 (cached)."""
    key = (parent, child, off & 7)
    mid = _MIDS.get(key)
    if mid is None:
        pb = _frame_bytes(parent)
        cb = _frame_bytes(child)
        at = off + len(pb)
        pad1 = -at & 3
        at += pad1 + len(cb)
        mid = pb + _PAD[pad1] + cb + _PAD[-at & 7]
        if len(mid) <= 2 * DEFAULT_MAX_FRAME_ID_LENGTH + 16:
            bounded_put(_MIDS, _MIDS_HELD, key, mid, len(mid) + _ENTRY_BYTES)
    return mid


def encode_tf(transforms: Iterable[Any]) -> bytes:
    """A CDR TFMessage (with encapsulation header) from TransformStamped objects or plain dicts."""
    items = transforms if isinstance(transforms, (list, tuple)) else list(transforms)
    parts = [b"\x00\x01\x00\x00", _U32.pack(len(items))]
    append = parts.append
    off = 4  # bytes written after the encapsulation header; 4-aligned at each element
    pack_stamp = _STAMP.pack
    pack_seven = _SEVEN.pack
    for t in items:
        try:
            sec, nsec, parent, child, x, y, z, qx, qy, qz, qw = _fields(t)
            stamp = pack_stamp(sec, nsec)
            values = pack_seven(x, y, z, qx, qy, qz, qw)
            mid = frames_between(parent, child, off + 8)
        except (KeyError, AttributeError, TypeError) as e:
            raise CdrError(f"not a TransformStamped: {type(e).__name__}: {e}"[:160]) from None
        except struct.error as e:
            raise CdrError(f"TransformStamped value out of range: {e}") from None
        append(stamp)
        append(mid)
        append(values)
        off += 64 + len(mid)
    return b"".join(parts)
