"""URDF text -> checked ``Robot``, with the stdlib's expat; every refusal names element and file:line.

Checks (urdfdom's, plus the tree ones robot_state_publisher relies on): required attributes, numbers
(finite, right count), known joint types, limits on revolute/prismatic joints, unique names, joints
whose parent/child links exist, a child that is not its own parent, one parent per link, exactly one
root, no loops, mimic targets that exist (and no mimic cycles), named materials that are defined.
``.xacro`` files are expanded by zentf's own xacro (``zentf.urdf.xacro``): in a confined child process,
with a restricted expression evaluator and a CPU/memory budget; a model file is data, never code.
"""
from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping
from pathlib import Path

from ..core.text import printable
from .errors import URDFError
from .model import (JOINT_TYPES, Box, Cylinder, Joint, JointLimit, JointMimic, Link, Material, Mesh,
                    Pose, Robot, Sphere, Visual)
from .resolve import resolve_uri, search_path
from .xacro.budget import DEFAULT_BUDGET, Budget, parse_budget
from .xacro.errors import XacroError
from .xacro.process import expand_file
from .xmltree import XElement, no_gc, parse_xml

__all__ = ["parse_urdf", "load_urdf", "read_urdf_text"]

log = logging.getLogger("zentf.urdf")


class _Ctx:
    """Where we are: the file name for error messages; the number texts already read."""

    def __init__(self, source: str | None) -> None:
        self.source = source
        #: text -> its finite numbers: models repeat "0 0 0" and "0 0 1" thousands of times (bounded in entries,
        #: and its keys are strings the document holds anyway)
        self.numbers: dict[str, tuple[float, ...]] = {}
        #: frozen values built from those numbers, shared the same way (same bound)
        self.shared: dict[tuple, object] = {}

    def error(self, message: str, el: XElement | None, element: str | None = None) -> URDFError:
        return URDFError(message, element=element if element is not None else (_describe(el) if el else None),
                         file=self.source, line=el.line if el is not None else None)


def _describe(el: XElement) -> str:
    name = el.get("name")
    return f"<{el.tag} name='{name}'>" if name is not None else f"<{el.tag}>"


def _req(ctx: _Ctx, el: XElement, attr: str, owner: XElement | None = None) -> str:
    v = el.get(attr)
    if v is None:
        where = _describe(owner) + " " if owner is not None and owner is not el else ""
        raise ctx.error(f"missing required attribute '{attr}'", el, f"{where}{_describe(el)}")
    return v


_NUMBERS_KEPT = 4096


def _floats(ctx: _Ctx, el: XElement, attr: str, n: int, default: tuple | None, owner: XElement | None = None
            ) -> tuple[float, ...]:
    text = el.attrib.get(attr)
    if text is None:
        if default is None:
            raise ctx.error(f"missing required attribute '{attr}'", el, _where(el, owner))
        return default
    values = ctx.numbers.get(text)
    if values is None:
        try:
            values = tuple(map(float, text.split()))
        except ValueError:
            raise ctx.error(f"bad number in {attr}=\"{text}\"", el, _where(el, owner)) from None
        if not all(map(math.isfinite, values)):
            if len(values) != n:
                raise ctx.error(f"{attr}=\"{text}\" needs {n} number{'s' if n > 1 else ''}, got {len(values)}", el,
                                _where(el, owner))
            raise ctx.error(f"{attr}=\"{text}\" must be finite numbers", el, _where(el, owner))
        if len(ctx.numbers) < _NUMBERS_KEPT:
            ctx.numbers[text] = values
    if len(values) != n:
        raise ctx.error(f"{attr}=\"{text}\" needs {n} number{'s' if n > 1 else ''}, got {len(values)}", el,
                        _where(el, owner))
    return values


def _where(el: XElement, owner: XElement | None) -> str:
    """The element a refused number is in (worked out only when refusing: a model has hundreds of thousands)."""
    return (_describe(owner) + " " if owner is not None and owner is not el else "") + _describe(el)


def _float(ctx: _Ctx, el: XElement, attr: str, default: float | None, owner: XElement | None = None) -> float:
    return _floats(ctx, el, attr, 1, None if default is None else (default,), owner)[0]


_ZERO3 = (0.0, 0.0, 0.0)
_IDENTITY = Pose()


