"""``zentf bridge ros2``: relay tf, tf_static, /clock and named topics between a zentf graph and a ROS 2
(rmw_zenoh) graph, both ways, for systems that mix both.

Two nodes, one per side (each may be on its own Zenoh network, or both on one): what one side
publishes is decoded (msgpack or CDR) and republished on the other in that side's format. Echo loops
cannot form: a sample the bridge itself published is recognised on arrival (zentf side: the bridge's
node name in the attachment; ROS 2 side: one of the bridge's publisher GIDs) and dropped. Statics stay
latched on both sides: each side's tf_static is accumulated per child frame and republished, whole, by a
StaticTransformBroadcaster on the other side (late joiners there get it from the cache).
"""
from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from typing import Any

from ..core.messages import Clock, TFMessage, message_type
from ..transport.broadcaster import StaticTransformBroadcaster
from ..core.ratelimit import RateLimitedLogger
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

    def publisher(self, topic: str, type_name: str) -> Any:
        with self.lock:
            pub = self.pubs.get((topic, type_name))
            if pub is None:
                pub = self.node.create_publisher(topic, message_type(type_name),
                                                 100 if type_name == TFMessage.TYPE_NAME else 10)
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
                type_name, msg, known = profile.decode_any(sample.payload, sample.encoding, sample.key)
                if not known or type_name is None or isinstance(msg, (bytes, dict)):
                    raise ValueError(f"cannot convert a message of type {type_name or 'unknown'}")
                if latched and type_name == TFMessage.TYPE_NAME:
                    dst.static(topic).send_transform(list(msg.transforms))
                else:
                    dst.publisher(topic, type_name).publish(msg)
                counts[fq] = counts.get(fq, 0) + 1
            except Exception as e:  # noqa: BLE001 - one bad message must not stop the bridge
                self.stats.dropped += 1
                self._complain.log(logging.WARNING, (fq, type(e).__name__), "not relayed from %s '%s': %s",
                                   profile.name, fq, e)

        return relay

    def close(self) -> None:
        for sub in self._subs:
            sub.destroy()
        self._subs.clear()
