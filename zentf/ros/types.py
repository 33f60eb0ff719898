"""The ROS 2 types zentf knows: parsed definitions, DDS type names and RIHS01 hashes (computed once)."""
from __future__ import annotations

from functools import lru_cache

from .definitions import DEFINITIONS, SERVICES
from .errors import UnknownTypeError
from .msgdef import MsgDef, parse_msg
from .typehash import type_hash as _type_hash

__all__ = ["definition", "known_types", "dds_type_name", "ros_type_name", "type_hash", "register_definition",
           "schema_text"]

_DEFS: dict[str, MsgDef] = {}
_TEXTS: dict[str, str] = dict(DEFINITIONS)


def register_definition(type_name: str, text: str) -> MsgDef:
    """Add (or replace) a .msg definition, e.g. for a message type a program defines itself."""
    d = parse_msg(type_name, text)
    _DEFS[type_name] = d
    _TEXTS[type_name] = text
    type_hash.cache_clear()
    return d


for _name, _text in DEFINITIONS.items():
    _DEFS[_name] = parse_msg(_name, _text)
for _name, (_req, _resp) in SERVICES.items():
    _DEFS[f"{_name}_Request"] = parse_msg(f"{_name}_Request", _req)
    _DEFS[f"{_name}_Response"] = parse_msg(f"{_name}_Response", _resp)


def definition(type_name: str) -> MsgDef:
    """The parsed definition of 'pkg/msg/Name' (UnknownTypeError names the type)."""
    try:
        return _DEFS[type_name]
    except KeyError:
        raise UnknownTypeError(f"unknown ROS type {type_name!r}") from None


def known_types() -> list[str]:
    return sorted(_DEFS)


def dds_type_name(type_name: str) -> str:
    """'tf2_msgs/msg/TFMessage' -> 'tf2_msgs::msg::dds_::TFMessage_' (the name rmw implementations use)."""
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def ros_type_name(dds_name: str) -> str:
    """'tf2_msgs::msg::dds_::TFMessage_' -> 'tf2_msgs/msg/TFMessage' (non-DDS names come back unchanged)."""
    parts = dds_name.split("::")
    if len(parts) == 4 and parts[2] == "dds_" and parts[3].endswith("_"):
        return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"
    return dds_name


@lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """RIHS01 hash of a known message type, computed from its definition and those it references."""
    return _type_hash(type_name, definition)


def schema_text(type_name: str) -> str:
    """The rosbag2 'ros2msg' schema of a type: its .msg text, then a block per referenced type
    (``=====`` line, ``MSG: pkg/msg/Name``, its text), as ROS 2 writes into MCAP files."""
    seen: list[str] = []
    todo = [f.base for f in definition(type_name).fields if f.nested]
    while todo:
        ref = todo.pop(0)
        if ref in seen:
            continue
        seen.append(ref)
        todo.extend(f.base for f in definition(ref).fields if f.nested)
    parts = [_TEXTS[type_name].strip("\n")]
    for ref in seen:
        parts.append("=" * 80 + f"\nMSG: {ref}\n" + _TEXTS[ref].strip("\n"))
    return "\n".join(parts) + "\n"
