"""Live 3D view of the tf tree, markers and points in Rerun (RViz's TF, Marker and PointStamped displays).

Entity layout (what a saved ``.rrd`` holds): ``tf`` is the fixed frame's space; each frame is
``tf/<frame>`` with its pose in the fixed frame (Transform3D, TransformAxes3D and a labelled point);
``tf_links`` draws each child -> parent link; a marker ``(ns, id)`` in frame F is
``tf/<F>/markers/<ns>/<id>`` and a PointStamped on key K in frame F is ``tf/<F>/points/<K>``, so
they move with their frame. Time line ``ros_time`` follows the node clock (sim time with /clock).
Frame names are escaped into one path part (``robot1/base_link`` stays one entity).

The viewer gets a blueprint (``view_blueprint``), as RViz opens on one 3D view: a single 3D view of
the whole scene (Rerun's automatic layout drew ``/`` and ``tf`` as two copies side by side), a ground
grid, and a camera that frames the frames shown in the first seconds; after that the camera is the user's.
"""
from __future__ import annotations

import logging
import queue
import threading
import time
from typing import Any, Sequence

from ..core.messages import Marker, MarkerArray, PointStamped, PoseStamped
from ..core.ratelimit import RateLimitedLogger
from ..core.text import printable
from ..transport.node import RawSample

__all__ = ["Viewer", "frame_path", "VIEW_TYPES", "require_rerun", "view_blueprint", "pick_fixed_frame",
           "LABELS_UP_TO"]

log = logging.getLogger("zentf.tools.view")

VIEW_TYPES = {MarkerArray.TYPE_NAME: MarkerArray, Marker.TYPE_NAME: Marker, PointStamped.TYPE_NAME: PointStamped,
              PoseStamped.TYPE_NAME: PoseStamped}


def require_rerun() -> Any:
    """The rerun module, or ImportError with the one-line install hint."""
    try:
        import rerun as rr
    except ImportError:
        raise ImportError("zentf view needs Rerun: pip install 'zentf[view]' (or: pip install rerun-sdk)") from None
    return rr


#: Frame names are drawn by default up to this many frames; past it they overlap into noise (--labels).
LABELS_UP_TO = 30
#: Seconds after the first frame during which the camera is re-aimed as more frames arrive.
FRAMING_TIME = 2.0
#: Fixed frames tried in turn when none is given: RViz's usual choices, then the root of the largest tree.
FIXED_FRAME_CHOICES = ("world", "map", "odom")


def pick_fixed_frame(buffer: Any) -> str | None:
    """world, map or odom if present, else the root of the largest tree; None without frames."""
    infos = buffer.frame_info()
    frames = {i["frame"] for i in infos} | {i["parent"] for i in infos if i.get("parent")}
    for name in FIXED_FRAME_CHOICES:
        if name in frames:
            return name
    parent = {i["frame"]: i.get("parent") or "" for i in infos}
    size: dict[str, int] = {}
    for frame in frames:
        root, seen = frame, set()
        while parent.get(root) and root not in seen:  # a loop in the data must not hang the view
            seen.add(root)
            root = parent[root]
        size[root] = size.get(root, 0) + 1
    return max(sorted(size), key=lambda r: size[r]) if size else None


def view_blueprint(rrb: Any, fixed_frame: str, eye: tuple[list[float], list[float]] | None = None) -> Any:
    """One 3D view of the scene in the fixed frame with a ground grid; ``eye`` = (camera position, target)."""
    from rerun.components import Plane3D

    controls = None
    if eye is not None:
        controls = rrb.EyeControls3D(position=eye[0], look_target=eye[1], eye_up=[0.0, 0.0, 1.0])
    view = rrb.Spatial3DView(origin="/", contents=["+ /tf/**", "+ /tf_links"], name=f"3D ({fixed_frame})",
                             line_grid=rrb.LineGrid3D(visible=True, spacing=0.5, plane=Plane3D.XY,
                                                      color=[128, 128, 128, 96]),
                             eye_controls=controls)
    return rrb.Blueprint(view, collapse_panels=True, auto_views=False, auto_layout=False)


