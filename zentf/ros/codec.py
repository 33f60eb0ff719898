"""zentf messages <-> ROS 2 CDR bytes, for every type zentf has (TFMessage takes the fast path)."""
from __future__ import annotations

import typing
from typing import Any

from ..core.messages import Message, TFMessage, TransformStamped, message_type
from .cdr import deserialize, serialize
from .errors import CdrError, UnknownTypeError
from .tf import encode_tf
from .types import definition

__all__ = ["encode", "decode", "decode_plain", "fit_plain", "is_known"]


def encode(msg: Message | dict, type_name: str | None = None) -> bytes:
    """A zentf message (or a plain dict with ``type_name``) as CDR bytes with the encapsulation header."""
    name = type_name or getattr(msg, "TYPE_NAME", "")
    if not name:
        raise CdrError(f"cannot encode a {type(msg).__name__} without a type name")
    if name == TFMessage.TYPE_NAME:
        items = msg.transforms if isinstance(msg, TFMessage) else msg.get("transforms", []) if isinstance(msg, dict) else None
        if items is not None and all(type(t) is TransformStamped or isinstance(t, dict) for t in items):
            return encode_tf(items)
    return serialize(msg, name, definition)


def decode_plain(payload: bytes | bytearray | memoryview, type_name: str) -> dict:
    """CDR bytes -> plain dict of the full ROS type (every field of the ROS definition)."""
    return deserialize(payload, type_name, definition)


def fit_plain(cls: type[Message], plain: Any) -> Any:
    """Drop the ROS fields a zentf dataclass does not have (e.g. Marker's mesh fields), recursively."""
    if not isinstance(plain, dict):
        return plain
    out = {}
    for name, tp in cls._fields():
        if name not in plain:
            continue
        v = plain[name]
        if isinstance(tp, type) and issubclass(tp, Message):
            v = fit_plain(tp, v)
        elif typing.get_origin(tp) is list:
            (item,) = typing.get_args(tp)
            if isinstance(item, type) and issubclass(item, Message) and isinstance(v, list):
                v = [fit_plain(item, x) for x in v]
            elif item is int and isinstance(v, (bytes, bytearray)):
                v = list(v)  # a uint8/byte sequence decodes as bytes; the dataclass holds a list of ints
        out[name] = v
    return out


def decode(payload: bytes | bytearray | memoryview, type_name: str) -> Any:
    """CDR bytes -> the zentf message of ``type_name`` (plain dict if zentf has no class for it)."""
    plain = decode_plain(payload, type_name)
    try:
        cls = message_type(type_name)
    except KeyError:
        return plain
    try:
        return cls.from_dict(fit_plain(cls, plain))
    except (ValueError, TypeError) as e:
        raise CdrError(f"{type_name}: {e}") from None


def is_known(type_name: str) -> bool:
    try:
        definition(type_name)
        return True
    except UnknownTypeError:
        return False
