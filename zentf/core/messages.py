"""ROS message types as typed dataclasses whose plain-dict form (ROS field names) is the wire form."""
from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypeVar

from .time import Duration, Time

__all__ = [
    "Message", "Header", "Vector3", "Point", "Quaternion", "Transform", "TransformStamped",
    "PointStamped", "Vector3Stamped", "Pose", "PoseStamped", "TFMessage", "Clock",
    "register", "message_type", "type_name_of", "MESSAGE_TYPES",
]

M = TypeVar("M", bound="Message")

#: Every message class by its ROS type name ("geometry_msgs/msg/TransformStamped").
MESSAGE_TYPES: dict[str, type["Message"]] = {}


class Message:
    """Base of all messages: dict conversion driven by the dataclass fields."""

    TYPE_NAME: ClassVar[str] = ""
    _spec: ClassVar[tuple[tuple[str, Any], ...]]

    def to_dict(self) -> dict:
        return {name: _to_plain(getattr(self, name)) for name, _ in type(self)._fields()}

    @classmethod
    def from_dict(cls: type[M], d: object, _path: str = "") -> M:
        """Build from the plain dict; a ValueError names the first bad field by its path."""
        where = _path or cls.__name__
        if not isinstance(d, dict):
            raise ValueError(f"{where}: expected a dict, got {type(d).__name__}")
        spec = cls._fields()
        names = {n for n, _ in spec}
        unknown = [k for k in d if k not in names]
        if unknown:
            raise ValueError(f"{where}: unknown field {unknown[0]!r}")
        kwargs = {}
        for name, tp in spec:
            if name in d:
                kwargs[name] = _from_plain(tp, d[name], f"{where}.{name}" if _path else f"{cls.__name__}.{name}")
        return cls(**kwargs)

    @classmethod
    def _fields(cls) -> tuple[tuple[str, Any], ...]:
        spec = cls.__dict__.get("_spec")
        if spec is None:
            hints = typing.get_type_hints(cls)
            spec = tuple((f.name, hints[f.name]) for f in dataclasses.fields(cls))  # type: ignore[arg-type]
            cls._spec = spec
        return spec


def _to_plain(v: Any) -> Any:
    if isinstance(v, (Message, Time, Duration)):
        return v.to_dict()
    if isinstance(v, list):
        return [_to_plain(x) for x in v]
    return v


def _from_plain(tp: Any, v: Any, path: str) -> Any:
    if tp is float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"{path}: expected a number, got {v!r}")
        return float(v)
    if tp is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise ValueError(f"{path}: expected an integer, got {v!r}")
        return v
    if tp is str:
        if not isinstance(v, str):
            raise ValueError(f"{path}: expected a string, got {v!r}")
        return v
    if tp is bool:
        if not isinstance(v, bool):
            raise ValueError(f"{path}: expected true or false, got {v!r}")
        return v
    if tp is Time or tp is Duration:
        try:
            return tp.from_dict(v)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None
    origin = typing.get_origin(tp)
    if origin is list:
        (item,) = typing.get_args(tp)
        if not isinstance(v, (list, tuple)):
            raise ValueError(f"{path}: expected a list, got {type(v).__name__}")
        return [_from_plain(item, x, f"{path}[{i}]") for i, x in enumerate(v)]
    if isinstance(tp, type) and issubclass(tp, Message):
        return tp.from_dict(v, path)
    raise TypeError(f"{path}: unsupported field type {tp!r}")  # a bug in a message definition


def register(cls: type[M]) -> type[M]:
    """Make a message class decodable by its carried type name."""
    MESSAGE_TYPES[cls.TYPE_NAME] = cls
    return cls


def message_type(type_name: str) -> type[Message]:
    """The class for a type name; KeyError names the unknown type."""
    try:
        return MESSAGE_TYPES[type_name]
    except KeyError:
        raise KeyError(f"unknown message type {type_name!r}") from None


def type_name_of(msg_or_cls: Message | type[Message]) -> str:
    return msg_or_cls.TYPE_NAME