def _origin(ctx: _Ctx, parent: XElement) -> Pose:
    o = parent.find("origin")
    if o is None:
        return _IDENTITY
    key = (_floats(ctx, o, "xyz", 3, _ZERO3, parent), _floats(ctx, o, "rpy", 3, _ZERO3, parent))
    return _shared(ctx, key, Pose)  # type: ignore[return-value]


def _shared(ctx: _Ctx, key: tuple, make, args: tuple | None = None) -> object:
    """``make(*args)`` (args: the key's own values by default), one object per distinct key (the objects are
    frozen)."""
    got = ctx.shared.get(key)
    if got is None:
        got = make(*(key if args is None else args))
        if len(ctx.shared) < _NUMBERS_KEPT:
            ctx.shared[key] = got
    return got


def _material(ctx: _Ctx, el: XElement, owner: XElement | None) -> Material:
    name = el.get("name", "") or ""
    color = None
    texture = None
    c = el.find("color")
    if c is not None:
        rgba = _floats(ctx, c, "rgba", 4, None, owner or el)
        color = (rgba[0], rgba[1], rgba[2], rgba[3])
    t = el.find("texture")
    if t is not None:
        texture = t.get("filename")
    return Material(name, color, texture)


def _geometry(ctx: _Ctx, visual: XElement, link: XElement, dirs: list[str], base_dir: str | None):
    g = visual.find("geometry")
    if g is None:
        raise ctx.error("visual without <geometry>", visual, f"{_describe(link)} <visual>")
    shapes = [c for c in g.children]
    if not shapes:
        raise ctx.error("empty <geometry>", g, f"{_describe(link)} <geometry>")
    s = shapes[0]
    if s.tag == "box":
        return Box(_floats(ctx, s, "size", 3, None, link))  # type: ignore[arg-type]
    if s.tag == "cylinder":
        return Cylinder(_float(ctx, s, "radius", None, link), _float(ctx, s, "length", None, link))
    if s.tag == "sphere":
        return Sphere(_float(ctx, s, "radius", None, link))
    if s.tag == "mesh":
        filename = _req(ctx, s, "filename", link)
        scale = _floats(ctx, s, "scale", 3, (1.0, 1.0, 1.0), link)
        return Mesh(filename, scale, resolve_uri(filename, dirs, base_dir))  # type: ignore[arg-type]
    raise ctx.error(f"unknown geometry <{s.tag}> (box, cylinder, sphere or mesh)", s, f"{_describe(link)} <{s.tag}>")


def parse_urdf(text: str | bytes, *, source: str | None = None, package_path: list[str] | None = None) -> Robot:
    """Parse and check URDF text; URDFError (one line) says what is wrong where."""
    with no_gc():  # the model is acyclic: see no_gc
        return _parse(text, source, package_path)


