"""Message and service classes made from ROS definitions, for the types zentf has a .msg/.srv text of but no
hand-written class (so `zentf service call` takes every service type it knows, on either wire).

A made class is a zentf Message dataclass like the hand-written ones (``from_dict``, ``to_dict``, ROS field
names and defaults); a type that has a class already (``zentf.core.messages.message_type``) keeps it, so
nested hand-written types stay themselves. Made classes are cached (made again when a definition is
registered anew), not registered: decoding elsewhere is unchanged.
"""
from __future__ import annotations

import dataclasses
import keyword
import threading
from typing import Any

from ..core.messages import Message, message_type
from ..core.services import SERVICE_TYPES, ServiceType
from ..core.time import Duration, Time
from .errors import DefinitionError, UnknownTypeError
from .msgdef import PRIMITIVES, Field
from .types import definition, service_types

__all__ = ["message_class", "service_class"]

_FLOATS = ("float32", "float64")
_BUILTIN = {"builtin_interfaces/msg/Time": Time, "builtin_interfaces/msg/Duration": Duration}
_made: dict[str, Any] = {}
_lock = threading.Lock()


def _scalar(base: str) -> tuple[Any, Any]:
    """(annotation, default factory) of one element of ``base``."""
    if base in _FLOATS:
        return float, float
    if base == "bool":
        return bool, bool
    if base in PRIMITIVES:
        return int, int
    if base in ("string", "wstring"):
        return str, str
    cls = _class(base)
    return cls, cls


def _field(f: Field) -> tuple[str, Any, Any]:
    if keyword.iskeyword(f.name):
        raise DefinitionError(f"field name {f.name!r} is a Python keyword")
    tp, make = _scalar(f.base)
    if f.array is None:
        return f.name, tp, dataclasses.field(default_factory=make)
    n = f.length if f.array == "fixed" else 0
    return f.name, list[tp], dataclasses.field(default_factory=lambda: [make() for _ in range(n)])


def _class(type_name: str) -> Any:
    """The class of a message type: Time/Duration, a hand-written one, or one made from its definition."""
    if type_name in _BUILTIN:
        return _BUILTIN[type_name]
    try:
        return message_type(type_name)
    except KeyError:
        pass
    d = definition(type_name)
    made = _made.get(type_name)
    if made is not None and made[0] is d:
        return made[1]
    # first use, or the definition was registered again since (register_definition replaces)
    short = type_name.rsplit("/", 1)[-1]
    cls = dataclasses.make_dataclass(short, [_field(f) for f in d.fields], bases=(Message,),
                                     namespace={"TYPE_NAME": type_name, "__module__": __name__}, slots=True)
    _made[type_name] = (d, cls)
    return cls


def message_class(type_name: str) -> type[Message]:
    """A Message class for ``type_name`` ('pkg/msg/Name'); UnknownTypeError when zentf has no definition."""
    with _lock:
        return _class(type_name)


def service_class(type_name: str) -> type[ServiceType]:
    """The service type ``type_name`` ('pkg/srv/Name'): its registered class, or one made from its .srv text;
    UnknownTypeError when zentf has neither."""
    known = SERVICE_TYPES.get(type_name)
    if known is not None:
        return known
    if type_name not in service_types():
        raise UnknownTypeError(f"unknown service type {type_name!r}")
    with _lock:
        parts = (_class(type_name + "_Request"), _class(type_name + "_Response"))
        made = _made.get(type_name)
        if made is not None and made[0] == parts:
            return made[1]
        short = type_name.rsplit("/", 1)[-1]
        srv = type(short, (ServiceType,), {
            "TYPE_NAME": type_name, "Request": parts[0], "Response": parts[1], "__module__": __name__,
            "__doc__": f"ROS service {type_name} (made from its definition)."})
        _made[type_name] = (parts, srv)
    return srv
