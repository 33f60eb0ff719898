"""CDR (DDS, rmw_zenoh) <-> a zentf graph's payloads, for the DDS bridge.

With ``--wire ros2`` the zentf side carries the same CDR bytes as DDS and nothing is converted. With
zentf's wire a message is decoded and re-encoded; ``/tf`` takes a fast path both ways: a CDR TFMessage
is read by the compiled decoder and written as the msgpack that zentf's broadcasters write (one struct
call per transform, the constant bytes of each frame pair made once), and zentf's TFMessage goes to CDR
through zentf.ros's hand-laid encoder.
"""
from __future__ import annotations

import struct
from typing import Any

import msgpack

from ...core.messages import TFMessage
from ...ros import codec as cdr_codec
from ...ros.tf import tf_samples

__all__ = ["tf_cdr_to_msgpack", "cdr_to_message", "message_to_cdr", "check_cdr"]

# the compiled decoder: None for anything doubtful, then the Python one (tf_samples) names what is wrong
from ...transport.ingest.decoders import cdr_tf as _cdr_tf
from ...transport.ingest.tf_transcode import tf_cdr_to_msgpack as _compiled  # in C: None for anything doubtful

_NS = 1_000_000_000
_STAMP = b"\x83\xa6header\x82\xa5stamp\x82\xa3sec\xce"
_NSEC = b"\xa7nanosec\xce"
_KY = b"\xa1y\xcb"
_KZ = b"\xa1z\xcb"
_ROT = b"\xa8rotation\x84\xa1x\xcb"
_KW = b"\xa1w\xcb"
#: one transform: stamp, frames, translation, rotation; the frame part is per (frame_id, child) pair
_FMT = ">{s}sI{n}sI{f}sd3sd3sd{r}sd3sd3sd3sd"
_FRAMES: dict[tuple[str, str], tuple[struct.Struct, bytes]] = {}
_FRAMES_MAX = 4096


def _frames(parent: str, child: str) -> tuple[struct.Struct, bytes]:
    key = (parent, child)
    hit = _FRAMES.get(key)
    if hit is None:
        frames = (b"\xa8frame_id" + msgpack.packb(parent) + b"\xaechild_frame_id" + msgpack.packb(child)
                  + b"\xa9transform\x82\xabtranslation\x83\xa1x\xcb")
        st = struct.Struct(_FMT.format(s=len(_STAMP), n=len(_NSEC), f=len(frames), r=len(_ROT)))
        if len(_FRAMES) >= _FRAMES_MAX:
            _FRAMES.clear()
        hit = _FRAMES[key] = (st, frames)
    return hit


def _head(n: int) -> bytes:
    if n < 16:
        return b"\x81\xaatransforms" + bytes((0x90 | n,))
    if n < 0x10000:
        return b"\x81\xaatransforms\xdc" + n.to_bytes(2, "big")
    return b"\x81\xaatransforms\xdd" + n.to_bytes(4, "big")


def tf_cdr_to_msgpack(cdr: bytes) -> tuple[bytes, int]:
    """(zentf payload, transforms left out) of a CDR TFMessage: what zentf's TransformBroadcaster would
    send for it. Elements that cannot be read (bad stamp, name not UTF-8) are left out and counted;
    ValueError if the payload is not a CDR TFMessage at all."""
    out = _compiled(cdr)
    if out is not None:
        return out, 0
    return _python_tf_cdr_to_msgpack(cdr)


def _python_tf_cdr_to_msgpack(cdr: bytes) -> tuple[bytes, int]:
    """tf_cdr_to_msgpack of what the compiled converter finds doubtful: what can be read of it."""
    samples = _cdr_tf(cdr)
    bad = 0
    if samples is None:
        try:
            samples, bad, _problem = tf_samples(cdr)
        except Exception as e:  # CdrError and anything a forged payload provokes
            raise ValueError(str(e)) from None
    parts = [_head(len(samples))]
    for parent, child, ns, x, y, z, qx, qy, qz, qw in samples:
        st, frames = _frames(parent, child)
        sec = ns // _NS
        if sec > 0xFFFFFFFF:
            raise ValueError(f"stamp {ns} ns is beyond ROS time")
        parts.append(st.pack(_STAMP, sec, _NSEC, ns - sec * _NS, frames, x, _KY, y, _KZ, z, _ROT, qx, _KY, qy,
                             _KZ, qz, _KW, qw))
    return b"".join(parts), bad


def cdr_to_message(cdr: bytes, type_name: str) -> Any:
    """CDR bytes -> zentf message (a plain dict for a type zentf has a definition but no class of);
    ValueError says what was wrong."""
    try:
        return cdr_codec.decode(cdr, type_name)
    except Exception as e:  # CdrError, and whatever a forged payload provokes in a message class
        raise ValueError(f"bad CDR {type_name}: {e}") from None


def message_to_cdr(msg: Any, type_name: str) -> bytes:
    """zentf message (or plain dict) -> CDR bytes; ValueError says what was wrong."""
    try:
        return cdr_codec.encode(msg, type_name)
    except Exception as e:
        raise ValueError(f"cannot write {type_name} as CDR: {e}") from None


def check_cdr(cdr: bytes, type_name: str) -> None:
    """ValueError unless ``cdr`` is a well-formed CDR message of ``type_name`` (a ROS 2 payload from
    the zentf side goes to DDS readers as it is, so it is read once first)."""
    if type_name == TFMessage.TYPE_NAME:
        if _cdr_tf(cdr) is not None:
            return
        try:
            _samples, bad, problem = tf_samples(cdr)
        except Exception as e:
            raise ValueError(f"bad CDR {type_name}: {e}") from None
        if bad:
            raise ValueError(f"bad CDR {type_name}: {problem}")
        return
    try:
        cdr_codec.decode_plain(cdr, type_name)
    except Exception as e:
        raise ValueError(f"bad CDR {type_name}: {e}") from None
