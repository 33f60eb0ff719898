"""TransformListener: fills a Buffer from ``tf`` and ``tf_static`` on Zenoh's own threads (fast path)."""
from __future__ import annotations

import logging
import threading
import uuid
from functools import partial
from typing import Any

from .core.messages import TFMessage
from .node import Node, RateLimitedLog

__all__ = ["TransformListener", "StaticTransformListener"]

log = logging.getLogger("zentf.listener")


class TransformListener:
    """TransformListener(buffer, node=None, *, static_only=False): subscribes and inserts; never raises.

    Each message is msgpack-decoded and inserted with ``set_transforms_raw`` (no dataclasses); a
    malformed element is counted, logged (rate-limited, naming the sender) and skipped. The sender's
    node name (sample attachment) is the authority. A backwards jump of the node's clock clears the
    buffer (statics survive), as tf2 does. Without a node, a hidden one is created from the env.
    """

    def __init__(self, buffer: Any, node: Node | None = None, *, static_only: bool = False,
                 tf_topic: str = "tf", tf_static_topic: str = "tf_static", spin_thread: bool = True) -> None:
        import zenoh.ext as zx

        self.buffer = buffer
        self._own_node = node is None
        self.node = node if node is not None else Node(f"transform_listener_impl_{uuid.uuid4().hex[:12]}",
                                                       check_unique=False)
        if getattr(buffer, "node", "missing") is None:
            buffer.node = self.node
        self._log = RateLimitedLog(log)
        self._lock = threading.Lock()
        self.messages = 0          # TFMessages applied (fully or partly)
        self.transforms = 0        # transforms accepted by the buffer
        self.rejected = 0          # well-formed transforms the buffer refused (NaN, bad quaternion, old data...)
        self.malformed = 0         # transform elements with a bad shape
        self.bad_messages = 0      # payloads that were not a TFMessage at all
        self._subs: list[Any] = []
        self._tokens: list[Any] = []
        profile = self.node.wire  # zentf or ros2 (zentf.profile): key layout, payload format, authority
        self._tf_encoding = profile.encoding(TFMessage.TYPE_NAME)
        self._check_encoding = profile.check_tf_encoding
        self._authority = profile.authority
        self._ingest = profile.ingest_tf
        #: ROS 2 carries no sender name: tf2_ros records one fixed authority for every transform
        self._fixed_authority = profile.authority(None, "") if profile.name == "ros2" else None
        self._authorities: dict[bytes, str] = {}
        session = self.node.session
        static_key = wire_key(self.node, tf_static_topic)
        self._subs.append(zx.declare_advanced_subscriber(
            session, static_key, partial(self._on_sample, is_static=True),
            history=zx.HistoryConfig(detect_late_publishers=True)))
        self._declare_token(static_key, is_static=True)
        if not static_only:
            key = wire_key(self.node, tf_topic)
            # the bound method itself (no lambda frame): tf ingest runs right in Zenoh's callback thread
            self._subs.append(session.declare_subscriber(key, self._on_sample))
            self._declare_token(key)
        self._jump = self.node.get_clock().add_jump_callback(self._on_jump)
        self.node.add_on_shutdown(self.unregister)

    def _declare_token(self, key: str, is_static: bool = False) -> None:
        if "*" not in key:  # a liveliness token cannot hold a wildcard; '*/tf' listeners stay unlisted
            # depth 100 on both, as tf2_ros's DynamicListenerQoS / StaticListenerQoS
            self._tokens.append(self.node._declare_entity("sub", TFMessage.TYPE_NAME, key, depth=100,
                                                          latched=is_static,
                                                          topic=self.node.wire.topic_of_key(key)[0]))

    def _on_sample(self, sample: Any, is_static: bool = False) -> None:
        """Zenoh thread: decode and insert; every failure is contained here."""
        try:
            enc = sample.encoding
            if enc != self._tf_encoding:  # cheap Rust-side compare for the common case
                self._check_encoding(enc)
            authority = self._fixed_authority
            if authority is None:
                att = sample.attachment
                authority = self._authorities.get(att.to_bytes()) if att is not None else None
                if authority is None:
                    authority = self._authority(att, str(sample.key_expr))
                    if att is not None and len(self._authorities) < 1024:
                        self._authorities[att.to_bytes()] = authority
            accepted, rejected, malformed, problem = self._ingest(sample.payload.to_bytes(), self.buffer,
                                                                  authority, is_static)
        except Exception as e:
            self.bad_messages += 1
            try:
                key = str(sample.key_expr)
                sender = self._authority(sample.attachment, "unknown sender")
            except Exception:
                key, sender = "?", "unknown sender"
            self._log(f"bad:{key}:{sender}", f"dropped bad message on '{key}' from {sender}: {e}")
            return
        # plain counters (statistics only; no lock on the hot path)
        self.messages += 1
        self.transforms += accepted
        if rejected:
            self.rejected += rejected
        if malformed:
            self.malformed += malformed
            key = str(sample.key_expr)
            self._log(f"malformed:{key}:{authority}",
                      f"skipped {malformed} malformed transform(s) on '{key}' from {authority}: {problem}")

    def _on_jump(self, old: Any, new: Any) -> None:
        log.warning("Detected jump back in time of %.6fs. Clearing TF buffer.", (old - new).to_sec())
        self.buffer.clear()

    def stats(self) -> dict[str, int]:
        with self._lock:
            return {"messages": self.messages, "transforms": self.transforms, "rejected": self.rejected,
                    "malformed": self.malformed, "bad_messages": self.bad_messages}

    def unregister(self) -> None:
        """Stop listening (the buffer keeps its data)."""
        self.node.get_clock().remove_jump_callback(self._jump)
        for obj in [*self._subs, *self._tokens]:
            try:
                obj.undeclare()
            except Exception:
                pass
        self._subs.clear()
        self._tokens.clear()
        if self._own_node and not self.node._closed:
            self.node.shutdown()

    close = unregister

    def __enter__(self) -> "TransformListener":
        return self

    def __exit__(self, *exc: object) -> None:
        self.unregister()


class StaticTransformListener(TransformListener):
    """Only ``tf_static`` (tf2_ros rolling)."""

    def __init__(self, buffer: Any, node: Node | None = None, **kw: Any) -> None:
        super().__init__(buffer, node, static_only=True, **kw)


def wire_key(node: Node, topic: str) -> str:
    """Key of a tf topic; '*' / '**' parts make it a pattern ('*/tf' = the tf of every robot namespace)."""
    from .core.messages import TFMessage as _TF

    if "*" not in topic:
        return node.wire.data_key(node.resolve_topic_name(topic), _TF.TYPE_NAME)
    marks = {"**": "zentf_wild2_", "*": "zentf_wild1_"}
    parts = topic.split("/")
    for part in parts:
        if "*" in part and part not in marks:
            raise ValueError(f"invalid tf topic {topic!r}: a wildcard must be a whole part ('*' or '**')")
    key = node.wire.data_key(node.resolve_topic_name("/".join(marks.get(p, p) for p in parts)), _TF.TYPE_NAME)
    return "/".join({v: k for k, v in marks.items()}.get(c, c) for c in key.split("/"))
