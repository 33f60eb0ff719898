"""The URDF model: links with their visuals, joints, materials, and the kinematic tree they form.

Names follow urdf_parser_py (``Robot``, ``Joint``, ``Link``, ``Visual``, ``Mesh``...; ``URDF`` is an
alias of ``Robot``). A ``Robot`` comes from ``zentf.urdf.load_urdf``/``parse_urdf`` and is always a
valid tree: the parser refuses anything else.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Union

import numpy as np

from ..core.text import printable

__all__ = ["Pose", "Color", "Material", "Box", "Cylinder", "Sphere", "Mesh", "Geometry", "Visual",
           "Link", "JointLimit", "JointMimic", "Joint", "Robot", "URDF", "JOINT_TYPES", "MOVABLE_TYPES"]

#: Every joint type URDF defines.
JOINT_TYPES = ("fixed", "revolute", "continuous", "prismatic", "floating", "planar")
#: Types driven by one joint_states position. robot_state_publisher (via KDL) treats floating and
#: planar joints as fixed at their origin; zentf does the same.
MOVABLE_TYPES = ("revolute", "continuous", "prismatic")


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """3x3 rotation of URDF rpy: fixed axes X, Y, Z (R = Rz·Ry·Rx)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def origin_matrices(poses: "list[Pose]") -> np.ndarray:
    """``(n, 4, 4)``: ``Pose.matrix()`` of each pose, built in one go (a model can have 100,000 joints); the
    same arithmetic as ``rpy_matrix``, element by element, so the same bits."""
    n = len(poses)
    angles = [a for p in poses for a in p.rpy]
    cos = np.array([math.cos(a) for a in angles]).reshape(n, 3)
    sin = np.array([math.sin(a) for a in angles]).reshape(n, 3)
    cr, cp, cy = cos[:, 0], cos[:, 1], cos[:, 2]
    sr, sp, sy = sin[:, 0], sin[:, 1], sin[:, 2]
    m = np.zeros((n, 4, 4))
    m[:, 0, 0] = cy * cp
    m[:, 0, 1] = cy * sp * sr - sy * cr
    m[:, 0, 2] = cy * sp * cr + sy * sr
    m[:, 1, 0] = sy * cp
    m[:, 1, 1] = sy * sp * sr + cy * cr
    m[:, 1, 2] = sy * sp * cr - cy * sr
    m[:, 2, 0] = -sp
    m[:, 2, 1] = cp * sr
    m[:, 2, 2] = cp * cr
    m[:, :3, 3] = np.array([p.xyz for p in poses], dtype=float).reshape(n, 3)
    m[:, 3, 3] = 1.0
    return m


@dataclass(frozen=True, slots=True)
class Pose:
    """An ``<origin xyz rpy>``: translation and fixed-axis roll, pitch, yaw."""

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = rpy_matrix(*self.rpy)
        m[:3, 3] = self.xyz
        return m

    def quaternion(self) -> tuple[float, float, float, float]:
        from ..core.math3d import quaternion_from_rpy

        return quaternion_from_rpy(*self.rpy)


Color = tuple[float, float, float, float]


@dataclass(slots=True)
class Material:
    name: str = ""
    color: Color | None = None
    texture: str | None = None


@dataclass(slots=True)
class Box:
    size: tuple[float, float, float]


@dataclass(slots=True)
class Cylinder:
    radius: float
    length: float


@dataclass(slots=True)
class Sphere:
    radius: float


@dataclass(slots=True)
class Mesh:
    """A mesh file; ``path`` is the resolved local file, None when it could not be found."""

    filename: str
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    path: str | None = None


Geometry = Union[Box, Cylinder, Sphere, Mesh]


@dataclass(slots=True)
class Visual:
    geometry: Geometry
    origin: Pose = field(default_factory=Pose)
    material: Material | None = None
    name: str | None = None


@dataclass(slots=True)
class Link:
    name: str
    visuals: list[Visual] = field(default_factory=list)
    line: int | None = None

    @property
    def visual(self) -> Visual | None:
        return self.visuals[0] if self.visuals else None


@dataclass(frozen=True, slots=True)
class JointLimit:
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0


@dataclass(frozen=True, slots=True)
class JointMimic:
    """position = multiplier * position(joint) + offset."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(slots=True)
class Joint:
    name: str
    type: str
    parent: str
    child: str
    origin: Pose = field(default_factory=Pose)
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    limit: JointLimit | None = None
    mimic: JointMimic | None = None
    line: int | None = None

    @property
    def joint_type(self) -> str:  # urdf_parser_py's attribute name
        return self.type

    @property
    def movable(self) -> bool:
        """Driven by a joint_states position (revolute, continuous, prismatic)."""
        return self.type in MOVABLE_TYPES

    def bounds(self) -> tuple[float, float]:
        """The range a slider or a sweep uses: the limits; continuous (or limitless) joints ±π."""
        if self.type == "continuous" or self.limit is None:
            return (-math.pi, math.pi)
        return (min(self.limit.lower, self.limit.upper), max(self.limit.lower, self.limit.upper))

    def center(self) -> float:
        """joint_state_publisher's start value: 0, or the middle of the range when 0 is outside it."""
        lo, hi = self.bounds()
        return 0.0 if lo <= 0.0 <= hi else lo / 2.0 + hi / 2.0  # (lo + hi) / 2 overflows near 1e308


