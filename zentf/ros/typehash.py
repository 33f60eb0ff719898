"""RIHS01 type hashes (REP-2011), computed from the type description, as rosidl does at build time.

The hash is sha256 over a canonical JSON of the type's description (its fields, then every type it
references, sorted by name), with default values left out: ``RIHS01_<64 hex digits>``. rmw_zenoh puts
it in every data key and liveliness token, rosbag2 in its metadata.
"""
from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping

from .errors import UnknownTypeError
from .msgdef import Field, MsgDef

__all__ = ["type_hash", "type_description", "FIELD_TYPE_IDS"]

#: type_description_interfaces/msg/FieldType ids of the scalar types.
FIELD_TYPE_IDS: dict[str, int] = {
    "nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7, "int64": 8,
    "uint64": 9, "float32": 10, "float64": 11, "char": 3, "bool": 15, "byte": 16, "string": 17,
    "wstring": 18,
}
# .msg 'char' is IDL 'uint8' (rosidl_adapter), so its id is FIELD_TYPE_UINT8, not FIELD_TYPE_CHAR (13);
# checked: service_msgs/msg/ServiceEventInfo (char[16] client_gid) hashes as ROS 2 Jazzy's JSON says.
_BOUNDED_STRING = 21     # FIELD_TYPE_BOUNDED_STRING (string<=N)
_ARRAY_OFFSET = {None: 0, "fixed": 48, "bounded": 96, "sequence": 144}

Resolver = Callable[[str], MsgDef]


def _field_type(f: Field) -> dict:
    if f.nested:
        scalar = FIELD_TYPE_IDS["nested"]
    elif f.base == "string" and f.string_bound:
        scalar = _BOUNDED_STRING
    else:
        scalar = FIELD_TYPE_IDS[f.base]
    return {"type_id": scalar + _ARRAY_OFFSET[f.array], "capacity": f.length if f.array in ("fixed", "bounded") else 0,
            "string_capacity": f.string_bound, "nested_type_name": f.base if f.nested else ""}


def _individual(d: MsgDef) -> dict:
    fields = [{"name": f.name, "type": _field_type(f)} for f in d.fields]
    if not fields:  # rosidl gives empty messages one dummy member
        fields = [{"name": "structure_needs_at_least_one_member",
                   "type": {"type_id": FIELD_TYPE_IDS["uint8"], "capacity": 0, "string_capacity": 0,
                            "nested_type_name": ""}}]
    return {"type_name": d.name, "fields": fields}


def type_description(name: str, resolve: Resolver | Mapping[str, MsgDef]) -> dict:
    """The hashable type description: the type and every type it references (transitively), sorted."""
    get = resolve.__getitem__ if isinstance(resolve, Mapping) else resolve
    try:
        main = get(name)
    except KeyError:
        raise UnknownTypeError(f"no definition for {name}") from None
    seen: dict[str, MsgDef] = {}
    todo = [f.base for f in main.fields if f.nested]
    while todo:
        ref = todo.pop()
        if ref in seen:
            continue
        try:
            d = get(ref)
        except KeyError:
            raise UnknownTypeError(f"no definition for {ref} (referenced by {name})") from None
        seen[ref] = d
        todo.extend(f.base for f in d.fields if f.nested)
    return {"type_description": _individual(main),
            "referenced_type_descriptions": [_individual(seen[k]) for k in sorted(seen)]}


def type_hash(name: str, resolve: Resolver | Mapping[str, MsgDef]) -> str:
    """'RIHS01_' + sha256 hex of the canonical JSON of the type description."""
    text = json.dumps(type_description(name, resolve), ensure_ascii=True, allow_nan=False,
                      separators=(", ", ": "), sort_keys=False)
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()
