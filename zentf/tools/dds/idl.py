"""ROS 2 message types as Cyclone DDS topic types, made from zentf's .msg definitions.

DDS ROS 2 (rmw_fastrtps, rmw_cyclonedds) names a message type ``pkg::msg::dds_::Name_`` and a topic
``rt/<name without the leading '/'>``; the payload is the same XCDR1 CDR that zentf's codec reads and
writes. Cyclone needs a declared type to create a topic (its name and structure go into discovery and
into the XTypes type information that peers check); the bridge itself moves the CDR bytes as they are.
"""
from __future__ import annotations

from functools import lru_cache
from typing import Any, Callable

from ...ros import dds_type_name
from ...ros.msgdef import Field, MsgDef, parse_msg
from ...ros.types import definition as zentf_definition

__all__ = ["idl_type", "dds_topic", "ros_topic", "DISCOVERY_INFO", "discovery_definition", "DDS_PREFIX"]

#: Prefix of ROS 2 topics on DDS (rq/ and rr/ are service requests and replies).
DDS_PREFIX = "rt/"

#: rmw_dds_common (Jazzy and later: a 16-byte Gid; Humble's is 24 bytes): what every ROS 2 participant
#: publishes on ``ros_discovery_info`` so that others can tell its nodes and their endpoints.
_DISCOVERY_DEFS = {
    "rmw_dds_common/msg/Gid": "char[16] data\n",
    "rmw_dds_common/msg/NodeEntitiesInfo": ("string<=256 node_namespace\nstring<=256 node_name\n"
                                            "Gid[] reader_gid_seq\nGid[] writer_gid_seq\n"),
    "rmw_dds_common/msg/ParticipantEntitiesInfo": "Gid gid\nNodeEntitiesInfo[] node_entities_info_seq\n",
}
DISCOVERY_INFO = "rmw_dds_common/msg/ParticipantEntitiesInfo"
_PARSED = {name: parse_msg(name, text) for name, text in _DISCOVERY_DEFS.items()}


def discovery_definition(type_name: str) -> MsgDef:
    """Definitions lookup for the codec: rmw_dds_common's types, then zentf's."""
    d = _PARSED.get(type_name)
    return d if d is not None else zentf_definition(type_name)


def dds_topic(fq_topic: str) -> str:
    """'/tf' -> 'rt/tf' (ROS 2's DDS topic of a fully qualified topic name)."""
    return DDS_PREFIX + fq_topic.lstrip("/")


def ros_topic(dds_name: str) -> str | None:
    """'rt/tf' -> '/tf'; None for what is not a ROS topic (services, ros_discovery_info, DDS's own)."""
    if not dds_name.startswith(DDS_PREFIX) or len(dds_name) == len(DDS_PREFIX):
        return None
    return "/" + dds_name[len(DDS_PREFIX):]


def _primitives() -> dict[str, Any]:
    from cyclonedds.idl import types as t

    # rosidl's IDL mapping: byte -> octet, char -> uint8
    return {"bool": bool, "byte": t.byte, "char": t.uint8, "int8": t.int8, "uint8": t.uint8,
            "int16": t.int16, "uint16": t.uint16, "int32": t.int32, "uint32": t.uint32, "int64": t.int64,
            "uint64": t.uint64, "float32": t.float32, "float64": t.float64}


def _field_type(f: Field, lookup: Callable[[str], MsgDef]) -> Any:
    from cyclonedds.idl import types as t

    if f.base in ("string", "wstring"):
        base: Any = t.bounded_str[f.string_bound] if f.string_bound else str
    elif f.nested:
        base = _struct(f.base, lookup)
    else:
        base = _primitives()[f.base]
    if f.array == "fixed":
        return t.array[base, f.length]
    if f.array == "bounded":
        return t.sequence[base, f.length]
    if f.array == "sequence":
        return t.sequence[base]
    return base


_STRUCTS: dict[str, Any] = {}


def _struct(type_name: str, lookup: Callable[[str], MsgDef]) -> Any:
    cls = _STRUCTS.get(type_name)
    if cls is None:
        from cyclonedds.idl import make_idl_struct

        d = lookup(type_name)
        fields = {f.name: _field_type(f, lookup) for f in d.fields}
        if not fields:  # an empty ROS message has one uint8 member on the wire (rosidl's structure_needs_at_least_one_member)
            from cyclonedds.idl import types as t

            fields = {"structure_needs_at_least_one_member": t.uint8}
        cls = make_idl_struct(type_name.rsplit("/", 1)[-1] + "_", dds_type_name(type_name), fields)
        _STRUCTS[type_name] = cls
    return cls


@lru_cache(maxsize=None)
def idl_type(type_name: str) -> Any:
    """The Cyclone type of a ROS 2 message type zentf knows ('tf2_msgs/msg/TFMessage');
    zentf.ros.UnknownTypeError if it has no definition."""
    return _struct(type_name, discovery_definition)