def _parse(text: str | bytes, source: str | None, package_path: list[str] | None) -> Robot:
    ctx = _Ctx(source)
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    root_el = parse_xml(text, source)
    if root_el.tag != "robot":
        raise ctx.error(f"the root element is <{root_el.tag}>, expected <robot>", root_el)
    robot = Robot(name=_req(ctx, root_el, "name"), source=source, xml=text)
    dirs = search_path(package_path, source)
    base_dir = str(Path(source).resolve().parent) if source else None

    top: dict[str, list[XElement]] = {"material": [], "link": [], "joint": []}
    for el in root_el.children:  # one pass over what can be hundreds of thousands of elements
        group = top.get(el.tag)
        if group is not None:
            group.append(el)

    for m in top["material"]:
        mat = _material(ctx, m, None)
        if not mat.name:
            raise ctx.error("missing required attribute 'name'", m)
        robot.materials[mat.name] = mat

    link_els: dict[str, XElement] = {}
    for el in top["link"]:
        name = _req(ctx, el, "name")
        if name in robot.links:
            raise ctx.error(f"duplicate link name (first at line {link_els[name].line})", el)
        link = Link(name, line=el.line)
        for v in el.findall("visual"):
            geometry = _geometry(ctx, v, el, dirs, base_dir)
            material = None
            m = v.find("material")
            if m is not None:
                material = _material(ctx, m, el)
                if material.color is None and material.texture is None:
                    known = robot.materials.get(material.name)
                    if known is None:
                        raise ctx.error(f"material '{material.name}' is not defined", m, f"{_describe(el)} <material>")
                    material = known
            link.visuals.append(Visual(geometry, _origin(ctx, v), material, v.get("name")))
        robot.links[name] = link
        link_els[name] = el
    if not robot.links:
        raise ctx.error("no <link> elements", root_el)

    joint_els: dict[str, XElement] = {}
    for el in top["joint"]:
        name = _req(ctx, el, "name")
        if name in robot.joints:
            raise ctx.error(f"duplicate joint name (first at line {joint_els[name].line})", el)
        jtype = _req(ctx, el, "type")
        if jtype not in JOINT_TYPES:
            raise ctx.error(f"unknown joint type '{jtype}' ({', '.join(JOINT_TYPES)})", el)
        pe, ce = el.find("parent"), el.find("child")
        if pe is None:
            raise ctx.error("missing <parent link=...>", el)
        if ce is None:
            raise ctx.error("missing <child link=...>", el)
        parent, child = _req(ctx, pe, "link", el), _req(ctx, ce, "link", el)
        axis = (1.0, 0.0, 0.0)
        a = el.find("axis")
        if a is not None:
            axis = _floats(ctx, a, "xyz", 3, (1.0, 0.0, 0.0), el)
        if jtype in ("revolute", "continuous", "prismatic", "planar"):
            axis = _shared(ctx, ("axis", axis), _unit_axis, (ctx, axis, a or el))  # type: ignore[assignment]
        limit = None
        le = el.find("limit")
        if le is not None:
            limit = _shared(ctx, (_float(ctx, le, "lower", 0.0, el), _float(ctx, le, "upper", 0.0, el),
                                  _float(ctx, le, "effort", None, el), _float(ctx, le, "velocity", None, el)),
                            JointLimit)
        elif jtype in ("revolute", "prismatic"):
            raise ctx.error(f"a {jtype} joint needs <limit> (lower, upper, effort, velocity)", el)
        mimic = None
        me = el.find("mimic")
        if me is not None:
            mimic = JointMimic(_req(ctx, me, "joint", el), _float(ctx, me, "multiplier", 1.0, el),
                               _float(ctx, me, "offset", 0.0, el))
        robot.joints[name] = Joint(name, jtype, parent, child, _origin(ctx, el), axis, limit, mimic, el.line)  # type: ignore[arg-type]
        joint_els[name] = el

    # ---- the tree
    for name, j in robot.joints.items():
        el = joint_els[name]
        if j.parent not in robot.links:
            raise ctx.error(f"unknown parent link '{j.parent}'", el)
        if j.child not in robot.links:
            raise ctx.error(f"unknown child link '{j.child}'", el)
        if j.parent == j.child:
            raise ctx.error(f"parent and child are the same link '{j.child}'", el)
        first = robot.parent_joint.get(j.child)
        if first is not None:
            raise ctx.error(f"link '{j.child}' has two parents: '{robot.joints[first].parent}' (joint '{first}', "
                            f"line {robot.joints[first].line}) and '{j.parent}'", el)
        robot.parent_joint[j.child] = name
        robot.child_joints.setdefault(j.parent, []).append(name)
    roots = [n for n in robot.links if n not in robot.parent_joint]
    if not roots:
        j = robot.joints[next(iter(robot.joints))]
        raise ctx.error("the joints form a loop: every link has a parent, so there is no root link",
                        joint_els[j.name])
    if len(roots) > 1:
        raise ctx.error(f"more than one root link: {', '.join(repr(r) for r in roots[:5])} "
                        "(every link but one needs a parent joint)", link_els[roots[1]])
    robot.root = roots[0]
    reached = {robot.root}
    todo = [robot.root]
    while todo:
        for jn in robot.child_joints.get(todo.pop(), []):
            c = robot.joints[jn].child
            reached.add(c)
            todo.append(c)
    if len(reached) != len(robot.links):
        stray = next(j for j in robot.joints.values() if j.child not in reached)
        raise ctx.error(f"the joints form a loop through link '{stray.child}' (not reachable from root "
                        f"'{robot.root}')", joint_els[stray.name])
    _check_mimics(ctx, robot, joint_els)
    return robot


def _unit_axis(ctx: _Ctx, axis: tuple[float, ...], el: XElement) -> tuple[float, float, float]:
    """The axis scaled to length 1 without overflow (divided by its largest component first: 1e200 1e200 0
    is a fine direction); a zero axis is refused."""
    big = max(abs(c) for c in axis)
    if big == 0.0:
        raise ctx.error(f"the axis xyz=\"{' '.join(f'{c:g}' for c in axis)}\" is zero", el)
    scaled = [c / big for c in axis]
    norm = math.hypot(*scaled)  # between 1 and sqrt(3)
    unit = (scaled[0] / norm, scaled[1] / norm, scaled[2] / norm)
    if not all(math.isfinite(c) for c in unit) or abs(math.hypot(*unit) - 1.0) > 1e-9:
        raise ctx.error(f"the axis xyz=\"{' '.join(f'{c:g}' for c in axis)}\" has no usable direction", el)
    return unit


