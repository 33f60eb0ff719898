"""robot_state_publisher: a URDF model plus ``joint_states`` -> ``tf`` and ``tf_static``.

ROS 2 semantics (robot_state_publisher 3.x): fixed joints (and floating/planar ones, which KDL
treats as fixed) go once on ``tf_static``, latched, stamped at start (ROS 1 re-sent them every
``1/publish_frequency``); each JointState publishes its movable joints on ``tf`` stamped with the
JointState's own stamp, unless every joint in it was published less than ``1/publish_frequency`` ago (by stamp; ``ignore_timestamp`` turns that off).
Mimic joints follow their master. ``frame_prefix`` is prepended to every frame id as is (ROS 2;
ROS 1 used tf_prefix with a '/'). The URDF text is published latched on ``robot_description``
(std_msgs/String). Joint states are decoded and turned into one TFMessage in Zenoh's callback
thread (no executor hop; a raw subscription through the node's wire profile). On zentf's msgpack wire:
throttle, finite check, kinematics and the message bytes in one compiled call (zentf/tools/jointtf.pyx:
at 100 Hz the process wakes with cold caches, where numpy's per-call cost would dominate), and a
JointState whose name list is byte for byte the one last seen (publishers resend the same list) is
read in C without decoding a name (``JointTfFiller.read``); anything else, or anything odd, takes the
general decoder, which names what is wrong. On a wire of other payloads (``--wire ros2``: CDR) the
profile decodes the JointState, numpy computes the joints and the profile writes the TFMessage.

The program (``zentf run robot_state_publisher``):

    zentf run robot_state_publisher configs/robots/my_robot.urdf
    zentf run robot_state_publisher robot.urdf.xacro --frame-prefix robot1/ --publish-frequency 50
    zentf run robot_state_publisher -p robot_description:="$(cat robot.urdf)"

Parameters (``-p NAME:=VALUE`` or launch ``parameters:``): ``publish_frequency`` (Hz, default 20),
``frame_prefix`` (default ''), ``ignore_timestamp`` (default false), ``robot_description`` (URDF
text, used when no file is given), ``package_path`` (os.pathsep-separated). The flags below
override them. A malformed URDF is refused before anything starts (one line, exit 2).
"""
from __future__ import annotations

import argparse
import logging
import struct
import sys
import threading
from typing import Any, Sequence

import msgpack
import numpy as np

from ..core.messages import (Header, JointState, Quaternion, String, TFMessage, Transform, TransformStamped,
                             Vector3)
from ..core.ratelimit import RateLimitedLogger
from ..core.time import Time
from ..transport import program
from ..transport.broadcaster import StaticTransformBroadcaster
from ..transport.clock import rate_problem
from ..transport.node import Node, RawSample
from ..transport.wire import codec as wire
from ..urdf import Kinematics, Robot
from ..urdf.kinematics import JointTransforms
from .jointtf import JointTfFiller  # zentf's wire: decode, kinematics and the TFMessage bytes in C
from .robot_model import START_ERRORS, Prepared, own_arguments, prepare

__all__ = ["RobotStatePublisher"]

log = logging.getLogger("zentf.robot_state_publisher")
_NS = 1_000_000_000
_MAX_SEC = 2**32


def _joint_state_decoder() -> Any:
    """msgspec decoder of a JointState's plain-dict wire form (strict types)."""
    import msgspec

    def struct_(name: str, fields: list) -> Any:
        return msgspec.defstruct(name, fields, gc=False)

    stamp = struct_("Time", [("sec", int), ("nanosec", int)])
    header = struct_("Header", [("stamp", stamp), ("frame_id", str)])
    return msgspec.msgpack.Decoder(struct_("JointState", [
        ("header", header), ("name", list[str]), ("position", list[float]),
        ("velocity", list[float], []), ("effort", list[float], [])]))


