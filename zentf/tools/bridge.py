"""``zentf bridge ros2``: relay tf, tf_static, /clock and named topics between a zentf graph and a ROS 2
(rmw_zenoh) graph, both ways, for systems that mix both.

Two nodes, one per side (each may be on its own Zenoh network, or both on one): what one side
publishes is decoded (msgpack or CDR) and republished on the other in that side's format. Echo loops
cannot form: a sample the bridge itself published is recognised on arrival (zentf side: the bridge's
node name in the attachment; ROS 2 side: one of the bridge's publisher GIDs) and dropped. Statics stay
latched on both sides: each side's tf_static is accumulated per child frame and republished, whole, by a
StaticTransformBroadcaster on the other side (late joiners there get it from the cache).

Whatever a peer sends, the bridge's memory stays bounded: a TFMessage is read by the TF decoders (compiled,
malformed elements named and skipped, nothing kept but frame names), the latched statics keep at most a
buffer's frame cap of child frames, payloads beyond the decoders' cap are refused, and the memory a burst
of big messages used is given back (zentf.transport.heap.BurstRelease).
"""
from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from typing import Any

from ..core.constants import DEFAULT_MAX_FRAME_ID_LENGTH, DEFAULT_MAX_FRAMES
from ..core.messages import Clock, TFMessage, message_type
from ..core.ratelimit import RateLimitedLogger
from ..ros.tf import MAX_PAYLOAD
from ..transport.broadcaster import StaticTransformBroadcaster
from ..transport.heap import BurstRelease
from ..transport.node import Node, RawSample

__all__ = ["Ros2Bridge", "BridgeStats"]

log = logging.getLogger("zentf.bridge")

#: (topic, latched) relayed by default: tf2's two topics and the sim clock.
DEFAULT_TOPICS = (("tf", False), ("tf_static", True), ("/clock", False))


@dataclass
class BridgeStats:
    """Messages relayed per direction and topic, and echoes dropped."""

    to_ros2: dict[str, int] = field(default_factory=dict)
    to_zentf: dict[str, int] = field(default_factory=dict)
    echoes: int = 0
    dropped: int = 0


class _Side:
    """One side's node plus the publishers the bridge made there (created on the first message of a type),
    and how to tell the bridge's own samples when they come back (echoes)."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.pubs: dict[tuple[str, str], Any] = {}
        self.statics: dict[str, StaticTransformBroadcaster] = {}
        self.own: set[bytes] = set()  # the sender ids of the bridge's publishers on this side
        self.lock = threading.Lock()

    def publisher(self, topic: str, type_name: str, *, latched: bool = False) -> Any:
        with self.lock:
            pub = self.pubs.get((topic, type_name))
            if pub is None:
                pub = self.node.create_publisher(topic, message_type(type_name),
                                                 1 if latched else 100 if type_name == TFMessage.TYPE_NAME else 10,
                                                 latched=latched)
                self._remember(pub)
                self.pubs[(topic, type_name)] = pub
            return pub

    def static(self, topic: str) -> StaticTransformBroadcaster:
        with self.lock:
            b = self.statics.get(topic)
            if b is None:
                b = self.statics[topic] = StaticTransformBroadcaster(self.node, topic)
                self._remember(b._pub)
            return b

    def _remember(self, pub: Any) -> None:
        self.own.add(pub.sender_id)

    def is_own(self, sample: RawSample) -> bool:
        """Whether a sample is one this side's bridge publishers sent (its sender id in their attachments:
        the node's name on zentf's wire, a publisher GID on ROS 2's)."""
        return sample.attachment is not None and self.node.wire.sender_id(sample.attachment) in self.own


