"""robot_state_publisher: a URDF model plus ``joint_states`` -> ``tf`` and ``tf_static``.

ROS 2 semantics (robot_state_publisher 3.x): fixed joints (and floating/planar ones, which KDL
treats as fixed) go once on ``tf_static``, latched, stamped at start; each JointState publishes its
movable joints on ``tf`` stamped with the JointState's own stamp, unless every joint in it was
published less than ``1/publish_frequency`` ago (by stamp; ``ignore_timestamp`` turns that off).
Mimic joints follow their master. ``frame_prefix`` is prepended to every frame id as is (ROS 2;
ROS 1 used tf_prefix with a '/'). The URDF text is published latched on ``robot_description``
(std_msgs/String). Joint states are decoded and turned into one TFMessage in Zenoh's callback
thread (no executor hop), vectorized over the joints with numpy.
"""
from __future__ import annotations

import logging
import struct
import threading
from typing import Any

import msgpack
import numpy as np

from .. import wire
from ..broadcaster import StaticTransformBroadcaster
from ..core.messages import (Header, JointState, Quaternion, String, TFMessage, Transform, TransformStamped,
                             Vector3)
from ..names import topic_to_key
from ..node import Node, RateLimitedLog
from ..urdf import Kinematics, Robot
from ..urdf.kinematics import JointTransforms

__all__ = ["RobotStatePublisher"]

log = logging.getLogger("zentf.robot_state_publisher")
_NS = 1_000_000_000
_MAX_SEC = 2**32


def _joint_state_decoder() -> Any:
    """msgspec decoder of a JointState's plain-dict wire form (strict types; None without msgspec)."""
    try:
        import msgspec
    except ImportError:  # pragma: no cover - msgspec is a dependency
        return None

    def struct_(name: str, fields: list) -> Any:
        return msgspec.defstruct(name, fields, gc=False)

    stamp = struct_("Time", [("sec", int), ("nanosec", int)])
    header = struct_("Header", [("stamp", stamp), ("frame_id", str)])
    return msgspec.msgpack.Decoder(struct_("JointState", [
        ("header", header), ("name", list[str]), ("position", list[float]),
        ("velocity", list[float], []), ("effort", list[float], [])]))


class _TFEncoder:
    """TFMessage bytes for the movable joints, from per-joint byte templates (same map as wire.encode_tf)."""

    _VALUES = struct.Struct(">d3sd3sd13sd3sd3sd3sd")

    def __init__(self, parents: list[str], children: list[str]) -> None:
        p = msgpack.packb
        self._head = b"\x83" + p("header") + b"\x82" + p("stamp") + b"\x82" + p("sec") + b"\xce"
        self._frames = [b"".join((p("frame_id"), p(par), p("child_frame_id"), p(ch), p("transform"), b"\x82",
                                  p("translation"), b"\x83", p("x"), b"\xcb"))
                        for par, ch in zip(parents, children)]

    def encode(self, sec: int, nsec: int, idx: list[int], t: np.ndarray, q: np.ndarray) -> bytes:
        stamp = b"".join((self._head, sec.to_bytes(4, "big"), b"\xa7nanosec\xce", nsec.to_bytes(4, "big")))
        pack = self._VALUES.pack
        frames = self._frames
        y, z, w, rot = b"\xa1y\xcb", b"\xa1z\xcb", b"\xa1w\xcb", b"\xa8rotation\x84\xa1x\xcb"
        items = [b"".join((stamp, frames[j], pack(tx, y, ty, z, tz, rot, qx, y, qy, z, qz, w, qw)))
                 for j, (tx, ty, tz), (qx, qy, qz, qw) in zip(idx, t.tolist(), q.tolist())]
        n = len(items)
        head = (b"\x81\xaatransforms" + (bytes((0x90 | n,)) if n < 16 else b"\xdc" + n.to_bytes(2, "big")))
        return head + b"".join(items)