class _Plan:
    """What one joint-name list means, worked out once per distinct list (publishers resend the same):
    the joints it sets, where their values are in the message, its mimic joints, its unknown names,
    the joints' constants (for the rare message a joint of which is not finite, computed apart), and
    the compiled filler of the TFMessage bytes (None when the list names no movable joint)."""

    _ITEM_VALUES = struct.Struct(">d3sd3sd13sd3sd3sd3sd")

    def __init__(self, rsp: "RobotStatePublisher", names: list[str]) -> None:
        index = rsp._index
        first = {}
        for k, n in enumerate(names):
            first.setdefault(n, k)
        # a name given twice counts once, its first value (ROS builds a map with insert)
        self.sel = [k for k, n in enumerate(names) if n in index and first[n] == k]
        self.unknown = [n for n in names if n not in index]
        given = first
        # a mimic joint follows its master unless the message names it itself (ROS keeps the given value)
        self.mimics = [(i, given[master], mult, off) for i, master, mult, off in rsp._mimics
                       if master in given and rsp._movable.names[i] not in given]
        idx = [index[names[k]] for k in self.sel] + [m[0] for m in self.mimics]
        self.idx = np.asarray(idx, dtype=int)
        self.known = np.asarray([index[names[k]] for k in self.sel], dtype=int)
        self.sel_arr = np.asarray(self.sel, dtype=int)
        self.all_known = len(self.sel) == len(names)  # every name known, none repeated: no selection needed
        self.mimic_src = np.asarray([m[1] for m in self.mimics], dtype=int)
        self.mimic_mult = np.asarray([m[2] for m in self.mimics], dtype=float)
        self.mimic_off = np.asarray([m[3] for m in self.mimics], dtype=float)
        self.joints = rsp._movable.subset(self.idx)
        self.filler: Any = None
        k = len(idx)
        if not k:
            return
        # the payload template: TFMessage{transforms: [TransformStamped x k]} with zeroed stamps/values
        p = msgpack.packb
        head = b"\x83" + p("header") + b"\x82" + p("stamp") + b"\x82" + p("sec") + b"\xce"
        nsec_key = b"\xa7nanosec\xce"
        out = bytearray(b"\x81\xaatransforms" + (bytes((0x90 | k,)) if k < 16 else b"\xdc" + k.to_bytes(2, "big")
                                                 if k < 0x10000 else b"\xdd" + k.to_bytes(4, "big")))
        sec_pos, nsec_pos, val_pos = [], [], []  # where each item's sec, nanosec and first double go
        zero = self._ITEM_VALUES.pack(0.0, b"\xa1y\xcb", 0.0, b"\xa1z\xcb", 0.0, b"\xa8rotation\x84\xa1x\xcb", 0.0,
                                      b"\xa1y\xcb", 0.0, b"\xa1z\xcb", 0.0, b"\xa1w\xcb", 0.0)
        for i in idx:
            out += head
            sec_pos.append(len(out))
            out += b"\0\0\0\0" + nsec_key
            nsec_pos.append(len(out))
            out += b"\0\0\0\0" + rsp._frames[i]
            val_pos.append(len(out))
            out += zero
        j = self.joints
        ip = np.intp
        self.filler = JointTfFiller(
            bytes(out), np.asarray(self.sel, dtype=ip), np.asarray(self.mimic_src, dtype=ip),
            np.ascontiguousarray(self.mimic_mult), np.ascontiguousarray(self.mimic_off),
            np.asarray(self.known, dtype=ip), rsp._last_publish,
            *(np.ascontiguousarray(a, dtype=float) for a in (j.t0, j.q0, j.q0a, j.half, j.slide)),
            np.asarray(sec_pos, dtype=ip), np.asarray(nsec_pos, dtype=ip), np.asarray(val_pos, dtype=ip))


