"""tf2_msgs/msg/TFMessage in CDR, hand-laid for speed: the hot path of a listener on a ROS 2 graph.

One TransformStamped in XCDR1 little-endian is: int32 sec, uint32 nanosec, string frame_id, string
child_frame_id (each a uint32 length counting the NUL, the bytes, the NUL, then padding to 4), padding
to 8 (counted from the end of the encapsulation header), 7 float64 (translation x y z, rotation x y z w).
``tf_samples`` reads that straight into the tuples ``BufferCore.set_transforms_raw`` takes, with
precompiled structs and a cache of frame names; ``encode_tf`` writes it from TransformStamped objects or
plain dicts. Values are checked only as far as the layout needs: the buffer validates the rest.
"""
from __future__ import annotations

import struct
from collections.abc import Iterable
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
#: Frame names decoded once, by their UTF-8 bytes (a tree has tens to hundreds). The one cache of every
#: TFMessage decoder (this module's, zentf.transport.wire.codec's per-element path, zentf/transport/ingest/tfwire.pyx): when full it
#: starts over and names longer than the buffer takes are not kept, so forged names cost at most
#: ~4096 x 0.6 kB, whatever number of distinct names a peer sends.
FRAME_CACHE_SIZE = 4096
_FRAMES: dict[bytes, str] = {}


def frame_name(raw: bytes) -> str:
    """Frame id bytes -> str through the shared cache; UnicodeDecodeError if not UTF-8."""
    name = _FRAMES.get(raw)
    if name is None:
        name = raw.decode("utf-8")
        if len(raw) <= DEFAULT_MAX_FRAME_ID_LENGTH:  # a longer one the buffer refuses anyway
            if len(_FRAMES) >= FRAME_CACHE_SIZE:
                _FRAMES.clear()
            _FRAMES[raw] = name
    return name


_name = frame_name


class _Layout:
    """Where the numbers of one message shape are: a message with the same frame names in the same
    order (a broadcaster's usual stream) is read with one struct call and C-level zips."""

    __slots__ = ("size", "checks", "numbers", "parents", "children")

    def __init__(self, size: int, checks: tuple, numbers: struct.Struct, parents: list, children: list) -> None:
        self.size = size
        self.checks = checks          # ((offset, end, bytes), ...): length + name + NUL of every string
        self.numbers = numbers        # sec, nanosec, 7 doubles per element, gaps skipped
        self.parents = parents
        self.children = children


_LAYOUTS: dict[tuple[int, bytes], _Layout] = {}


def _learn(payload: bytes, n: int) -> _Layout | None:
    """The layout of a well-formed message (None if anything is off: the generic loop handles it)."""
    checks = []
    parents = []
    children = []
    off = 8
    try:
        for _ in range(n):
            off += 8                                  # stamp
            for names in (parents, children):
                (ln,) = _U32.unpack_from(payload, off)
                start = off
                off += 4 + ln
                if ln == 0 or off > len(payload):
                    return None
                names.append(_name(payload[start + 4:off - 1]))
                checks.append((start, off, payload[start:off]))
                off = (off + 3) & ~3 if names is parents else off
            off += (4 - off) & 7                      # pad to 8 (counted after the 4-byte header)
            off += 56
    except (struct.error, UnicodeDecodeError):
        return None
    if off != len(payload):
        return None
    return _build(payload, n, checks, parents, children)


def _build(payload: bytes, n: int, checks: list, parents: list, children: list) -> _Layout | None:
    """Struct format from the string positions: stamp (8 bytes) before each frame_id, 56 after each child."""
    fmt = "<"
    pos = 0
    for i in range(n):
        p_start = checks[2 * i][0]
        stamp_at = p_start - 8
        fmt += (f"{stamp_at - pos}x" if stamp_at > pos else "") + "iI"
        c_end = checks[2 * i + 1][1]
        doubles_at = c_end + ((4 - c_end) & 7)
        fmt += f"{doubles_at - p_start}x7d"
        pos = doubles_at + 56
    if pos != len(payload):
        return None
    return _Layout(len(payload), tuple(checks), struct.Struct(fmt), parents, children)