@dataclass(slots=True)
class Robot:
    """A parsed, checked URDF: ``links`` and ``joints`` by name, in document order."""

    name: str
    links: dict[str, Link] = field(default_factory=dict)
    joints: dict[str, Joint] = field(default_factory=dict)
    materials: dict[str, Material] = field(default_factory=dict)
    source: str | None = None       # file it came from (None for a string)
    xml: str = ""                   # the URDF text (published as robot_description)
    root: str = ""                  # the one link with no parent
    parent_joint: dict[str, str] = field(default_factory=dict)   # child link -> joint name
    child_joints: dict[str, list[str]] = field(default_factory=dict)  # link -> joint names
    _drivers: dict | None = field(default=None, repr=False, compare=False)

    def get_root(self) -> str:
        return self.root

    def joints_in_order(self) -> list[Joint]:
        """Every joint, parents before children (breadth-first from the root; no recursion, linear time)."""
        out: list[Joint] = []
        todo = deque([self.root])
        while todo:
            link = todo.popleft()
            for jn in self.child_joints.get(link, []):
                j = self.joints[jn]
                out.append(j)
                todo.append(j.child)
        return out

    def mimic_drivers(self) -> dict[str, tuple[str | None, float, float]]:
        """Every joint's driver: (the joint whose position sets it, multiplier, offset), mimic chains
        composed (``m1 * (m2 * q + o2) + o1``); a joint that mimics nothing drives itself (1, 0), and the
        driver is None when a chain ends at a joint that is not movable. Worked out once, in linear time
        (a chain of any length; the parser has refused cycles and unknown targets)."""
        if self._drivers is not None:
            return self._drivers
        out: dict[str, tuple[str | None, float, float]] = {}
        for name in self.joints:
            chain: list[Joint] = []
            j = self.joints[name]
            while j.name not in out and j.mimic is not None:
                chain.append(j)
                j = self.joints[j.mimic.joint]
            if j.name not in out:
                out[j.name] = (j.name if j.movable else None, 1.0, 0.0)
            driver, mult, off = out[j.name]
            for c in reversed(chain):
                m = c.mimic
                driver, mult, off = driver, m.multiplier * mult, m.multiplier * off + m.offset
                out[c.name] = (driver, mult, off)
        self._drivers = out
        return out

    def movable_joints(self) -> list[Joint]:
        """Revolute, continuous and prismatic joints in document order (mimic joints included)."""
        return [j for j in self.joints.values() if j.movable]

    def actuated_joints(self) -> list[Joint]:
        """Movable joints that are not mimics: the ones a joint state sets."""
        return [j for j in self.movable_joints() if j.mimic is None]

    def chain(self, root: str, tip: str) -> list[Joint]:
        """The joints from link ``root`` down to link ``tip``; ValueError if tip is not below root."""
        path: list[Joint] = []
        link = tip
        while link != root:
            jn = self.parent_joint.get(link)
            if jn is None:
                raise ValueError(f"link {tip!r} is not below {root!r}")
            path.append(self.joints[jn])
            link = self.joints[jn].parent
        return path[::-1]

    def missing_meshes(self) -> list[tuple[str, str]]:
        """(link, filename) of every mesh whose file was not found."""
        return [(ln.name, v.geometry.filename) for ln in self.links.values() for v in ln.visuals
                if isinstance(v.geometry, Mesh) and v.geometry.path is None]

    def tree_text(self, max_indent: int = 64) -> str:
        """check_urdf's tree: the root, then each child link indented under its parent (depth first, with
        an explicit stack: a chain of any length works; the indent stops growing at ``max_indent`` levels
        and the line then says the depth). Names are escaped: they come from the file."""
        def name(s: str) -> str:
            return printable(s, 1024)

        lines = [f"root Link: {name(self.root)} has {len(self.child_joints.get(self.root, []))} child(ren)"]
        todo: list[tuple[str, int, int]] = []  # (joint, child number, depth), popped in document order
        for i, jn in reversed(list(enumerate(self.child_joints.get(self.root, []), 1))):
            todo.append((jn, i, 1))
        while todo:
            jn, i, depth = todo.pop()
            j = self.joints[jn]
            indent = "    " * min(depth, max_indent) + (f"[{depth}] " if depth > max_indent else "")
            lines.append(f"{indent}child({i}):  {name(j.child)}  ({j.type} joint '{name(j.name)}')")
            for k, cn in reversed(list(enumerate(self.child_joints.get(j.child, []), 1))):
                todo.append((cn, k, depth + 1))
        return "\n".join(lines)


URDF = Robot