@register
@dataclass(slots=True)
class Header(Message):
    TYPE_NAME: ClassVar[str] = "std_msgs/msg/Header"
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@register
@dataclass(slots=True)
class Vector3(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Vector3"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@register
@dataclass(slots=True)
class Point(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Point"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@register
@dataclass(slots=True)
class Quaternion(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Quaternion"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0

    def is_finite(self) -> bool:
        return all(map(math.isfinite, (self.x, self.y, self.z, self.w)))


@register
@dataclass(slots=True)
class Transform(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Transform"
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@register
@dataclass(slots=True)
class TransformStamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/TransformStamped"
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@register
@dataclass(slots=True)
class PointStamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/PointStamped"
    header: Header = field(default_factory=Header)
    point: Point = field(default_factory=Point)


@register
@dataclass(slots=True)
class Vector3Stamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Vector3Stamped"
    header: Header = field(default_factory=Header)
    vector: Vector3 = field(default_factory=Vector3)


@register
@dataclass(slots=True)
class Pose(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Pose"
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@register
@dataclass(slots=True)
class PoseStamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/PoseStamped"
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


# --- More geometry_msgs that tf2_geometry_msgs transforms -----------------------------------------


@register
@dataclass(slots=True)
class QuaternionStamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/QuaternionStamped"
    header: Header = field(default_factory=Header)
    quaternion: Quaternion = field(default_factory=Quaternion)


@register
@dataclass(slots=True)
class PoseWithCovariance(Message):
    """A pose and its 6x6 row-major covariance (x, y, z, rotation about X, Y, Z), 36 numbers."""

    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/PoseWithCovariance"
    pose: Pose = field(default_factory=Pose)
    covariance: list[float] = field(default_factory=lambda: [0.0] * 36)

    def __post_init__(self) -> None:
        if len(self.covariance) != 36:  # a fixed float64[36] in ROS
            raise ValueError(f"PoseWithCovariance.covariance must have 36 numbers, got {len(self.covariance)}")


@register
@dataclass(slots=True)
class PoseWithCovarianceStamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/PoseWithCovarianceStamped"
    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@register
@dataclass(slots=True)
class Wrench(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Wrench"
    force: Vector3 = field(default_factory=Vector3)
    torque: Vector3 = field(default_factory=Vector3)


@register
@dataclass(slots=True)
class WrenchStamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/WrenchStamped"
    header: Header = field(default_factory=Header)
    wrench: Wrench = field(default_factory=Wrench)


@register
@dataclass(slots=True)
class TwistStamped(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/TwistStamped"
    header: Header = field(default_factory=Header)
    twist: "Twist" = field(default_factory=lambda: Twist())  # Twist is defined with the demo messages below


@register
@dataclass(slots=True)
class VelocityStamped(Message):
    """What ROS 2 tf2's lookupVelocity returns: the twist of body_frame_id, in header.frame_id."""

    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/VelocityStamped"
    header: Header = field(default_factory=Header)
    body_frame_id: str = ""
    reference_frame_id: str = ""
    velocity: "Twist" = field(default_factory=lambda: Twist())


__all__ += ["QuaternionStamped", "PoseWithCovariance", "PoseWithCovarianceStamped", "Wrench", "WrenchStamped",
            "TwistStamped", "VelocityStamped"]


@register
@dataclass(slots=True)
class TFMessage(Message):
    TYPE_NAME: ClassVar[str] = "tf2_msgs/msg/TFMessage"
    transforms: list[TransformStamped] = field(default_factory=list)


@register
@dataclass(slots=True)
class Clock(Message):
    TYPE_NAME: ClassVar[str] = "rosgraph_msgs/msg/Clock"
    clock: Time = field(default_factory=Time)


# --- Messages used by the demo node programs (nodes/) -------------------------------------------


@register
@dataclass(slots=True)
class Twist(Message):
    TYPE_NAME: ClassVar[str] = "geometry_msgs/msg/Twist"
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@register
@dataclass(slots=True)
class TurtlePose(Message):
    """turtlesim's own Pose (planar), not geometry_msgs/Pose."""

    TYPE_NAME: ClassVar[str] = "turtlesim/msg/Pose"
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    linear_velocity: float = 0.0
    angular_velocity: float = 0.0


@register
@dataclass(slots=True)
class SpawnRequest(Message):
    """turtlesim's Spawn request; an empty name asks the simulator to pick one."""

    TYPE_NAME: ClassVar[str] = "turtlesim/srv/Spawn_Request"
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    name: str = ""


@register
@dataclass(slots=True)
class SpawnResponse(Message):
    TYPE_NAME: ClassVar[str] = "turtlesim/srv/Spawn_Response"
    name: str = ""


@register
@dataclass(slots=True)
class ColorRGBA(Message):
    TYPE_NAME: ClassVar[str] = "std_msgs/msg/ColorRGBA"
    r: float = 0.0
    g: float = 0.0
    b: float = 0.0
    a: float = 0.0


@register
@dataclass(slots=True)
class Marker(Message):
    """visualization_msgs/Marker without the mesh/texture fields nobody here draws."""

    TYPE_NAME: ClassVar[str] = "visualization_msgs/msg/Marker"
    ARROW: ClassVar[int] = 0
    CUBE: ClassVar[int] = 1
    SPHERE: ClassVar[int] = 2
    CYLINDER: ClassVar[int] = 3
    LINE_STRIP: ClassVar[int] = 4
    LINE_LIST: ClassVar[int] = 5
    CUBE_LIST: ClassVar[int] = 6
    SPHERE_LIST: ClassVar[int] = 7
    POINTS: ClassVar[int] = 8
    TEXT_VIEW_FACING: ClassVar[int] = 9
    ADD: ClassVar[int] = 0
    MODIFY: ClassVar[int] = 0
    DELETE: ClassVar[int] = 2
    DELETEALL: ClassVar[int] = 3
    header: Header = field(default_factory=Header)
    ns: str = ""
    id: int = 0
    type: int = 0
    action: int = 0
    pose: Pose = field(default_factory=Pose)
    scale: Vector3 = field(default_factory=Vector3)
    color: ColorRGBA = field(default_factory=ColorRGBA)
    lifetime: Duration = field(default_factory=Duration)
    frame_locked: bool = False
    points: list[Point] = field(default_factory=list)
    colors: list[ColorRGBA] = field(default_factory=list)
    text: str = ""


@register
@dataclass(slots=True)
class MarkerArray(Message):
    TYPE_NAME: ClassVar[str] = "visualization_msgs/msg/MarkerArray"
    markers: list[Marker] = field(default_factory=list)


__all__ += ["Twist", "TurtlePose", "SpawnRequest", "SpawnResponse", "ColorRGBA", "Marker", "MarkerArray"]


# --- Robot models (zentf.urdf, robot_state_publisher, joint_state_publisher) ---------------------


@register
@dataclass(slots=True)
class String(Message):
    """std_msgs/String: the URDF text on ``robot_description``."""

    TYPE_NAME: ClassVar[str] = "std_msgs/msg/String"
    data: str = ""


@register
@dataclass(slots=True)
class JointState(Message):
    """sensor_msgs/JointState: ``name[i]`` is at ``position[i]``; velocity/effort may be empty."""

    TYPE_NAME: ClassVar[str] = "sensor_msgs/msg/JointState"
    header: Header = field(default_factory=Header)
    name: list[str] = field(default_factory=list)
    position: list[float] = field(default_factory=list)
    velocity: list[float] = field(default_factory=list)
    effort: list[float] = field(default_factory=list)

    def to_dict(self) -> dict:
        """The generic form without the per-element reflection (lists of plain values; ~10x cheaper)."""
        h = self.header
        return {"header": {"stamp": h.stamp.to_dict(), "frame_id": h.frame_id}, "name": list(self.name),
                "position": list(self.position), "velocity": list(self.velocity), "effort": list(self.effort)}


__all__ += ["String", "JointState"]
