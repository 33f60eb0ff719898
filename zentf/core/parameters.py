"""ROS 2 parameter messages and services (rcl_interfaces) and the Python value <-> ParameterValue rules.

Types follow rcl_interfaces/msg/ParameterType: a parameter's type is fixed by the value it is declared
with, and a set of another type is refused with ROS 2's message. One difference from ROS 2, said in
the docs: an integer set on a double parameter is taken (as a float), since `zentf param set n rate 20`
should not fail for want of a `.0`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

from .messages import Message, register
from .services import ServiceType, register_service

__all__ = ["PARAMETER_NOT_SET", "PARAMETER_BOOL", "PARAMETER_INTEGER", "PARAMETER_DOUBLE", "PARAMETER_STRING",
           "PARAMETER_BYTE_ARRAY", "PARAMETER_BOOL_ARRAY", "PARAMETER_INTEGER_ARRAY", "PARAMETER_DOUBLE_ARRAY",
           "PARAMETER_STRING_ARRAY", "TYPE_NAMES", "ParameterValue", "ParameterMsg", "SetParametersResult",
           "ParameterDescriptor", "ListParametersResult", "GetParameters", "SetParameters", "ListParameters",
           "DescribeParameters", "GetParameterTypes", "SetParametersAtomically", "type_of", "to_value", "from_value", "check_type", "coerce"]

PARAMETER_NOT_SET = 0
PARAMETER_BOOL = 1
PARAMETER_INTEGER = 2
PARAMETER_DOUBLE = 3
PARAMETER_STRING = 4
PARAMETER_BYTE_ARRAY = 5
PARAMETER_BOOL_ARRAY = 6
PARAMETER_INTEGER_ARRAY = 7
PARAMETER_DOUBLE_ARRAY = 8
PARAMETER_STRING_ARRAY = 9

#: The words ROS 2 uses in its messages ("parameter x is of type {double}").
TYPE_NAMES = {PARAMETER_NOT_SET: "not set", PARAMETER_BOOL: "bool", PARAMETER_INTEGER: "integer",
              PARAMETER_DOUBLE: "double", PARAMETER_STRING: "string", PARAMETER_BYTE_ARRAY: "byte_array",
              PARAMETER_BOOL_ARRAY: "bool_array", PARAMETER_INTEGER_ARRAY: "integer_array",
              PARAMETER_DOUBLE_ARRAY: "double_array", PARAMETER_STRING_ARRAY: "string_array"}

_INT64 = (-(2**63), 2**63 - 1)


@register
@dataclass(slots=True)
class ParameterValue(Message):
    TYPE_NAME: ClassVar[str] = "rcl_interfaces/msg/ParameterValue"
    type: int = PARAMETER_NOT_SET
    bool_value: bool = False
    integer_value: int = 0
    double_value: float = 0.0
    string_value: str = ""
    byte_array_value: list[int] = field(default_factory=list)
    bool_array_value: list[bool] = field(default_factory=list)
    integer_array_value: list[int] = field(default_factory=list)
    double_array_value: list[float] = field(default_factory=list)
    string_array_value: list[str] = field(default_factory=list)


@register
@dataclass(slots=True)
class ParameterMsg(Message):
    """rcl_interfaces/msg/Parameter (named apart from zentf.transport.node.Parameter, the node-side object)."""

    TYPE_NAME: ClassVar[str] = "rcl_interfaces/msg/Parameter"
    name: str = ""
    value: ParameterValue = field(default_factory=ParameterValue)


@register
@dataclass(slots=True)
class SetParametersResult(Message):
    TYPE_NAME: ClassVar[str] = "rcl_interfaces/msg/SetParametersResult"
    successful: bool = False
    reason: str = ""


@register
@dataclass(slots=True)
class ParameterDescriptor(Message):
    TYPE_NAME: ClassVar[str] = "rcl_interfaces/msg/ParameterDescriptor"
    name: str = ""
    type: int = PARAMETER_NOT_SET
    description: str = ""
    read_only: bool = False


@register
@dataclass(slots=True)
class ListParametersResult(Message):
    TYPE_NAME: ClassVar[str] = "rcl_interfaces/msg/ListParametersResult"
    names: list[str] = field(default_factory=list)
    prefixes: list[str] = field(default_factory=list)


def _pair(type_name: str, req_fields: dict[str, Any], resp_fields: dict[str, Any]) -> type[ServiceType]:
    """A service type from field specs {name: (type, default factory)}."""
    import dataclasses

    short = type_name.rsplit("/", 1)[-1]
    parts = []
    for suffix, spec in (("_Request", req_fields), ("_Response", resp_fields)):
        cls = dataclasses.make_dataclass(
            short + suffix, [(n, tp, field(default_factory=f)) for n, (tp, f) in spec.items()],
            bases=(Message,), namespace={"TYPE_NAME": type_name + suffix, "__module__": __name__}, slots=True)
        globals()[cls.__name__] = cls
        parts.append(cls)
    srv = type(short, (ServiceType,), {"TYPE_NAME": type_name, "Request": parts[0], "Response": parts[1],
                                       "__module__": __name__, "__doc__": f"ROS service {type_name}."})
    return register_service(srv)


GetParameters = _pair("rcl_interfaces/srv/GetParameters", {"names": (list[str], list)},
                      {"values": (list[ParameterValue], list)})
SetParameters = _pair("rcl_interfaces/srv/SetParameters", {"parameters": (list[ParameterMsg], list)},
                      {"results": (list[SetParametersResult], list)})
ListParameters = _pair("rcl_interfaces/srv/ListParameters",
                       {"prefixes": (list[str], list), "depth": (int, int)},
                       {"result": (ListParametersResult, ListParametersResult)})
DescribeParameters = _pair("rcl_interfaces/srv/DescribeParameters", {"names": (list[str], list)},
                           {"descriptors": (list[ParameterDescriptor], list)})
GetParameterTypes = _pair("rcl_interfaces/srv/GetParameterTypes", {"names": (list[str], list)},
                          {"types": (list[int], list)})
SetParametersAtomically = _pair("rcl_interfaces/srv/SetParametersAtomically",
                                {"parameters": (list[ParameterMsg], list)},
                                {"result": (SetParametersResult, SetParametersResult)})


def _all(items: Any, kind: type) -> bool:
    return all(type(x) is kind for x in items)


def type_of(value: Any) -> int:
    """The ParameterType of a Python value; ValueError for values a parameter cannot hold."""
    if value is None:
        return PARAMETER_NOT_SET
    if isinstance(value, bool):
        return PARAMETER_BOOL
    if isinstance(value, int):
        if not _INT64[0] <= value <= _INT64[1]:
            raise ValueError(f"integer {value} does not fit in 64 bits")
        return PARAMETER_INTEGER
    if isinstance(value, float):
        return PARAMETER_DOUBLE
    if isinstance(value, str):
        return PARAMETER_STRING
    if isinstance(value, (bytes, bytearray)):
        return PARAMETER_BYTE_ARRAY
    if isinstance(value, (list, tuple)):
        items = list(value)
        if not items:
            return PARAMETER_STRING_ARRAY  # an empty list has no element type; ROS 2 reads [] as string[]
        if _all(items, bool):
            return PARAMETER_BOOL_ARRAY
        if _all(items, int):
            return PARAMETER_INTEGER_ARRAY
        if all(type(x) in (int, float) for x in items):
            return PARAMETER_DOUBLE_ARRAY
        if _all(items, str):
            return PARAMETER_STRING_ARRAY
        raise ValueError(f"a list parameter holds one type (bool, integer, double or string), got {value!r}"[:160])
    raise ValueError(f"a parameter cannot hold a {type(value).__name__} ({value!r})"[:160])


def coerce(value: Any, declared: int) -> Any:
    """The value a parameter of type ``declared`` stores for ``value`` (ints widen to doubles)."""
    if declared == PARAMETER_DOUBLE and type(value) is int:
        return float(value)
    if declared == PARAMETER_DOUBLE_ARRAY and isinstance(value, (list, tuple)):
        return [float(x) for x in value]
    if isinstance(value, tuple):
        return list(value)
    return value


def check_type(name: str, value: Any, declared: int) -> str | None:
    """None if ``value`` may be set on a parameter of type ``declared``, else ROS 2's reason."""
    try:
        got = type_of(value)
    except ValueError as e:
        return f"parameter {name}: {e}"
    if declared == PARAMETER_NOT_SET or got == declared:
        return None
    if declared == PARAMETER_DOUBLE and got == PARAMETER_INTEGER:
        return None
    if declared == PARAMETER_DOUBLE_ARRAY and got == PARAMETER_INTEGER_ARRAY:
        return None
    if got == PARAMETER_STRING_ARRAY and not value and declared in (
            PARAMETER_BOOL_ARRAY, PARAMETER_INTEGER_ARRAY, PARAMETER_DOUBLE_ARRAY, PARAMETER_BYTE_ARRAY):
        return None  # [] fits any array
    return (f"Wrong parameter type, parameter {{{name}}} is of type {{{TYPE_NAMES[declared]}}}, "
            f"setting it to {{{TYPE_NAMES[got]}}} is not allowed.")