class RobotStatePublisher:
    """Publishes a robot's frames from its model and its joint states (see the module doc)."""

    def __init__(self, node: Node, robot: Robot, *, frame_prefix: str = "", publish_frequency: float = 20.0,
                 ignore_timestamp: bool = False, joint_states_topic: str = "joint_states") -> None:
        if not publish_frequency > 0:
            raise ValueError(f"publish_frequency must be > 0, got {publish_frequency!r}")
        self.node = node
        self.robot = robot
        self.frame_prefix = frame_prefix
        self.publish_interval_ns = int(round(1e9 / publish_frequency))
        self.ignore_timestamp = ignore_timestamp
        self.kin = Kinematics(robot)
        self._log = RateLimitedLog(log)
        self._lock = threading.Lock()
        self.received = 0     # joint state messages
        self.published = 0    # TFMessages sent on tf
        self.ignored = 0      # invalid or throttled joint states
        movable = robot.movable_joints()
        self._movable = JointTransforms(robot, movable)
        self._index = {j.name: i for i, j in enumerate(movable)}
        # mimic joints: (their index, the actuated master's name, multiplier, offset)
        self._mimics: list[tuple[int, str, float, float]] = []
        for i, j in enumerate(movable):
            if j.mimic is not None:
                src, mult, off = self.kin._source(j)
                if src >= 0:
                    self._mimics.append((i, self.kin.joint_names[src], mult, off))
        self._encoder = _TFEncoder([frame_prefix + p for p in self._movable.parents],
                                   [frame_prefix + c for c in self._movable.children])
        self._last_publish: dict[str, int] = {}
        self._decoder = _joint_state_decoder()

        self._description = node.create_publisher("robot_description", String, latched=True)
        self._description.publish(String(robot.xml))
        self._static = StaticTransformBroadcaster(node)
        self.publish_fixed_transforms()
        self._tf = node.create_publisher("tf", TFMessage)
        key = topic_to_key(node.resolve_topic_name(joint_states_topic))
        self._sub = node.session.declare_subscriber(key, self._on_sample)
        self._token = node._declare_entity("sub", JointState.TYPE_NAME, key)
        node.add_on_shutdown(self.close)

    # ------------------------------------------------------------------ fixed joints
    def fixed_transforms(self) -> list[TransformStamped]:
        """One TransformStamped per non-movable joint, stamped now."""
        now = self.node.get_clock().now()
        out = []
        for j in self.robot.joints_in_order():
            if j.movable:
                continue
            qx, qy, qz, qw = j.origin.quaternion()
            out.append(TransformStamped(Header(now, self.frame_prefix + j.parent), self.frame_prefix + j.child,
                                        Transform(Vector3(*j.origin.xyz), Quaternion(qx, qy, qz, qw))))
        return out

    def publish_fixed_transforms(self) -> None:
        fixed = self.fixed_transforms()
        if fixed:
            self._static.send_transform(fixed)

    # ------------------------------------------------------------------ joint states
    def _on_sample(self, sample: Any) -> None:
        """Zenoh thread: decode, compute, publish; never raises."""
        try:
            payload = sample.payload.to_bytes()
            msg = None
            if self._decoder is not None:
                try:
                    msg = self._decoder.decode(payload)
                except Exception:
                    msg = None
            if msg is None:  # the generic path names what is wrong
                js = wire.decode(payload, JointState)
                names, position, stamp = js.name, js.position, (js.header.stamp.sec, js.header.stamp.nanosec)
            else:
                names, position, stamp = msg.name, msg.position, (msg.header.stamp.sec, msg.header.stamp.nanosec)
            self.process(names, position, stamp[0], stamp[1])
        except Exception as e:  # noqa: BLE001 - one bad message must not stop the publisher
            with self._lock:
                self.ignored += 1
            sender = wire.authority_of(getattr(sample, "attachment", None), "unknown sender")
            self._log("bad", f"ignored a bad JointState from {sender}: {e}")

    def process(self, names: list[str], position: list[float], sec: int, nsec: int) -> bool:
        """Publish the transforms of one joint state; False when it was invalid or throttled."""
        with self._lock:
            self.received += 1
            if len(names) != len(position):
                self.ignored += 1
                self._log("size", f"Robot state publisher ignored an invalid JointState message: {len(names)} "
                          f"names but {len(position)} positions")
                return False
            if not (0 <= sec < _MAX_SEC and 0 <= nsec < _NS):
                self.ignored += 1
                self._log("stamp", f"ignored a JointState with an out-of-range stamp ({sec}, {nsec})")
                return False
            stamp = sec * _NS + nsec
            last = self._last_publish
            if not self.ignore_timestamp:
                oldest = min((last.get(n, 0) for n in names), default=0)
                if stamp < oldest + self.publish_interval_ns:
                    self.ignored += 1
                    return False
            index = self._index
            idx: list[int] = []
            values: list[float] = []
            unknown = None
            for n, v in zip(names, position):
                i = index.get(n)
                if i is None:
                    unknown = n
                    continue
                idx.append(i)
                values.append(v)
            if unknown is not None:
                self._log(f"unknown:{unknown}", f"joint state names unknown joint '{unknown}' (not a movable "
                          f"joint of robot '{self.robot.name}'); ignored")
            if self._mimics:
                given = dict(zip(names, position))
                for i, master, mult, off in self._mimics:
                    v = given.get(master)
                    if v is not None:
                        idx.append(i)
                        values.append(mult * v + off)
            for n in names:
                last[n] = stamp
            if not idx:
                return False
            vals = np.asarray(values, dtype=float)
            if not np.isfinite(vals).all():
                bad = names[int(np.flatnonzero(~np.isfinite(np.asarray(position, dtype=float)))[0])] \
                    if not np.isfinite(np.asarray(position, dtype=float)).all() else "?"
                self.ignored += 1
                self._log("nonfinite", f"ignored a JointState with a non-finite position (joint '{bad}')")
                return False
            ia = np.asarray(idx)
            t, q = self._movable.compute(ia, vals)
            payload = self._encoder.encode(sec, nsec, idx, t, q)
            self.published += 1
        self._tf.publish_bytes(payload)
        return True

    def close(self) -> None:
        for obj in (self._sub, self._token):
            try:
                obj.undeclare()
            except Exception:  # noqa: BLE001
                pass
