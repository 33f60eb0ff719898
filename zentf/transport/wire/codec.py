"""Wire format: msgpack of a message's plain dict, Zenoh encoding ``application/msgpack;<type name>``.

The sending node's fully qualified name travels as the sample attachment (UTF-8), so receivers
know the authority of every transform. ``ingest_tf`` puts a TFMessage payload into a buffer: the
compiled decoder (zentf/transport/ingest/decoders.pyx) reads a well-formed one, ``tf_samples`` reads any
other and names what is wrong, each bad element skipped on its own; ``encode_tf`` is the broadcasters'
(TransformStamped written from a byte template, zentf/transport/ingest/tf_encoder.pyx).
"""
from __future__ import annotations

from collections.abc import Iterable
import threading
from functools import lru_cache
from typing import Any

import msgpack

from ...core.messages import JointState, Message, TransformStamped, message_type
from ...ros.tf import FRAME_CACHE_SIZE, frame_name  # the one bounded cache of frame names
from ...ros.tf import _FRAMES as _FRAME_CACHE
from ..ingest.decoders import msgpack_tf
from ..ingest.joint_state_encoder import js_payload as _js_payload
from ..ingest.tf_encoder import ts_item as _ts_item, ts_payload as _ts_payload

__all__ = [
    "ENCODING", "MAX_PAYLOAD", "encoding_for", "type_name_from_encoding", "pack", "unpack", "encode",
    "decode", "decode_any", "tf_to_plain", "encode_tf", "ingest_tf", "tf_samples", "insert_samples", "authority_of",
    "RowCapture",
]

ENCODING = "application/msgpack"
#: Payloads larger than this are refused before decoding (a huge message must not stall a listener).
MAX_PAYLOAD = 64 * 1024 * 1024
_NS = 1_000_000_000
_MAX_SEC = (2**63 - 1) // _NS  # stamps are int64 nanoseconds


@lru_cache(maxsize=256)
def encoding_for(type_name: str) -> Any:
    """zenoh.Encoding ``application/msgpack;<type_name>``."""
    import zenoh

    return zenoh.Encoding(ENCODING).with_schema(type_name) if type_name else zenoh.Encoding(ENCODING)


def type_name_from_encoding(encoding: object) -> str | None:
    """'application/msgpack;geometry_msgs/msg/Point' -> 'geometry_msgs/msg/Point'; None if not ours."""
    text = str(encoding)
    if not text.startswith(ENCODING):
        return None
    _, _, schema = text.partition(";")
    return schema or None


_local = threading.local()


def pack(plain: Any) -> bytes:
    """msgpack with a reused per-thread Packer (packb builds a new one per call)."""
    packer = getattr(_local, "packer", None)
    if packer is None:
        packer = _local.packer = msgpack.Packer(use_bin_type=True)
    try:
        return packer.pack(plain)
    except BaseException:
        _local.packer = None  # a failed pack may leave data in the buffer
        raise


def unpack(payload: bytes | bytearray | memoryview) -> Any:
    """msgpack -> plain data; any failure (truncated, garbage, too big) is a one-line ValueError."""
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds the {MAX_PAYLOAD} byte limit")
    try:
        return msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception as e:  # msgpack raises several classes (ExtraData, FormatError, ValueError, ...)
        raise ValueError(f"not valid msgpack ({type(e).__name__}: {str(e)[:80]})") from None


def encode(msg: Message | dict) -> bytes:
    if type(msg) is JointState:  # joint_states at hundreds of hertz: written in C (joint_state_encoder.pyx)
        payload = _js_payload(msg)
        if payload is not None:
            return payload
    if isinstance(msg, Message):
        return pack(msg.to_dict())
    if isinstance(msg, dict):
        return pack(msg)
    raise TypeError(f"cannot publish a {type(msg).__name__}: expected a message or a dict")


def decode(payload: bytes, msg_type: type[Message]) -> Message:
    """Bytes -> message of msg_type; ValueError names what was wrong."""
    return msg_type.from_dict(unpack(payload))