def to_value(value: Any) -> ParameterValue:
    """Python value -> ParameterValue; ValueError for values a parameter cannot hold."""
    t = type_of(value)
    v = ParameterValue(type=t)
    if t == PARAMETER_BOOL:
        v.bool_value = value
    elif t == PARAMETER_INTEGER:
        v.integer_value = value
    elif t == PARAMETER_DOUBLE:
        v.double_value = value
    elif t == PARAMETER_STRING:
        v.string_value = value
    elif t == PARAMETER_BYTE_ARRAY:
        v.byte_array_value = list(value)
    elif t == PARAMETER_BOOL_ARRAY:
        v.bool_array_value = list(value)
    elif t == PARAMETER_INTEGER_ARRAY:
        v.integer_array_value = list(value)
    elif t == PARAMETER_DOUBLE_ARRAY:
        v.double_array_value = [float(x) for x in value]
    elif t == PARAMETER_STRING_ARRAY:
        v.string_array_value = list(value)
    return v


def from_value(v: ParameterValue) -> Any:
    """ParameterValue -> Python value (None when not set); ValueError for an unknown type code."""
    fields = {PARAMETER_NOT_SET: None, PARAMETER_BOOL: "bool_value", PARAMETER_INTEGER: "integer_value",
              PARAMETER_DOUBLE: "double_value", PARAMETER_STRING: "string_value",
              PARAMETER_BYTE_ARRAY: "byte_array_value", PARAMETER_BOOL_ARRAY: "bool_array_value",
              PARAMETER_INTEGER_ARRAY: "integer_array_value", PARAMETER_DOUBLE_ARRAY: "double_array_value",
              PARAMETER_STRING_ARRAY: "string_array_value"}
    if v.type not in fields:
        raise ValueError(f"unknown parameter type code {v.type}")
    name = fields[v.type]
    if name is None:
        return None
    out = getattr(v, name)
    return list(out) if isinstance(out, list) else out