class RobotStatePublisher:
    """Publishes a robot's frames from its model and its joint states (see the module doc)."""

    def __init__(self, node: Node, robot: Robot, *, frame_prefix: str = "", publish_frequency: float = 20.0,
                 ignore_timestamp: bool = False, joint_states_topic: str = "joint_states") -> None:
        problem = rate_problem("publish_frequency", publish_frequency)
        if problem is not None:
            raise ValueError(problem)
        self.node = node
        self.robot = robot
        self.frame_prefix = frame_prefix
        self.publish_interval_ns = int(round(1e9 / publish_frequency))
        self.ignore_timestamp = ignore_timestamp
        self.kin = Kinematics(robot)
        #: zentf's msgpack payloads: the compiled reader and writer apply (else the profile decodes and encodes)
        self._msgpack = node.wire.payload_format == "msgpack"
        self._log = RateLimitedLogger(log)
        self._lock = threading.Lock()
        self.received = 0     # joint state messages
        self.published = 0    # TFMessages sent on tf
        self.ignored = 0      # invalid or throttled joint states
        self.fast_reads = 0   # joint states read in C (names as last time, sent the same way)
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
        pk = msgpack.packb
        self._frames = [b"".join((pk("frame_id"), pk(frame_prefix + par), pk("child_frame_id"), pk(frame_prefix + ch),
                                  pk("transform"), b"\x82", pk("translation"), b"\x83", pk("x"), b"\xcb"))
                        for par, ch in zip(self._movable.parents, self._movable.children)]
        self._plans: dict[tuple[str, ...], _Plan] = {}
        self._last_names: list[str] | None = None
        self._last_plan: _Plan | None = None
        self._last_publish = np.zeros(len(movable), dtype=np.int64)  # stamp of each joint's last publish
        self._clock = node.get_clock()
        self._last_callback = 0
        self._decoder = _joint_state_decoder()

        self._description = node.create_publisher("robot_description", String, latched=True)
        self._description.publish(String(robot.xml))
        self._static = StaticTransformBroadcaster(node)
        self.publish_fixed_transforms()
        self._tf = node.create_publisher("tf", TFMessage)
        self._sub = node.create_raw_subscription(joint_states_topic, self._on_sample, type_name=JointState)
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
    def _on_sample(self, sample: RawSample) -> None:
        """Zenoh thread: decode, compute, publish; never raises."""
        try:
            if self._msgpack:
                self.on_payload(sample.payload)
            else:
                js = self.node.wire.decode(sample.payload, sample.encoding, sample.key, JointState)
                self.process(js.name, js.position, js.header.stamp.sec, js.header.stamp.nanosec)
        except Exception as e:  # noqa: BLE001 - one bad message must not stop the publisher
            with self._lock:
                self.ignored += 1
            sender = self.node.wire.authority(sample.attachment, "unknown sender")
            self._log.log(logging.WARNING, ("bad", sender), "ignored a bad JointState from %s: %s", sender, e)

    def on_payload(self, payload: bytes) -> None:
        """One JointState as zentf's wire carries it (msgpack bytes): publish its transforms; raises on a
        bad one."""
        plan = self._last_plan
        if plan is not None and plan.filler is not None:
            # the same names as last time, sent the same way: positions and stamp read in C, no name decoded
            stamp = plan.filler.read(payload)
            if stamp is not None:
                self._publish_read(plan, stamp[0], stamp[1])
                return
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
        plan = self._last_plan
        if plan is not None and plan.filler is not None and names == self._last_names:
            plan.filler.learn(payload, len(names))

    def process(self, names: list[str], position: list[float], sec: int, nsec: int) -> bool:
        """Publish the transforms of one joint state; False when it was invalid or throttled."""
        with self._lock:
            self.received += 1
            if len(names) != len(position):
                self.ignored += 1
                self._log.log(logging.WARNING, "size", "Robot state publisher ignored an invalid JointState "
                              "message: %d names but %d positions", len(names), len(position))
                return False
            if not (0 <= sec < _MAX_SEC and 0 <= nsec < _NS):
                self.ignored += 1
                self._log.log(logging.WARNING, "stamp", "ignored a JointState with an out-of-range stamp (%s, %s)",
                              sec, nsec)
                return False
            stamp = sec * _NS + nsec
            plan = self._plan(names)
            self._arrived(plan)
            filler = plan.filler
            if filler is None:  # no movable joint named: nothing to publish
                return False
            if not self.ignore_timestamp and not filler.fresh(stamp, self.publish_interval_ns):
                self.ignored += 1
                return False
            # zentf's wire: finite check, kinematics and bytes in one compiled call
            payload = filler.payload(position, sec, nsec) if self._msgpack else None
            if payload is None:  # another wire's format, or a joint not finite (then left out)
                payload = self._finite_part(plan, position, sec, nsec, stamp)
                if payload is None:
                    return False
            else:
                filler.mark(stamp)
            self.published += 1
        self._tf.publish_bytes(payload)
        return True

    def _publish_read(self, plan: _Plan, sec: int, nsec: int) -> None:
        """``process`` for a message ``plan.filler.read`` took in (names known, sizes, stamp and values
        checked there)."""
        filler = plan.filler
        with self._lock:
            self.received += 1
            self.fast_reads += 1
            stamp = sec * _NS + nsec
            self._arrived(plan)
            if not self.ignore_timestamp and not filler.fresh(stamp, self.publish_interval_ns):
                self.ignored += 1
                return
            payload = filler.build(sec, nsec)
            filler.mark(stamp)
            self.published += 1
        self._tf.publish_bytes(payload)

    def _arrived(self, plan: _Plan) -> None:
        """A valid JointState of this plan came (the caller holds the lock): its unknown names logged, the
        clock noted (gone back: every joint is published again)."""
        if plan.unknown:
            self._log.log(logging.WARNING, ("unknown", plan.unknown[0]), "joint state names unknown joint '%s' "
                          "(not a movable joint of robot '%s'); ignored", plan.unknown[0], self.robot.name)
        now = self._clock.now_ns()
        if now < self._last_callback:  # e.g. a bag played in a loop with --clock (ROS 2 does the same)
            log.warning("Moved backwards in time, re-publishing joint transforms!")
            self._last_publish[:] = 0
        self._last_callback = now

    @staticmethod
    def _compute(plan: _Plan, position: list[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(values, translations, quaternions) of a plan's joints, mimics included (numpy; overflow quiet): what
        the compiled filler computes, apart, for a message some joint of which is not finite."""
        given = np.asarray(position, dtype=float)
        values = given if plan.all_known else given[plan.sel_arr]
        with np.errstate(all="ignore"):
            if plan.mimics:
                values = np.concatenate((values, given[plan.mimic_src] * plan.mimic_mult + plan.mimic_off))
            t, q = plan.joints.compute(values)
        return values, t, q

    def _finite_part(self, plan: _Plan, position: list[float], sec: int, nsec: int, stamp: int) -> bytes | None:
        """The TFMessage, in the wire's format, of the joints whose value and transform are finite; each joint
        left out is named in a rate-limited line (a mimic of a huge master, a NaN position) and the message
        counted as ignored, the others are published as usual. None when no joint is left (the caller holds
        the lock)."""
        values, t, q = self._compute(plan, position)
        ok = np.isfinite(values) & np.isfinite(t).all(axis=1) & np.isfinite(q).all(axis=1)
        n_sel = len(plan.sel)
        for k in np.flatnonzero(~ok)[:8]:
            j = int(plan.idx[k])
            name = self._movable.names[j]
            if k < n_sel:
                why = f"its position {position[plan.sel[k]]!r} is not finite" if not np.isfinite(values[k]) \
                    else f"its transform at {values[k]!r} is not finite"
            else:
                _i, src, mult, off = plan.mimics[k - n_sel]
                why = (f"as a mimic ({mult:g} * {position[src]!r} + {off:g}) its position is not finite"
                       if not np.isfinite(values[k]) else f"its transform at {values[k]!r} is not finite")
            self._log.log(logging.WARNING, ("dropped", name), "left joint '%s' out of a JointState's transforms: %s",
                          name, why)
        if not ok.all():
            self.ignored += 1
        if not ok.any():
            return None
        self._last_publish[plan.known[ok[:n_sel]]] = stamp
        prefix = self.frame_prefix
        header_stamp = Time(sec, nsec)
        out = []
        for k in np.flatnonzero(ok):
            j = int(plan.idx[k])
            tk, qk = t[k], q[k]
            out.append(TransformStamped(Header(header_stamp, prefix + self._movable.parents[j]),
                                        prefix + self._movable.children[j],
                                        Transform(Vector3(float(tk[0]), float(tk[1]), float(tk[2])),
                                                  Quaternion(float(qk[0]), float(qk[1]), float(qk[2]),
                                                             float(qk[3])))))
        return self.node.wire.encode_tf(out)

    def _plan(self, names: list[str]) -> _Plan:
        """The cached plan of a joint-name list (the same list as last time: one list comparison)."""
        if names == self._last_names and self._last_plan is not None:
            return self._last_plan
        key = tuple(names)
        plan = self._plans.get(key)
        if plan is None:
            if len(self._plans) > 64:  # a publisher that changes its list every time: stay bounded
                self._plans.clear()
            plan = self._plans[key] = _Plan(self, list(names))
        self._last_names, self._last_plan = list(names), plan
        return plan

    def close(self) -> None:
        self._sub.destroy()


# ---- the program (zentf run robot_state_publisher)

PROG = "robot_state_publisher"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, allow_abbrev=False,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    own_arguments(p)
    p.add_argument("--frame-prefix", default=None, help="prepended to every frame id (e.g. robot1/)")
    p.add_argument("--publish-frequency", type=float, default=None, metavar="HZ",
                   help="most tf messages per second per joint (default 20)")
    p.add_argument("--ignore-timestamp", action="store_true", default=None,
                   help="publish every joint state, whatever its stamp")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Check everything, then run; a bad argument or model is one line and exit 2."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        p = prepare(PROG, _parser(), argv)
    except START_ERRORS as e:
        print(f"{PROG}: error: {e}", file=sys.stderr, flush=True)
        return 2
    return 0 if p is None else run(p)


def run(p: Prepared) -> int:
    return program.run(lambda: _run(p.opts, p.robot, p.args), PROG, p.debug)


def _run(opts, robot: Robot, args: argparse.Namespace) -> None:
    with program.make_node(opts, PROG) as node:
        prefix = args.frame_prefix if args.frame_prefix is not None else str(program.param(node, "frame_prefix", ""))
        freq = (program.check_rate("--publish-frequency", args.publish_frequency)
                if args.publish_frequency is not None else program.param_rate(node, "publish_frequency", 20.0))
        ignore = bool(args.ignore_timestamp) or program.param_bool(node, "ignore_timestamp", False)
        rsp = RobotStatePublisher(node, robot, frame_prefix=prefix, publish_frequency=freq, ignore_timestamp=ignore)
        movable = len(rsp._movable.names)
        program.say(f"publishing robot '{robot.name}' ({len(robot.links)} links): {len(robot.joints) - movable} "
                    f"fixed joints on tf_static, {movable} movable joints from joint_states on tf")
        node.spin()


if __name__ == "__main__":
    program.finish(main())