def tf_samples(payload: bytes) -> tuple[list[tuple], int, str | None]:
    """(samples, malformed, first problem) of a CDR TFMessage.

    A sample is ``(parent, child, stamp_ns, x, y, z, qx, qy, qz, qw)``. An element with a stamp out of
    range or a frame name that is not UTF-8 is skipped and counted; a layout error (truncated payload,
    impossible length) stops the decoding there: the elements read so far are kept, the rest counted
    malformed. CdrError only if the payload is not a little-endian CDR TFMessage at all.
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
    # many transforms: the layout is found by the size and the first transform's frame names
    sig = None
    if n >= 8:
        try:
            (ln,) = _U32.unpack_from(payload, 16)
            o2 = (20 + ln + 3) & ~3
            (ln2,) = _U32.unpack_from(payload, o2)
            sig = (end, payload[16:o2 + 4 + ln2])
        except struct.error:
            sig = None
    layout = _LAYOUTS.get(sig) if sig is not None else None
    if layout is not None:
        fast = _with_layout(payload, n, layout)
        if fast is not None:
            return fast
    elif sig is not None and len(_LAYOUTS) < 256:  # worth learning: many transforms per message
        layout = _learn(payload, n)
        if layout is not None:
            _LAYOUTS[sig] = layout
            fast = _with_layout(payload, n, layout)
            if fast is not None:
                return fast
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
            a = off + ln - 1
            pb = payload[off:a]
            off = (a + 4) & ~3          # skip the NUL, pad to 4 (the header is 4 bytes: same grid)
            (ln,) = u32(payload, off)
            off += 4
            b = off + ln - 1
            cb = payload[off:b]
            off = b + 1
            off += (4 - off) & 7         # pad to 8, counted from the end of the header
            x, y, z, qx, qy, qz, qw = seven(payload, off)
            off += 56
            if b > end or a > end:
                raise struct.error("string overruns the payload")
            if not (0 <= sec and nsec < _NS):
                malformed += 1
                if problem is None:
                    problem = f"transforms[{i}]: bad stamp sec={sec} nanosec={nsec}"
                continue
            try:
                parent = frames.get(pb) or _name(pb)
                child = frames.get(cb) or _name(cb)
            except UnicodeDecodeError:
                malformed += 1
                if problem is None:
                    problem = f"transforms[{i}]: frame id is not UTF-8"
                continue
            append((parent, child, sec * _NS + nsec, x, y, z, qx, qy, qz, qw))
    except struct.error:
        bad = n - i
        malformed += bad
        if problem is None:
            problem = f"transforms[{i}]: truncated payload ({bad} transform(s) unreadable)"
    return samples, malformed, problem


def _with_layout(payload: bytes, n: int, layout: _Layout) -> tuple[list[tuple], int, None] | None:
    """Decode with a learnt layout if every frame name is where it was; None otherwise."""
    for start, stop, raw in layout.checks:
        if payload[start:stop] != raw:
            return None
    if len(layout.parents) != n:
        return None
    v = layout.numbers.unpack_from(payload, 0)
    secs = v[0::9]
    nsecs = v[1::9]
    if min(secs) < 0 or max(nsecs) >= _NS:
        return None  # the careful loop names the bad element
    stamps = [a * _NS + b for a, b in zip(secs, nsecs)]
    return (list(zip(layout.parents, layout.children, stamps, v[2::9], v[3::9], v[4::9], v[5::9], v[6::9],
                     v[7::9], v[8::9])), 0, None)


# ---- encoding

_FRAME_BYTES: dict[str, bytes] = {}


def _frame_bytes(name: Any) -> bytes:
    """uint32 length + UTF-8 + NUL (not padded)."""
    raw = _FRAME_BYTES.get(name)
    if raw is None:
        if type(name) is not str:
            raise CdrError(f"frame ids must be strings, got {type(name).__name__}")
        b = name.encode("utf-8")
        raw = _U32.pack(len(b) + 1) + b + b"\x00"
        if len(_FRAME_BYTES) > 100_000:
            _FRAME_BYTES.clear()
        _FRAME_BYTES[name] = raw
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


def _middle(parent: Any, child: Any, off: int) -> bytes:
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
        if len(_MIDS) > 100_000:
            _MIDS.clear()
        _MIDS[key] = mid
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
            mid = _middle(parent, child, off + 8)
        except (KeyError, AttributeError, TypeError) as e:
            raise CdrError(f"not a TransformStamped: {type(e).__name__}: {e}"[:160]) from None
        except struct.error as e:
            raise CdrError(f"TransformStamped value out of range: {e}") from None
        append(stamp)
        append(mid)
        append(values)
        off += 64 + len(mid)
    return b"".join(parts)