def framing_eye(points: list[list[float]]) -> tuple[list[float], list[float]]:
    """An orbit camera from the front-right, above (RViz's camera of urdf_tutorial's pictures), far enough
    back to show every point."""
    import math

    lo = [min(p[i] for p in points) for i in range(3)]
    hi = [max(p[i] for p in points) for i in range(3)]
    center = [(lo[i] + hi[i]) / 2 for i in range(3)]
    distance = 2.8 * max(0.5, 0.5 * math.dist(lo, hi))  # a sphere of that radius fits Rerun's field of view
    yaw, pitch = math.radians(315.0), math.radians(25.0)
    eye = [center[0] + distance * math.cos(pitch) * math.cos(yaw),
           center[1] + distance * math.cos(pitch) * math.sin(yaw),
           center[2] + distance * math.sin(pitch)]
    return eye, center


def frame_path(frame: str) -> str:
    import rerun as rr

    return "tf/" + rr.escape_entity_path_part(frame.lstrip("/") or "/")


def _rgba(c: Any) -> list[int]:
    def ch(v: float) -> int:
        return max(0, min(255, int(round(float(v) * 255)))) if v == v else 0

    a = c.a if c.a > 0 else 1.0  # RViz: alpha 0 is invisible; here it means "not set"
    return [ch(c.r), ch(c.g), ch(c.b), ch(a)]


