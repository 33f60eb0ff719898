"""ROS service types: a request and a response message under one ROS name (``turtlesim/srv/Spawn``).

A service type is a class with ``TYPE_NAME`` and the ``Request``/``Response`` message classes, as in
rclpy (``Spawn.Request(x=4.0, y=2.0)``). Its messages are registered like any message under
``<type>_Request`` / ``<type>_Response`` (ROS 2's names), so generic tools decode them too.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from .messages import Message, SpawnRequest, SpawnResponse, TransformStamped, register
from .time import Duration, Time

__all__ = ["ServiceType", "SERVICE_TYPES", "register_service", "service_type", "Spawn", "Kill",
           "TeleportAbsolute", "Empty", "Trigger", "SetBool", "TF2Error", "LookupTransform"]

#: Every service type by its ROS name ("std_srvs/srv/Trigger").
SERVICE_TYPES: dict[str, type["ServiceType"]] = {}


class ServiceType:
    """Base of service types: ``TYPE_NAME`` plus ``Request`` and ``Response`` message classes."""

    TYPE_NAME: ClassVar[str] = ""
    Request: ClassVar[type[Message]]
    Response: ClassVar[type[Message]]


def register_service(cls: type[ServiceType]) -> type[ServiceType]:
    """Make a service type known by name (for ``zentf service call``) and its messages decodable."""
    for part, suffix in ((cls.Request, "_Request"), (cls.Response, "_Response")):
        if part.TYPE_NAME != cls.TYPE_NAME + suffix:
            raise TypeError(f"{part.__name__}.TYPE_NAME must be {cls.TYPE_NAME + suffix!r}")
        register(part)
    SERVICE_TYPES[cls.TYPE_NAME] = cls
    return cls


def service_type(type_name: str) -> type[ServiceType]:
    """The class for a service type name; KeyError names the unknown type and the known ones."""
    try:
        return SERVICE_TYPES[type_name]
    except KeyError:
        raise KeyError(f"unknown service type {type_name!r} (known: {', '.join(sorted(SERVICE_TYPES))})") from None


def _srv(type_name: str, request: type[Message], response: type[Message]) -> type[ServiceType]:
    cls = type(type_name.rsplit("/", 1)[-1], (ServiceType,),
               {"TYPE_NAME": type_name, "Request": request, "Response": response, "__module__": __name__,
                "__doc__": f"ROS service {type_name}."})
    return register_service(cls)


# ---- turtlesim
Spawn = _srv("turtlesim/srv/Spawn", SpawnRequest, SpawnResponse)


@dataclass(slots=True)
class KillRequest(Message):
    TYPE_NAME: ClassVar[str] = "turtlesim/srv/Kill_Request"
    name: str = ""


@dataclass(slots=True)
class KillResponse(Message):
    TYPE_NAME: ClassVar[str] = "turtlesim/srv/Kill_Response"


Kill = _srv("turtlesim/srv/Kill", KillRequest, KillResponse)


@dataclass(slots=True)
class TeleportAbsoluteRequest(Message):
    TYPE_NAME: ClassVar[str] = "turtlesim/srv/TeleportAbsolute_Request"
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0


@dataclass(slots=True)
class TeleportAbsoluteResponse(Message):
    TYPE_NAME: ClassVar[str] = "turtlesim/srv/TeleportAbsolute_Response"


TeleportAbsolute = _srv("turtlesim/srv/TeleportAbsolute", TeleportAbsoluteRequest, TeleportAbsoluteResponse)


# ---- std_srvs
@dataclass(slots=True)
class EmptyRequest(Message):
    TYPE_NAME: ClassVar[str] = "std_srvs/srv/Empty_Request"


@dataclass(slots=True)
class EmptyResponse(Message):
    TYPE_NAME: ClassVar[str] = "std_srvs/srv/Empty_Response"


Empty = _srv("std_srvs/srv/Empty", EmptyRequest, EmptyResponse)


@dataclass(slots=True)
class TriggerRequest(Message):
    TYPE_NAME: ClassVar[str] = "std_srvs/srv/Trigger_Request"


@dataclass(slots=True)
class TriggerResponse(Message):
    TYPE_NAME: ClassVar[str] = "std_srvs/srv/Trigger_Response"
    success: bool = False
    message: str = ""


Trigger = _srv("std_srvs/srv/Trigger", TriggerRequest, TriggerResponse)


@dataclass(slots=True)
class SetBoolRequest(Message):
    TYPE_NAME: ClassVar[str] = "std_srvs/srv/SetBool_Request"
    data: bool = False


@dataclass(slots=True)
class SetBoolResponse(Message):
    TYPE_NAME: ClassVar[str] = "std_srvs/srv/SetBool_Response"
    success: bool = False
    message: str = ""


SetBool = _srv("std_srvs/srv/SetBool", SetBoolRequest, SetBoolResponse)


# ---- tf2_msgs: the buffer server's lookup (tf2_ros serves it as an action; zentf as one request/reply)
@register
@dataclass(slots=True)
class TF2Error(Message):
    """tf2_msgs/msg/TF2Error: which tf2 exception a remote lookup raised, and its text."""

    TYPE_NAME: ClassVar[str] = "tf2_msgs/msg/TF2Error"
    NO_ERROR: ClassVar[int] = 0
    LOOKUP_ERROR: ClassVar[int] = 1
    CONNECTIVITY_ERROR: ClassVar[int] = 2
    EXTRAPOLATION_ERROR: ClassVar[int] = 3
    INVALID_ARGUMENT_ERROR: ClassVar[int] = 4
    TIMEOUT_ERROR: ClassVar[int] = 5
    TRANSFORM_ERROR: ClassVar[int] = 6
    error: int = 0
    error_string: str = ""


@dataclass(slots=True)
class LookupTransformRequest(Message):
    """The goal of tf2_msgs/action/LookupTransform (``advanced``: the full form with a fixed frame)."""

    TYPE_NAME: ClassVar[str] = "tf2_msgs/action/LookupTransform_Request"
    target_frame: str = ""
    source_frame: str = ""
    source_time: Time = field(default_factory=Time)
    timeout: Duration = field(default_factory=Duration)
    target_time: Time = field(default_factory=Time)
    fixed_frame: str = ""
    advanced: bool = False


@dataclass(slots=True)
class LookupTransformResponse(Message):
    """The result of tf2_msgs/action/LookupTransform: the transform, or the error."""

    TYPE_NAME: ClassVar[str] = "tf2_msgs/action/LookupTransform_Response"
    transform: TransformStamped = field(default_factory=TransformStamped)
    error: TF2Error = field(default_factory=TF2Error)


LookupTransform = _srv("tf2_msgs/action/LookupTransform", LookupTransformRequest, LookupTransformResponse)
