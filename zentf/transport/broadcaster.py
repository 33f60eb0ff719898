"""TransformBroadcaster (``tf``) and StaticTransformBroadcaster (latched ``tf_static``)."""
from __future__ import annotations

import threading
from collections.abc import Iterable
from typing import Any, Union

from ..core.messages import TFMessage, TransformStamped
from .node import Node

__all__ = ["TransformBroadcaster", "StaticTransformBroadcaster"]

TransformsArg = Union[TransformStamped, dict, Iterable[Union[TransformStamped, dict]], TFMessage]


def _as_list(transform: TransformsArg) -> list:
    if isinstance(transform, (TransformStamped, dict)):
        return [transform]
    if isinstance(transform, TFMessage):
        return list(transform.transforms)
    items = list(transform)
    for t in items:
        if not isinstance(t, (TransformStamped, dict)):
            raise TypeError(f"send_transform takes TransformStamped (or a list of them), got {type(t).__name__}")
    return items


class TransformBroadcaster:
    """send_transform(one or many) publishes one TFMessage on ``tf`` (relative to the node namespace)."""

    def __init__(self, node: Node, topic: str = "tf", qos: int = 100) -> None:
        self.node = node
        self._pub = node.create_publisher(topic, TFMessage, qos)
        self._encode_tf = node.wire.encode_tf  # msgpack (zentf) or CDR (ros2)
        if type(self).send_transform is _send_transform:
            # the common call, one TransformStamped, compiled from here to Zenoh's put where the wire has
            # such a sender (zentf/transport/ingest/tf_encoder.pyx); anything else reaches the method below
            fast = self._pub.compiled_tf_sender(self.send_transform)
            if fast is not None:
                self.send_transform = self.sendTransform = fast  # type: ignore[method-assign]

    def send_transform(self, transform: TransformsArg) -> None:
        self._pub.publish_bytes(self._encode_tf(_as_list(transform)))

    sendTransform = send_transform

    def wait_for_subscribers(self, timeout: float = 5.0) -> bool:
        return self._pub.wait_for_subscribers(timeout)


_send_transform = TransformBroadcaster.send_transform


class StaticTransformBroadcaster:
    """Latched ``tf_static``: re-sending a child frame replaces it, others accumulate; the whole set is
    republished each time so late joiners get everything (tf2 C++ semantics)."""

    def __init__(self, node: Node, topic: str = "tf_static", qos: int = 1) -> None:
        self.node = node
        self._pub = node.create_publisher(topic, TFMessage, qos, latched=True)
        self._by_child: dict[str, Any] = {}
        self._lock = threading.Lock()

    def send_transform(self, transform: TransformsArg) -> None:
        items = _as_list(transform)
        with self._lock:
            for t in items:
                child = t["child_frame_id"] if isinstance(t, dict) else t.child_frame_id
                self._by_child[child] = t
            payload = self.node.wire.encode_tf(list(self._by_child.values()))
            self._pub.publish_bytes(payload)

    sendTransform = send_transform

    @property
    def transforms(self) -> list:
        with self._lock:
            return list(self._by_child.values())