class Ros2Bridge:
    """Relays ``topics`` (tf, tf_static and /clock by default, plus ``extra_topics``) between a node on zentf's
    wire and a node on ROS 2's (``--wire ros2``), or any two nodes on different wires (``BridgeStats``'
    ``to_ros2`` counts what goes from the first to the second); ``close()`` stops it (the nodes stay yours)."""

    def __init__(self, zentf_node: Node, ros2_node: Node, extra_topics: tuple[str, ...] = (), *,
                 tf: bool = True, clock: bool = True) -> None:
        if zentf_node.wire == ros2_node.wire:  # one wire: each side would hear the other's relays, forever
            raise ValueError(f"the bridge needs nodes on two different wires (e.g. zentf and --wire ros2), "
                             f"both are on {zentf_node.wire.name} (domain {zentf_node.wire.domain_id})")
        self.stats = BridgeStats()
        self._z = _Side(zentf_node)
        self._r = _Side(ros2_node)
        self._complain = RateLimitedLogger(log)
        self._release = BurstRelease()
        self._subs: list[Any] = []
        topics = [t for t in DEFAULT_TOPICS if (tf or not t[0].startswith("tf")) and (clock or t[0] != "/clock")]
        topics += [(t, False) for t in extra_topics]
        for topic, latched in topics:
            type_name = TFMessage.TYPE_NAME if topic.startswith("tf") else (
                Clock.TYPE_NAME if topic == "/clock" else None)
            for src, dst in ((self._z, self._r), (self._r, self._z)):
                fq = src.node.resolve_topic_name(topic)
                self._subs.append(src.node.create_raw_subscription(
                    fq, self._relay_factory(src, dst, topic, fq, latched), type_name=type_name, latched=latched))

    # ---- relaying
    def _relay_factory(self, src: _Side, dst: _Side, topic: str, fq: str, latched: bool) -> Any:
        counts = self.stats.to_ros2 if dst is self._r else self.stats.to_zentf
        counts.setdefault(fq, 0)

        profile = src.node.wire

        def relay(sample: RawSample) -> None:  # Zenoh thread: decode, re-encode, publish; never raises
            try:
                if src.is_own(sample):
                    self.stats.echoes += 1
                    return
                payload = sample.payload
                size = len(payload)
                self._release.note(size)
                if size > MAX_PAYLOAD:
                    raise ValueError(f"payload of {size} bytes exceeds the {MAX_PAYLOAD} byte limit")
                if topic.startswith("tf"):
                    if sample.type_name not in (None, TFMessage.TYPE_NAME):  # another type on tf is named as such
                        raise ValueError(f"wrong type {sample.type_name}, expected {TFMessage.TYPE_NAME}")
                    if not self._relay_tf(src, dst, topic, fq, latched, payload):
                        self.stats.dropped += 1
                        return
                else:
                    type_name, msg, known = profile.decode_any(payload, sample.encoding, sample.key)
                    if not known or type_name is None or isinstance(msg, (bytes, dict)):
                        raise ValueError(f"cannot convert a message of type {type_name or 'unknown'}")
                    dst.publisher(topic, type_name).publish(msg)
                counts[fq] = counts.get(fq, 0) + 1
            except Exception as e:  # noqa: BLE001 - one bad message must not stop the bridge
                self.stats.dropped += 1
                self._complain.log(logging.WARNING, (fq, type(e).__name__), "not relayed from %s '%s': %s",
                                   profile.name, fq, e)

        return relay

    def _relay_tf(self, src: _Side, dst: _Side, topic: str, fq: str, latched: bool, payload: bytes) -> bool:
        """A TFMessage, through the TF decoders of the source's wire into the destination's encoder (no
        message objects); malformed elements are skipped with one line, statics kept within the frame
        cap. False if nothing was relayed."""
        profile = src.node.wire
        collect = _Samples()
        _, _, malformed, problem = profile.ingest_tf(payload, collect, "", latched)
        if malformed:
            self._complain.log(logging.WARNING, (fq, "malformed"), "skipped %d malformed transform(s) from %s '%s': %s",
                               malformed, profile.name, fq, problem or "")
        items = [_plain(s) for s in collect.samples if len(s[0].encode()) <= DEFAULT_MAX_FRAME_ID_LENGTH
                 and len(s[1].encode()) <= DEFAULT_MAX_FRAME_ID_LENGTH]
        if not items:
            if not latched and not collect.samples and not malformed:  # an empty TFMessage, relayed as one
                dst.publisher(topic, TFMessage.TYPE_NAME).publish_bytes(dst.node.wire.encode_tf([]))
                return True
            return False
        if latched:
            static = dst.static(topic)
            known = static._by_child
            fresh = [t for t in items if t["child_frame_id"] not in known]
            room = DEFAULT_MAX_FRAMES - len(known)
            if len(fresh) > room:
                self._complain.log(logging.WARNING, (fq, "frames"),
                                   "%s '%s': more than %d static child frames; %d not relayed",
                                   profile.name, fq, DEFAULT_MAX_FRAMES, len(fresh) - max(0, room))
                drop = {id(t) for t in fresh[max(0, room):]}
                items = [t for t in items if id(t) not in drop]
            if not items:
                return False
            static.send_transform(items)
        else:
            dst.publisher(topic, TFMessage.TYPE_NAME).publish_bytes(dst.node.wire.encode_tf(items))
        return True

    def close(self) -> None:
        self._release.close()
        for sub in self._subs:
            sub.destroy()
        self._subs.clear()


class _Samples:
    """What a wire's ingest_tf inserts into, for the bridge: the decoded samples, kept for re-encoding."""

    def __init__(self) -> None:
        self.samples: list[tuple] = []

    def set_transforms_raw(self, samples: list, authority: str, is_static: bool) -> int:
        self.samples.extend(samples)
        return len(samples)


_NS = 1_000_000_000


def _plain(s: tuple) -> dict:
    """A decoded sample as the plain TransformStamped dict both wires' encoders take."""
    return {"header": {"stamp": {"sec": s[2] // _NS, "nanosec": s[2] % _NS}, "frame_id": s[0]},
            "child_frame_id": s[1],
            "transform": {"translation": {"x": s[3], "y": s[4], "z": s[5]},
                          "rotation": {"x": s[6], "y": s[7], "z": s[8], "w": s[9]}}}