class Viewer:
    """Mirrors a namespace's tf tree and visual topics into a Rerun recording stream."""

    def __init__(self, node: Any, recording: Any, *, fixed_frame: str | None = "world", axis_length: float = 0.3,
                 label_frames: bool | None = True,
                 robot_description: str | None = "robot_description", frame_prefix: str = "",
                 blueprint: bool = True,
                 tf_topics: Sequence[tuple[str | None, str]] = (("tf", "tf_static"),)) -> None:
        """``fixed_frame`` None: picked from the tree (pick_fixed_frame); ``label_frames`` None: names drawn
        while there are at most LABELS_UP_TO frames; ``blueprint``: send the one-3D-view layout."""
        import rerun as rr

        from ..transport.buffer import Buffer
        from ..transport.listener import TransformListener

        self.rr = rr
        self.node = node
        self.rec = recording
        self.fixed_frame = fixed_frame.lstrip("/") if fixed_frame else ""
        self._auto_fixed = not fixed_frame
        self.axis_length = axis_length
        self.label_frames = label_frames
        self._labelled: set[str] = set()
        self._blueprint = blueprint
        self._framing_until: float | None = None  # monotonic end of the initial camera framing
        self._framed = 0  # frames the camera was last aimed at
        self.buffer = Buffer()
        # one listener per (tf, tf_static) pair: a fleet's namespaces, or the '/**/tf' pattern
        self.listeners = [TransformListener(self.buffer, node, tf_topic=dyn or "tf", tf_static_topic=st,
                                            static_only=dyn is None) for dyn, st in tf_topics]
        self.listener = self.listeners[0]
        self._inbox: "queue.Queue[tuple[str, str, bytes]]" = queue.Queue(maxsize=10_000)
        self._profile = node.wire  # zentf's format, or ROS 2's: it reads the type each sample carries
        #: the viewed namespace, as topic names start ('/robot1/'), for the points' entity paths
        self._prefix = node.get_namespace().rstrip("/") + "/"
        # every topic of the node's namespace, filtered by the type a sample carries
        self._sub = node.create_raw_subscription("**", self._on_sample)
        self._marker_paths: dict[tuple[str, int], str] = {}
        self._shown_frames: set[str] = set()
        self.ticks = 0
        self.problems = 0
        self._warned_fixed = 0.0
        self._complain = RateLimitedLogger(log)
        self.rec.log("tf", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.robot = None
        if robot_description:  # RViz's RobotModel: the URDF from the latched topic, drawn on its frames
            from ..core.messages import String
            from .robot_view import RobotModelDisplay

            robot = self.robot = RobotModelDisplay(rr, recording, frame_prefix=frame_prefix)
            node.create_subscription(robot_description, String, lambda m: robot.set_description(m.data),
                                     latched=True)

    def _on_sample(self, sample: RawSample) -> None:  # Zenoh thread: filter by carried type, hand over
        if sample.type_name in VIEW_TYPES:
            try:
                self._inbox.put_nowait((sample.key, sample.type_name, sample.payload))
            except queue.Full:  # the view is behind: drop
                pass

    # ------------------------------------------------------------ one refresh
    def step(self) -> None:
        """Log the current tree and every visual message received since the last step."""
        now = self.node.get_clock().now()
        self.rec.set_time("ros_time", timestamp=now.nanoseconds / 1e9)
        self._log_frames()
        while True:
            try:
                key, type_name, payload = self._inbox.get_nowait()
            except queue.Empty:
                break
            try:
                msg = self._profile.decode(payload, "", key, VIEW_TYPES[type_name])
                self._log_message(key, msg)
            except Exception as e:  # noqa: BLE001 - one bad message must not stop the view
                self.problems += 1
                self._complain.log(logging.WARNING, ("bad", key), "dropped bad %s on '%s': %s", type_name, key, e)
        if self.robot is not None:
            self.robot.draw(self._shown_frames, frame_path)
        self.ticks += 1

    def _log_frames(self) -> None:
        from ..core.exceptions import TransformException

        rr = self.rr
        frames = self.buffer.get_frames()
        if not frames:
            return
        if self._auto_fixed and self.fixed_frame not in frames:
            picked = pick_fixed_frame(self.buffer)
            if picked and picked != self.fixed_frame:
                self.fixed_frame = picked
                log.info("fixed frame: %s (--fixed-frame to choose another)", printable(picked))
                self._framing_until, self._framed = None, 0
        if self.fixed_frame not in frames:
            if time.monotonic() - self._warned_fixed > 5.0:
                self._warned_fixed = time.monotonic()
                log.warning("fixed frame '%s' is not in the tf tree (frames: %s)", printable(self.fixed_frame),
                            printable(", ".join(sorted(frames)), 2000))
            return
        origins: dict[str, list[float]] = {}
        for frame in frames:
            path = frame_path(frame)
            try:
                ts = self.buffer.lookup_transform(self.fixed_frame, frame, 0)
            except TransformException:
                if frame in self._shown_frames:  # gone from the tree (buffer cleared, link lost): hide it
                    self._shown_frames.discard(frame)
                    self.rec.log(path, rr.Clear(recursive=False))
                continue  # not connected to the fixed frame (yet)
            p, q = ts.transform.translation, ts.transform.rotation
            origins[frame] = [p.x, p.y, p.z]
            parts = [rr.Transform3D(translation=[p.x, p.y, p.z], quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w])),
                     rr.TransformAxes3D(self.axis_length)]
            self._shown_frames.add(frame)
            self.rec.log(path, *parts)
        self._update_labels(origins)
        self._frame_camera(origins)
        links = []
        for info in self.buffer.frame_info():
            a, b = origins.get(info["frame"]), origins.get(info["parent"])
            if a is not None and b is not None:
                links.append([b, a])
        if links:
            self.rec.log("tf_links", rr.LineStrips3D(links, radii=0.003, colors=[[200, 200, 80, 160]]))

    def _update_labels(self, origins: dict[str, list[float]]) -> None:
        """Frame names as labels: always, never, or (auto) while at most LABELS_UP_TO frames are shown."""
        rr = self.rr
        on = self.label_frames if self.label_frames is not None else len(origins) <= LABELS_UP_TO
        want = set(origins) if on else set()
        for frame in sorted(want - self._labelled):
            self.rec.log(frame_path(frame), rr.Points3D([[0.0, 0.0, 0.0]], radii=0.01, labels=[frame],
                                                        show_labels=True, colors=[[230, 230, 230]]))
        for frame in sorted(self._labelled - want):
            self.rec.log(frame_path(frame), rr.Points3D.from_fields(clear_unset=True))
        self._labelled = want

    def _frame_camera(self, origins: dict[str, list[float]]) -> None:
        """The first seconds: aim the camera at every frame shown, as more of the robot arrives."""
        if not self._blueprint or not origins:
            return
        now = time.monotonic()
        if self._framing_until is None:
            self._framing_until = now + FRAMING_TIME
        if now > self._framing_until or len(origins) <= self._framed:
            return
        self._framed = len(origins)
        import rerun.blueprint as rrb

        self.rec.send_blueprint(view_blueprint(rrb, self.fixed_frame, framing_eye(list(origins.values()))))

    def send_blueprint(self) -> None:
        """The layout before any data: one 3D view with a ground grid (the camera is aimed once frames show)."""
        import rerun.blueprint as rrb

        self.rec.send_blueprint(view_blueprint(rrb, self.fixed_frame or "auto"))

    def _log_message(self, key: str, msg: Any) -> None:
        rr = self.rr
        if isinstance(msg, MarkerArray):
            for m in msg.markers:
                self._log_marker(m)
        elif isinstance(msg, Marker):
            self._log_marker(msg)
        elif isinstance(msg, PointStamped):
            p = msg.point
            self.rec.log(f"{frame_path(msg.header.frame_id)}/points/{rr.escape_entity_path_part(self._topic(key))}",
                         rr.Points3D([[p.x, p.y, p.z]], radii=0.03, colors=[[255, 160, 0]]))
        elif isinstance(msg, PoseStamped):
            p, q = msg.pose.position, msg.pose.orientation
            self.rec.log(f"{frame_path(msg.header.frame_id)}/poses/{rr.escape_entity_path_part(self._topic(key))}",
                         rr.Transform3D(translation=[p.x, p.y, p.z], quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w])),
                         rr.TransformAxes3D(self.axis_length * 0.5))

    def _topic(self, key: str) -> str:
        """A sample's topic shown relative to the viewed namespace ('/ns/laser_point' -> 'laser_point')."""
        topic = self._profile.topic_of_key(key)[0]
        return topic[len(self._prefix):] if topic.startswith(self._prefix) else topic.lstrip("/")

    def _log_marker(self, m: Marker) -> None:
        rr = self.rr
        ident = (m.ns, m.id)
        if m.action == Marker.DELETEALL:
            for path in self._marker_paths.values():
                self.rec.log(path, rr.Clear(recursive=True))
            self._marker_paths.clear()
            return
        if m.action == Marker.DELETE:
            path = self._marker_paths.pop(ident, None)
            if path is not None:
                self.rec.log(path, rr.Clear(recursive=True))
            return
        ns_part = rr.escape_entity_path_part(m.ns or "_")
        path = f"{frame_path(m.header.frame_id)}/markers/{ns_part}/{m.id}"
        old = self._marker_paths.get(ident)
        if old is not None and old != path:  # the marker changed frame
            self.rec.log(old, rr.Clear(recursive=True))
        self._marker_paths[ident] = path
        p, q = m.pose.position, m.pose.orientation
        pose = rr.Transform3D(translation=[p.x, p.y, p.z],
                              quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w] if (q.x, q.y, q.z, q.w) != (0, 0, 0, 0)
                                                       else [0, 0, 0, 1]))
        color = _rgba(m.color)
        colors = [_rgba(c) for c in m.colors] if len(m.colors) == len(m.points) and m.colors else [color]
        pts = [[pt.x, pt.y, pt.z] for pt in m.points]
        s = m.scale
        t = m.type
        if t == Marker.LINE_STRIP:
            arch = rr.LineStrips3D([pts], radii=max(s.x, 1e-3) / 2, colors=[color], labels=[m.text] if m.text else None)
        elif t == Marker.LINE_LIST:
            arch = rr.LineStrips3D([pts[i:i + 2] for i in range(0, len(pts) - 1, 2)], radii=max(s.x, 1e-3) / 2,
                                   colors=[color])
        elif t in (Marker.POINTS, Marker.SPHERE_LIST, Marker.CUBE_LIST):
            arch = rr.Points3D(pts, radii=max(s.x, 1e-3) / 2, colors=colors)
        elif t == Marker.SPHERE or t == Marker.CYLINDER:
            arch = rr.Ellipsoids3D(half_sizes=[[s.x / 2, s.y / 2, s.z / 2]], colors=[color], fill_mode="solid")
        elif t == Marker.CUBE:
            arch = rr.Boxes3D(half_sizes=[[s.x / 2, s.y / 2, s.z / 2]], colors=[color], fill_mode="solid")
        elif t == Marker.ARROW:
            if len(pts) >= 2:
                a, b = pts[0], pts[1]
                arch = rr.Arrows3D(origins=[a], vectors=[[b[i] - a[i] for i in range(3)]], colors=[color])
            else:
                arch = rr.Arrows3D(origins=[[0, 0, 0]], vectors=[[max(s.x, 1e-3), 0, 0]], colors=[color])
        elif t == Marker.TEXT_VIEW_FACING:
            arch = rr.Points3D([[0, 0, 0]], radii=1e-3, labels=[m.text], colors=[color], show_labels=True)
        else:
            return
        self.rec.log(path, pose, arch)

    # ------------------------------------------------------------ loop
    def run(self, stop: threading.Event, rate: float = 20.0, duration: float | None = None) -> None:
        period = 1.0 / rate
        end = None if duration is None else time.monotonic() + duration
        while not stop.is_set() and self.node.ok():
            started = time.monotonic()
            self.step()
            if end is not None and started >= end:
                break
            stop.wait(max(0.0, period - (time.monotonic() - started)))

    def close(self) -> None:
        self._sub.destroy()
        for lis in self.listeners:
            lis.unregister()
