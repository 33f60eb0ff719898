"""RViz's RobotModel display for ``zentf view``: every link's visuals, posed by their tf frame.

The model comes from the latched ``robot_description`` topic (the URDF text robot_state_publisher
publishes). Each visual is logged once, as ``tf/<frame>/robot/<i>`` (a child of the frame entity, so it
moves with the frame): its origin as a Transform3D (with a mesh's scale), then a box, cylinder,
sphere, or mesh. .stl/.obj/.glb/.gltf meshes are Rerun assets; .dae (Collada) meshes are read with
trimesh + pycollada when installed (``zentf[view]``); a mesh that cannot be found or read is drawn as a
small grey placeholder cube and named once in the log.
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from ..urdf import Box, Cylinder, Mesh, Robot, Sphere, URDFError, Visual, parse_urdf

__all__ = ["RobotModelDisplay", "DEFAULT_COLOR"]

log = logging.getLogger("zentf.tools.view.robot")

#: RViz draws visuals without a material in this light grey.
DEFAULT_COLOR = (0.8, 0.8, 0.8, 1.0)
_ASSETS = {".stl": "model/stl", ".obj": "model/obj", ".glb": "model/gltf-binary", ".gltf": "model/gltf+json"}
_PLACEHOLDER = 0.03  # half size of the cube drawn for a mesh that cannot be shown


def _rgba(c: tuple[float, float, float, float]) -> list[int]:
    return [max(0, min(255, int(round(v * 255)))) for v in c]


class RobotModelDisplay:
    """Draws a robot model's visuals under the frames the viewer shows (frame = prefix + link)."""

    def __init__(self, rr: Any, recording: Any, *, frame_prefix: str = "") -> None:
        self.rr = rr
        self.rec = recording
        self.frame_prefix = frame_prefix
        self.robot: Robot | None = None
        self._pending: str | None = None
        self._drawn: set[str] = set()
        self._entities: list[str] = []
        self.problems: list[str] = []   # one line per mesh drawn as a placeholder (said once)

    def set_description(self, text: str) -> None:
        """A new robot_description text (any thread); applied on the next ``draw``."""
        self._pending = text

    def _load(self, text: str) -> None:
        try:
            robot = parse_urdf(text, source="robot_description")
        except URDFError as e:
            log.warning("cannot draw the robot: %s", e)
            return
        for path in self._entities:  # a new model replaces the old one (its visuals were logged static)
            self.rec.log(path, self.rr.Clear(recursive=True), static=True)
        self._entities.clear()
        self._drawn.clear()
        self.robot = robot
        log.info("drawing robot '%s' (%d links)", robot.name, len(robot.links))

    def draw(self, shown_frames: set[str], frame_path: Any) -> None:
        """Log the visuals of every link whose frame is shown and was not drawn yet."""
        text, self._pending = self._pending, None
        if text is not None:
            self._load(text)
        robot = self.robot
        if robot is None:
            return
        for link in robot.links.values():
            frame = self.frame_prefix + link.name
            if frame in self._drawn or frame not in shown_frames:
                continue
            self._drawn.add(frame)
            for i, visual in enumerate(link.visuals):
                path = f"{frame_path(frame)}/robot/{i}"
                self._entities.append(path)
                try:
                    self._log_visual(path, link.name, visual)
                except Exception as e:  # noqa: BLE001 - one bad visual must not stop the view
                    self._say_once(f"link '{link.name}': visual {i} not drawn ({type(e).__name__}: {e})")

    def _say_once(self, line: str) -> None:
        if line not in self.problems:
            self.problems.append(line)
            log.warning("%s", line)

    def _color(self, visual: Visual) -> list[int]:
        m = visual.material
        return _rgba(m.color if m is not None and m.color is not None else DEFAULT_COLOR)

    def _log_visual(self, path: str, link: str, visual: Visual) -> None:
        rr = self.rr
        g = visual.geometry
        o = visual.origin
        qx, qy, qz, qw = o.quaternion()
        scale = g.scale if isinstance(g, Mesh) else None
        pose = rr.Transform3D(translation=list(o.xyz), quaternion=rr.Quaternion(xyzw=[qx, qy, qz, qw]),
                              scale=list(scale) if scale is not None and scale != (1.0, 1.0, 1.0) else None)
        color = self._color(visual)
        if isinstance(g, Box):
            arch = rr.Boxes3D(half_sizes=[[s / 2 for s in g.size]], colors=[color], fill_mode="solid")
        elif isinstance(g, Cylinder):
            arch = rr.Cylinders3D(lengths=[g.length], radii=[g.radius], colors=[color], fill_mode="solid")
        elif isinstance(g, Sphere):
            arch = rr.Ellipsoids3D(radii=[g.radius], colors=[color], fill_mode="solid")
        else:
            arch = self._mesh(link, g, visual)
        self.rec.log(path, pose, arch, static=True)

    def _mesh(self, link: str, g: Mesh, visual: Visual) -> Any:
        rr = self.rr
        if g.path is None:
            self._say_once(f"link '{link}': mesh {g.filename} not found (drawn as a placeholder; "
                           f"set ZENTF_PACKAGE_PATH)")
            return self._placeholder()
        suffix = Path(g.path).suffix.lower()
        if suffix in _ASSETS:
            return rr.Asset3D(path=g.path, media_type=_ASSETS[suffix],
                              albedo_factor=self._color(visual) if visual.material is not None else None)
        if suffix == ".dae":
            mesh = _collada(rr, g.path)
            if mesh is not None:
                return mesh
            self._say_once(f"link '{link}': {g.filename} is Collada and trimesh + pycollada are not installed "
                           f"(pip install 'zentf[view]'); drawn as a placeholder")
        else:
            self._say_once(f"link '{link}': mesh format {suffix or '?'} is not supported; drawn as a placeholder")
        return self._placeholder()

    def _placeholder(self) -> Any:
        return self.rr.Boxes3D(half_sizes=[[_PLACEHOLDER] * 3], colors=[[128, 128, 128, 160]])


def _collada(rr: Any, path: str) -> Any:
    """A Collada file as a Rerun Mesh3D (texture or colour kept), or None without trimesh."""
    try:
        import trimesh
    except ImportError:
        return None
    logging.getLogger("trimesh").setLevel(logging.CRITICAL)  # missing bump maps etc. are not our problem
    mesh = trimesh.load(path, force="mesh")
    kw: dict[str, Any] = {"vertex_positions": mesh.vertices, "triangle_indices": mesh.faces,
                          "vertex_normals": mesh.vertex_normals}
    visual = mesh.visual
    try:
        if visual.kind == "texture" and getattr(visual, "uv", None) is not None:
            image = getattr(visual.material, "image", None) or getattr(visual.material, "baseColorTexture", None)
            if image is not None:
                import numpy as np

                kw["vertex_texcoords"] = visual.uv
                kw["albedo_texture"] = np.asarray(image.convert("RGB"))
        elif visual.kind in ("vertex", "face"):
            kw["vertex_colors"] = visual.to_color().vertex_colors
    except Exception:  # noqa: BLE001 - fall back to the plain mesh
        kw = {k: v for k, v in kw.items() if k in ("vertex_positions", "triangle_indices", "vertex_normals")}
    return rr.Mesh3D(**kw)
