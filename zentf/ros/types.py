"""The ROS 2 types zentf knows: parsed definitions, DDS type names and RIHS01 hashes (computed once).

A service ``pkg/srv/Name`` is held as rosidl describes it for hashing (rosidl_parser's Service,
rosidl_generator_type_description): the messages ``Name_Request`` and ``Name_Response``, the message
``Name_Event`` (``service_msgs/ServiceEventInfo info``, ``Name_Request[<=1] request``,
``Name_Response[<=1] response``) and the service itself as a structure of three fields
(``request_message``, ``response_message``, ``event_message``). Its RIHS01 hash is the hash of that
structure with all it references, as for a message; rmw_zenoh puts it in the service's key.
"""
from __future__ import annotations

from functools import lru_cache

from .definitions import DEFINITIONS, SERVICES
from .errors import DefinitionError, UnknownTypeError
from .msgdef import MsgDef, parse_msg
from .typehash import type_hash as _type_hash

__all__ = ["definition", "known_types", "dds_type_name", "ros_type_name", "type_hash", "register_definition",
           "register_service_definition", "split_srv", "service_types", "schema_text", "definition_text",
           "message_types"]

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
_SERVICES: set[str] = set()


def split_srv(type_name: str, text: str) -> tuple[str, str]:
    """(request text, response text) of a .srv: the parts before and after the ``---`` line."""
    lines = text.splitlines()
    marks = [i for i, line in enumerate(lines) if line.split("#", 1)[0].strip() == "---"]
    if len(marks) != 1:
        raise DefinitionError(f"{type_name}: a .srv needs exactly one '---' line, found {len(marks)}")
    i = marks[0]
    return "\n".join(lines[:i]) + "\n", "\n".join(lines[i + 1:]) + "\n"


def _service_defs(type_name: str, text: str) -> dict[str, str]:
    """The .msg texts of a service's Request, Response, Event and of the service structure itself."""
    req, resp = split_srv(type_name, text)
    return {
        f"{type_name}_Request": req,
        f"{type_name}_Response": resp,
        f"{type_name}_Event": (f"service_msgs/ServiceEventInfo info\n{type_name}_Request[<=1] request\n"
                               f"{type_name}_Response[<=1] response\n"),
        type_name: (f"{type_name}_Request request_message\n{type_name}_Response response_message\n"
                    f"{type_name}_Event event_message\n"),
    }


def register_service_definition(type_name: str, text: str) -> MsgDef:
    """Add (or replace) a service from its .srv text ('pkg/srv/Name', or 'pkg/action/Name' for an action
    zentf serves as one request and one reply); its hash needs the types it uses."""
    if type_name.count("/") != 2 or type_name.split("/")[1] not in ("srv", "action"):
        raise DefinitionError(f"a service type is named pkg/srv/Name, got {type_name!r}")
    parsed = {n: parse_msg(n, t) for n, t in _service_defs(type_name, text).items()}
    for n, t in _service_defs(type_name, text).items():
        _DEFS[n] = parsed[n]
        _TEXTS[n] = t
    _SERVICES.add(type_name)
    type_hash.cache_clear()
    return parsed[type_name]


def service_types() -> list[str]:
    """The service types with a definition ('pkg/srv/Name', 'pkg/action/Name')."""
    return sorted(_SERVICES)


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
    """RIHS01 hash of a known message or service type, computed from its definition and those it references."""
    return _type_hash(type_name, definition)


for _name, _text in SERVICES.items():
    register_service_definition(_name, _text)


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


def definition_text(type_name: str) -> str:
    """The .msg (or, for 'pkg/srv/Name', the .srv: request, ``---``, response) text of a known type."""
    if type_name in _SERVICES:
        return _TEXTS[f"{type_name}_Request"].rstrip("\n") + "\n---\n" + _TEXTS[f"{type_name}_Response"].lstrip("\n")
    try:
        return _TEXTS[type_name]
    except KeyError:
        raise UnknownTypeError(f"unknown ROS type {type_name!r}") from None


def message_types() -> list[str]:
    """The message types with a definition ('pkg/msg/Name'; a service's parts are not listed)."""
    return sorted(n for n in _DEFS if n.split("/")[1:2] == ["msg"])
