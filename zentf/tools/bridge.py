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

from ..transport.broadcaster import StaticTransformBroadcaster
from ..core.messages import TFMessage, message_type
from ..core.ratelimit import RateLimitedLogger
from ..transport.node import Node
from ..transport.wire.profiles import parse_ros2_attachment
from ..transport.entities import undeclare_all

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
        self.gids: set[bytes] = set()
        self.lock = threading.Lock()
        self._self_name = node.get_fully_qualified_name().encode()

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
        gid = getattr(pub._attach, "gid", None)
        if gid is not None:
            self.gids.add(gid)

    def is_own(self, sample: Any) -> bool:
        """Whether a sample is one this side's node published (its name on zentf's wire, one of its
        publisher GIDs on ROS 2's)."""
        att = sample.attachment
        if att is None:
            return False
        raw = att.to_bytes()
        if self.node.wire.name == "zentf":
            return raw == self._self_name
        try:
            return parse_ros2_attachment(raw)[2] in self.gids
        except ValueError:
            return False


class Ros2Bridge:
    """Relays ``topics`` (tf, tf_static and /clock by default, plus ``extra_topics``) between a zentf node
    and a ROS 2 node (``ros2_node.wire.name == 'ros2'``); ``close()`` stops it (the nodes stay yours)."""

    def __init__(self, zentf_node: Node, ros2_node: Node, extra_topics: tuple[str, ...] = (), *,
                 tf: bool = True, clock: bool = True) -> None:
        import zenoh.ext as zx

        if zentf_node.wire.name != "zentf" or ros2_node.wire.name != "ros2":
            raise ValueError("the bridge needs a zentf node and a ros2 node (--wire ros2)")
        self.stats = BridgeStats()
        self._z = _Side(zentf_node)
        self._r = _Side(ros2_node)
        self._complain = RateLimitedLogger(log)
        self._subs: list[Any] = []
        self._tokens: list[Any] = []
        topics = [t for t in DEFAULT_TOPICS if (tf or not t[0].startswith("tf")) and (clock or t[0] != "/clock")]
        topics += [(t, False) for t in extra_topics]
        for topic, latched in topics:
            for src, dst in ((self._z, self._r), (self._r, self._z)):
                node = src.node
                fq = node.resolve_topic_name(topic)
                key = node.wire.data_key(fq, None)
                cb = self._relay_factory(src, dst, topic, fq, latched)
                if latched:
                    sub = zx.declare_advanced_subscriber(node.session, key, cb,
                                                         history=zx.HistoryConfig(detect_late_publishers=True))
                else:
                    sub = node.session.declare_subscriber(key, cb)
                self._subs.append(sub)
                type_name = TFMessage.TYPE_NAME if topic.startswith("tf") else (
                    "rosgraph_msgs/msg/Clock" if topic == "/clock" else "")
                if type_name:
                    self._tokens.append(node._declare_entity("sub", type_name, key, topic=fq, depth=100,
                                                             latched=latched))

    # ---- relaying
    def _relay_factory(self, src: _Side, dst: _Side, topic: str, fq: str, latched: bool) -> Any:
        counts = self.stats.to_ros2 if dst is self._r else self.stats.to_zentf
        counts.setdefault(fq, 0)

        profile = src.node.wire

        def relay(sample: Any) -> None:  # Zenoh thread: decode, re-encode, publish; never raises
            try:
                if src.is_own(sample):
                    self.stats.echoes += 1
                    return
                key = str(sample.key_expr)
                payload = sample.payload.to_bytes()
                type_name, msg, known = profile.decode_any(payload, str(sample.encoding), key)
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
        undeclare_all([*self._subs, *self._tokens])
        self._subs.clear()
        self._tokens.clear()