def _check_mimics(ctx: _Ctx, robot: Robot, joint_els: dict[str, XElement]) -> None:
    """Mimic targets exist and form no cycle (linear time, no recursion), and every mimic joint's position
    stays finite over its driver's range (the limits; continuous joints: +-pi), mimic chains composed."""
    state: dict[str, int] = {}  # 1: on the chain being followed, 2: checked
    for name, j in robot.joints.items():
        if j.mimic is None or name in state:
            continue
        path: list[str] = []
        cur = name
        while state.get(cur) != 2:
            if state.get(cur) == 1:
                raise ctx.error(f"mimic joints form a cycle through '{cur}'", joint_els[name])
            joint = robot.joints[cur]
            if joint.mimic is None:
                break
            state[cur] = 1
            path.append(cur)
            target = robot.joints.get(joint.mimic.joint)
            if target is None:
                raise ctx.error(f"mimics unknown joint '{joint.mimic.joint}'", joint_els[cur])
            cur = target.name
        for p in path:
            state[p] = 2
    drivers = robot.mimic_drivers()
    for name, j in robot.joints.items():
        if j.mimic is None or not j.movable:
            continue
        driver, mult, off = drivers[name]
        lo, hi = robot.joints[driver].bounds() if driver is not None else (0.0, 0.0)
        ends = (mult * lo + off, mult * hi + off) if driver is not None else (off, off)
        if not (math.isfinite(mult) and math.isfinite(off) and all(math.isfinite(v) for v in ends)):
            raise ctx.error(f"mimic multiplier {j.mimic.multiplier:g} and offset {j.mimic.offset:g} take the "
                            f"position out of the finite range (over '{driver}' in [{lo:g}, {hi:g}])",
                            joint_els[name])


def _budget(budget: "Budget | str | None") -> Budget:
    if budget is None:
        return DEFAULT_BUDGET
    if isinstance(budget, Budget):
        return budget
    try:
        return parse_budget(str(budget))
    except ValueError as e:
        raise URDFError(str(e)) from None


def read_urdf_text(path: str, xacro_args: dict[str, str] | None = None, *, package_path: list[str] | None = None,
                   xacro_budget: "Budget | str | None" = None, xacro_env: Mapping[str, str] | None = None) -> str:
    """A URDF file's text; a .xacro file is expanded first, by zentf's confined xacro (see docs/urdf.md):
    files are data, never code; ``package_path`` is where ``$(find PKG)`` looks, ``xacro_env`` the only
    environment the model sees, ``xacro_budget`` its CPU and memory (``"30s,2GB"``)."""
    p = Path(path)
    if p.suffix == ".xacro":
        budget = _budget(xacro_budget)
        try:
            result = expand_file(str(p), args=dict(xacro_args or {}), package_path=list(package_path or []),
                                 env=dict(xacro_env or {}), budget=budget)
        except XacroError as e:
            msg = e.message if e.message.startswith("xacro") else f"xacro: {e.message}"
            raise URDFError(msg, file=e.file or path, line=e.line) from None
        for w in result.warnings[:20]:
            log.warning("%s: xacro: %s", printable(path), printable(w, 400))
        if not result.confined.get("landlock"):
            log.debug("%s: expanded without Landlock (kernel without it): rlimits and zentf's evaluator only", path)
        return result.urdf
    try:
        return p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise URDFError("no such file", file=path) from None
    except (OSError, UnicodeDecodeError) as e:
        raise URDFError(f"cannot read: {getattr(e, 'strerror', None) or e}", file=path) from None


def load_urdf(path: str | os.PathLike, *, package_path: list[str] | None = None,
              xacro_args: dict[str, str] | None = None, xacro_budget: "Budget | str | None" = None,
              xacro_env: Mapping[str, str] | None = None) -> Robot:
    """Read and parse a .urdf (or .xacro) file."""
    path = os.fspath(path)
    text = read_urdf_text(path, xacro_args, package_path=package_path, xacro_budget=xacro_budget, xacro_env=xacro_env)
    return parse_urdf(text, source=path, package_path=package_path)
