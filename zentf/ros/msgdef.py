"""ROS 2 .msg text -> a small type model (fields with their base type, array kind and bounds).

Parses what rosidl's .msg adapter accepts for the types zentf uses and what rosbag2 writes into MCAP
schemas (``ros2msg``: the main definition, then ``===`` + ``MSG: pkg/msg/Type`` blocks). Constants and
default values are read and skipped: neither is part of the wire layout nor of the type hash.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from .errors import DefinitionError

__all__ = ["Field", "MsgDef", "PRIMITIVES", "parse_msg", "parse_schema", "normalize_type_name"]

#: .msg primitive -> (struct code, size); strings are handled apart.
PRIMITIVES: dict[str, tuple[str, int]] = {
    "bool": ("?", 1), "byte": ("B", 1), "char": ("B", 1), "int8": ("b", 1), "uint8": ("B", 1),
    "int16": ("h", 2), "uint16": ("H", 2), "int32": ("i", 4), "uint32": ("I", 4),
    "int64": ("q", 8), "uint64": ("Q", 8), "float32": ("f", 4), "float64": ("d", 8),
}
STRINGS = ("string", "wstring")

_FIELD = re.compile(r"^(?P<type>[A-Za-z_][\w/]*)(?:<=(?P<sbound>\d+))?(?P<arr>\[(?P<abound><=)?(?P<n>\d*)\])?\s+"
                    r"(?P<name>[A-Za-z_]\w*)(?P<rest>.*)$")


@dataclass(frozen=True, slots=True)
class Field:
    """One field: ``base`` is a primitive, 'string'/'wstring' or a full nested type name."""

    name: str
    base: str
    array: str | None = None      # None, 'fixed', 'bounded' (sequence<=N) or 'sequence'
    length: int = 0               # fixed size or sequence bound
    string_bound: int = 0

    @property
    def nested(self) -> bool:
        return self.base not in PRIMITIVES and self.base not in STRINGS


@dataclass(frozen=True, slots=True)
class MsgDef:
    name: str                     # 'geometry_msgs/msg/Point'
    fields: tuple[Field, ...]


def normalize_type_name(name: str, package: str = "") -> str:
    """'Point' (in package geometry_msgs), 'geometry_msgs/Point' -> 'geometry_msgs/msg/Point'."""
    parts = name.split("/")
    if len(parts) == 3:
        return name
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 1 and package:
        return f"{package}/msg/{name}"
    raise DefinitionError(f"cannot resolve type name {name!r}")


def _base_type(token: str, package: str) -> str:
    if token in PRIMITIVES or token in STRINGS:
        return token
    if token == "Header":  # ROS 1 shorthand still accepted by rosidl
        return "std_msgs/msg/Header"
    return normalize_type_name(token, package)


def parse_msg(type_name: str, text: str) -> MsgDef:
    """Parse one .msg definition of ``type_name`` ('pkg/msg/Name')."""
    package = type_name.split("/")[0]
    fields: list[Field] = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = _FIELD.match(line)
        if m is None:
            raise DefinitionError(f"{type_name} line {lineno}: cannot parse {raw.strip()!r}")
        rest = m.group("rest").strip()
        if rest.startswith("="):
            continue  # a constant
        base = _base_type(m.group("type"), package)
        array = None
        length = 0
        if m.group("arr"):
            n = m.group("n")
            if m.group("abound"):
                array, length = "bounded", int(n)
            elif n:
                array, length = "fixed", int(n)
            else:
                array = "sequence"
        sbound = int(m.group("sbound") or 0)
        if base == "wstring":
            raise DefinitionError(f"{type_name}: wstring fields are not supported ({m.group('name')})")
        fields.append(Field(m.group("name"), base, array, length, sbound))
    return MsgDef(type_name, tuple(fields))


def parse_schema(type_name: str, text: str) -> dict[str, MsgDef]:
    """A rosbag2 'ros2msg' schema (main text, then '===...' / 'MSG: pkg/Name' blocks) -> every definition."""
    defs: dict[str, MsgDef] = {}
    current = type_name
    block: list[str] = []
    lines = text.splitlines()
    i = 0

    def flush() -> None:
        defs[current] = parse_msg(current, "\n".join(block))

    while i < len(lines):
        line = lines[i]
        if line.startswith("===") and i + 1 < len(lines) and lines[i + 1].startswith("MSG:"):
            flush()
            current = normalize_type_name(lines[i + 1][4:].strip())
            block = []
            i += 2
            continue
        block.append(line)
        i += 1
    flush()
    return defs
