"""rosbags message objects <-> zentf's plain dicts (what zentf's msgpack wire carries).

ROS 1 messages take the ROS 2 shape on the way in (``std_msgs/Header.seq`` is dropped, as
rosbag2's ROS 1 converter does; ROS 1 ``time`` is unsigned, so a sec that rosbags read as a negative
int32 is read back as the uint32 it is); primitive arrays become lists (``uint8[]`` becomes bytes).
On the way out, missing fields get ROS defaults (zero, empty), so zentf's trimmed messages (its
Marker has no mesh or texture fields) fill complete ROS 2 messages.
"""
from __future__ import annotations

from typing import Any

__all__ = ["to_plain", "from_plain"]

_HEADER = "std_msgs/msg/Header"
_TIME = "builtin_interfaces/msg/Time"
_DTYPES = {"bool": "bool", "byte": "uint8", "char": "uint8", "int8": "int8", "uint8": "uint8", "int16": "int16",
           "uint16": "uint16", "int32": "int32", "uint32": "uint32", "int64": "int64", "uint64": "uint64",
           "float32": "float32", "float64": "float64"}
_BASE_DEFAULTS = {"bool": False, "string": "", "wstring": "", "float32": 0.0, "float64": 0.0}


def to_plain(obj: Any, ros1: bool = False) -> Any:
    """A deserialized rosbags message (dataclass with ``__msgtype__``) as plain dicts and lists."""
    msgtype = getattr(obj, "__msgtype__", None)
    if msgtype is not None:
        out = {}
        for name in obj.__dataclass_fields__:
            if name == "__msgtype__" or (name == "seq" and msgtype == _HEADER):
                continue
            out[name] = to_plain(getattr(obj, name), ros1)
        if ros1 and msgtype == _TIME and type(out.get("sec")) is int and out["sec"] < 0:
            out["sec"] &= 0xFFFFFFFF
        return out
    if isinstance(obj, list):
        return [to_plain(x, ros1) for x in obj]
    tolist = getattr(obj, "tolist", None)
    if tolist is not None:  # numpy array or scalar
        if getattr(obj, "ndim", 0) and obj.dtype.kind == "u" and obj.dtype.itemsize == 1:
            return obj.tobytes()
        return tolist()
    return obj


def _base(kind: str, value: Any) -> Any:
    if value is None:
        return _BASE_DEFAULTS.get(kind, 0)
    if kind in ("string", "wstring"):
        return str(value)
    if kind == "bool":
        return bool(value)
    if kind in ("float32", "float64"):
        return float(value)
    return int(value)


def _array(store: Any, sub: tuple, value: Any, length: int) -> Any:
    import numpy as np

    node, detail = sub
    if node == 1:  # BASE
        kind = detail[0]
        if kind in ("string", "wstring"):
            vals = [str(v) for v in (value or [])]
            return vals + [""] * (length - len(vals)) if length else vals
        dtype = _DTYPES[kind]
        if isinstance(value, (bytes, bytearray, memoryview)):
            arr = np.frombuffer(bytes(value), dtype=np.uint8).astype(dtype)
        else:
            arr = np.asarray(value if value is not None else [], dtype=dtype)
        if length and len(arr) != length:
            fixed = np.zeros(length, dtype=dtype)
            fixed[:min(length, len(arr))] = arr[:length]
            arr = fixed
        return arr
    items = [from_plain(store, detail, v) for v in (value or [])]
    while length and len(items) < length:
        items.append(from_plain(store, detail, {}))
    return items


def from_plain(store: Any, typename: str, plain: Any) -> Any:
    """A rosbags message of ``typename`` built from a plain dict; missing fields get ROS defaults."""
    if not isinstance(plain, dict):
        plain = {}
    _, fields = store.fielddefs[typename]
    kwargs = {}
    for name, (node, detail) in fields:
        value = plain.get(name)
        if node == 1:
            kwargs[name] = _base(detail[0], value)
        elif node == 2:
            kwargs[name] = from_plain(store, detail, value)
        elif node == 3:
            kwargs[name] = _array(store, detail[0], value, detail[1])
        else:
            kwargs[name] = _array(store, detail[0], value, 0)
    return store.types[typename](**kwargs)