def decode_any(payload: bytes, encoding: object) -> tuple[str | None, Any]:
    """For generic tools: (type name or None, message object if the type is known else plain data)."""
    type_name = type_name_from_encoding(encoding)
    plain = unpack(payload)
    if type_name:
        try:
            return type_name, message_type(type_name).from_dict(plain)
        except KeyError:
            pass
    return type_name, plain


def tf_to_plain(ts: TransformStamped | dict) -> dict:
    """TransformStamped -> plain dict without the generic reflection (hot path of broadcasters)."""
    if isinstance(ts, dict):
        return ts
    h = ts.header
    st = h.stamp
    tr = ts.transform
    p = tr.translation
    q = tr.rotation
    return {"header": {"stamp": {"sec": st.sec, "nanosec": st.nanosec}, "frame_id": h.frame_id},
            "child_frame_id": ts.child_frame_id,
            "transform": {"translation": {"x": p.x, "y": p.y, "z": p.z},
                          "rotation": {"x": q.x, "y": q.y, "z": q.z, "w": q.w}}}


# Broadcaster fast path: a TransformStamped with a Time stamp is written straight as msgpack bytes by
# zentf/transport/ingest/tf_encoder.pyx (``ts_item``, ``ts_payload``): the same map (field names and
# order) that pack(tf_to_plain(ts)) writes, with sec/nanosec as uint32 and every number as float64 (valid
# msgpack that any decoder reads back to the same dict, ints as floats); anything unusual takes the dict path.


def _tf_item(t: TransformStamped | dict) -> bytes:
    item = _ts_item(t)  # None: a dict, or unusual (a non-number, sec >= 2**32): packed here (or said why not)
    return item if item is not None else pack(tf_to_plain(t))


def encode_tf(transforms: Iterable[TransformStamped | dict]) -> bytes:
    """A TFMessage payload from transforms (dataclasses or plain dicts)."""
    if type(transforms) is list and len(transforms) == 1:  # the common send_transform(one) case
        payload = _ts_payload(transforms[0])
        if payload is not None:
            return payload
    items = [_tf_item(t) for t in transforms]
    n = len(items)
    if n < 16:
        head = b"\x81\xaatransforms" + bytes((0x90 | n,))
    elif n < 0x10000:
        head = b"\x81\xaatransforms\xdc" + n.to_bytes(2, "big")
    else:
        head = b"\x81\xaatransforms\xdd" + n.to_bytes(4, "big")
    return head + b"".join(items)


def authority_of(attachment: Any, fallback: str) -> str:
    """The sender's node name from a sample attachment (ZBytes or bytes); fallback if absent/bad."""
    if attachment is None:
        return fallback
    try:
        raw = attachment.to_bytes() if hasattr(attachment, "to_bytes") else bytes(attachment)
        text = raw.decode("utf-8")
    except Exception:
        return fallback
    return text if 0 < len(text) <= 256 and text.isprintable() else fallback


def _num(v: Any) -> float:
    """A transform value: a float as it is, an int as a float (OverflowError beyond a double)."""
    if type(v) is float:
        return v
    if type(v) is int:
        return float(v)
    raise TypeError(f"expected a number, got {type(v).__name__}")


def _frame(b: Any) -> str:
    """Frame id bytes -> str (cached: a tree has few distinct names)."""
    name = _FRAME_CACHE.get(b)
    if name is None:
        if type(b) is not bytes:
            raise TypeError("frame ids must be strings")
        name = frame_name(b)
    return name


class RowCapture:
    """Stands in for the BufferCore a wire's ``ingest_tf`` inserts into: keeps the decoded rows instead (what
    the doctor takes as evidence and the bag loader's Python path stores)."""

    __slots__ = ("rows",)

    def __init__(self) -> None:
        self.rows: list = []

    def set_transforms_raw(self, samples: list, authority: str, is_static: bool = False) -> int:
        self.rows.extend(samples)
        return len(samples)

    def set_transform_raw(self, *args: Any) -> bool:
        self.rows.append(args[:10])
        return True


