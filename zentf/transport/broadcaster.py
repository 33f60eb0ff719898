"""TransformBroadcaster (``tf``) and StaticTransformBroadcaster (latched ``tf_static``)."""
from __future__ import annotations

import threading
from collections.abc import Iterable
from typing import Any, Union

from ..core.messages import TFMessage, TransformStamped
from .node import Node
from .wire.profiles import Ros2Profile
from .ingest.tf_encoder import OneTransformSender, OneTransformSenderCdr

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
        att = self._pub._const_attachment
        if node.wire.name == "zentf" and att is not None and type(self).send_transform is _send_transform:
            # the common call, one TransformStamped on zentf's wire, compiled from here to Zenoh's put
            # (zentf/transport/ingest/tf_encoder.pyx); anything else reaches the method below
            slow = self.send_transform
            self.send_transform = self.sendTransform = OneTransformSender(  # type: ignore[method-assign]
                self._pub._pub.put, att, slow)
        elif isinstance(node.wire, Ros2Profile) and type(node.wire).encode_tf is Ros2Profile.encode_tf \
                and type(self).send_transform is _send_transform and isinstance(getattr(self._pub._attach, "gid", None), bytes):
            # ROS 2's wire: the CDR payload and rmw_zenoh's attachment (the publisher's own sequence) in C
            slow = self.send_transform
            self.send_transform = self.sendTransform = OneTransformSenderCdr(  # type: ignore[method-assign]
                self._pub._pub.put, self._pub._attach.seq, self._pub._attach.gid, slow)

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