def ingest_tf(payload: bytes, core: Any, authority: str, is_static: bool) -> tuple[int, int, int, str | None]:
    """Insert every transform of a TFMessage payload into ``core`` (a BufferCore).

    Returns (accepted, rejected_by_buffer, malformed, first_problem). Raises ValueError only if the
    whole payload is unusable (not msgpack, not a TFMessage). A well-formed message is decoded by the
    compiled decoder; any other by ``tf_samples``, which names the first problem. Either way
    ``set_transforms_raw`` inserts the message under one lock and wakes waiters once.
    """
    samples = msgpack_tf(payload)
    if samples is None:
        samples, malformed, problem = tf_samples(payload)
        return insert_samples(samples, core, authority, is_static, malformed, problem)
    return insert_samples(samples, core, authority, is_static)


def tf_samples(payload: bytes) -> tuple[list[tuple], int, str | None]:
    """(samples, malformed, first problem) of a msgpack TFMessage: the path that reads any payload and
    names what is wrong, for the payloads the compiled decoder doubts.

    msgpack unpacks with raw=True and each element is validated on its own, so one bad element costs
    only itself; a number is a float or an int (not a bool), as for the compiled decoder. ValueError if the
    payload is not a TFMessage at all.
    """
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds the {MAX_PAYLOAD} byte limit")
    try:
        data = msgpack.unpackb(payload, raw=True, use_list=False, strict_map_key=False)
    except Exception as e:
        raise ValueError(f"not valid msgpack ({type(e).__name__}: {str(e)[:80]})") from None
    if type(data) is not dict:
        raise ValueError(f"expected a TFMessage dict, got {type(data).__name__}")
    transforms = data.get(b"transforms")
    if type(transforms) is not tuple:
        raise ValueError("TFMessage.transforms missing or not a list")
    malformed = 0
    problem: str | None = None
    samples: list[tuple] = []
    append = samples.append
    frame = _frame
    names = _FRAME_CACHE.get
    num = _num
    for t in transforms:
        try:
            h = t[b"header"]
            st = h[b"stamp"]
            sec = st[b"sec"]
            nsec = st[b"nanosec"]
            if type(sec) is not int or type(nsec) is not int or not 0 <= sec < _MAX_SEC or not 0 <= nsec < _NS:
                raise ValueError(f"bad stamp {st!r}"[:120])
            tr = t[b"transform"]
            p = tr[b"translation"]
            q = tr[b"rotation"]
            pb = h[b"frame_id"]
            cb = t[b"child_frame_id"]
            append((names(pb) or frame(pb), names(cb) or frame(cb), sec * _NS + nsec,
                    num(p[b"x"]), num(p[b"y"]), num(p[b"z"]), num(q[b"x"]), num(q[b"y"]), num(q[b"z"]), num(q[b"w"])))
        except (KeyError, TypeError, ValueError, IndexError, OverflowError) as e:
            malformed += 1
            if problem is None:
                i = len(samples) + malformed - 1
                if isinstance(e, KeyError):
                    k = e.args[0] if e.args else "?"
                    problem = f"transforms[{i}]: missing field {k.decode('utf-8', 'replace') if isinstance(k, bytes) else k!r}"
                else:
                    problem = f"transforms[{i}]: {type(e).__name__}: {e}"[:160]
    return samples, malformed, problem


def insert_samples(samples: list, core: Any, authority: str, is_static: bool, malformed: int = 0,
                   problem: str | None = None) -> tuple[int, int, int, str | None]:
    """``core.set_transforms_raw(samples)``, and one by one if the buffer raised (it must never take a
    listener down): (accepted, rejected, malformed, first problem)."""
    if not samples:
        return 0, 0, malformed, problem
    try:
        accepted = core.set_transforms_raw(samples, authority, is_static)
    except Exception:  # the buffer must never take the listener down: retry one by one
        accepted = 0
        for s in samples:
            try:
                accepted += bool(core.set_transform_raw(*s, authority, is_static))
            except Exception as e:
                if problem is None:
                    problem = f"rejected by buffer ({type(e).__name__}: {e})"[:200]
    return accepted, len(samples) - accepted, malformed, problem
