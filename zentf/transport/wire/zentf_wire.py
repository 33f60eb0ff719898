"""zentf's own wire (the default profile): msgpack payloads labelled with their type, the sender's node
name as attachment, ``@zentf`` graph tokens (docs/protocol.md).

- data key: the resolved topic without its leading '/' (``/robot1/tf`` -> ``robot1/tf``), any type;
- payload: msgpack of the message's plain-dict form (``codec``), encoding ``application/msgpack;<type>``;
- attachment: the publishing node's fully qualified name (the tf authority);
- services: a complete queryable on the service's key, msgpack request and response, the caller's name
  as the request's attachment;
- tokens (``<ns>`` and ``<type>`` squeezed into one chunk: ``%`` root, ``%a%b`` for ``a/b``):
  ``@zentf/node/<ns>/<name>`` and ``@zentf/<pub|sub|srv|cli>/<ns>/<name>/<type>/<key...>``.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from . import codec as wire
from .base import Attacher, GraphEntry, WireProfile
from ...core.messages import Message, TFMessage
from ..names import decode_chunk, encode_chunk, key_to_topic, normalize_namespace, topic_to_key
from ..ingest.handler import TfIngest
from ..ingest.tf_encoder import OneTransformSender

__all__ = ["ZentfProfile", "PREFIX", "node_token", "entity_token", "parse_token", "selector"]

_TF = TFMessage.TYPE_NAME

#: the first chunk of every zentf graph token
PREFIX = "@zentf"


def node_token(namespace: str, name: str) -> str:
    """``@zentf/node/<ns>/<name>``."""
    return f"{PREFIX}/node/{encode_chunk(namespace)}/{name}"


def entity_token(kind: str, namespace: str, name: str, type_name: str, key: str) -> str:
    """``@zentf/<pub|sub|srv|cli>/<ns>/<name>/<type>/<key>``."""
    return f"{PREFIX}/{kind}/{encode_chunk(namespace)}/{name}/{encode_chunk(type_name)}/{key}"


def parse_token(key: str) -> GraphEntry | None:
    """A zentf token key -> GraphEntry; None for keys that are not zentf tokens."""
    parts = str(key).split("/")
    if len(parts) < 4 or parts[0] != PREFIX:
        return None
    kind = parts[1]
    ns = decode_chunk(parts[2])
    if kind == "node" and len(parts) == 4:
        return GraphEntry("node", ns, parts[3])
    if kind in ("pub", "sub", "srv", "cli") and len(parts) >= 6:
        return GraphEntry(kind, ns, parts[3], decode_chunk(parts[4]), key_to_topic("/".join(parts[5:])))
    return None


def selector(namespace: str | None) -> str:
    """Every zentf token (namespace None), or those of one namespace (not its children)."""
    if namespace is None:
        return f"{PREFIX}/**"
    return f"{PREFIX}/*/{encode_chunk(normalize_namespace(namespace))}/**"


class _ConstAttacher(Attacher):
    """zentf's attachment: the node's name, the same on every sample."""

    __slots__ = ("constant", "sender_id")

    def __init__(self, value: bytes) -> None:
        self.constant = self.sender_id = value

    def __call__(self) -> bytes:
        return self.constant


class ZentfProfile(WireProfile):
    """zentf's own wire (see the module docstring)."""

    name = "zentf"
    payload_format = "msgpack"
    query_parameters = True

    # ---- keys
    def data_key(self, fq_topic: str, type_name: str | None) -> str:
        return topic_to_key(fq_topic)

    def topic_of_key(self, key: str) -> tuple[str, str | None]:
        return key_to_topic(key), None

    def service_key(self, fq_service: str, srv_type: str) -> str:
        """The resolved name, as a topic's."""
        return topic_to_key(fq_service)

    def encoding(self, type_name: str) -> Any:
        return wire.encoding_for(type_name)

    def encoded_type(self, encoding: Any) -> str | None:
        return wire.type_name_from_encoding(encoding)

    # ---- payloads
    def encode(self, msg: Message | dict, type_name: str = "") -> bytes:
        return wire.encode(msg)

    def encode_tf(self, transforms: Any) -> bytes:
        return wire.encode_tf(transforms)

    def decode(self, payload: bytes, encoding: Any, key: str, msg_type: type[Message] | None) -> Any:
        if msg_type is None:
            return wire.decode_any(payload, encoding)[1]
        type_name = self.encoded_type(encoding)
        if type_name is not None and type_name != msg_type.TYPE_NAME:
            raise ValueError(f"wrong type {type_name}, expected {msg_type.TYPE_NAME}")
        return wire.decode(payload, msg_type)

    def decode_any(self, payload: bytes, encoding: Any, key: str) -> tuple[str | None, Any, bool]:
        known = str(encoding).startswith(wire.ENCODING)
        type_name, value = wire.decode_any(payload, encoding)
        return type_name, value, known

    def decode_clock(self, payload: bytes, key: str) -> tuple[Any, Any]:
        st = wire.unpack(payload)["clock"]  # the plain form read as it is: no message object per tick
        return st["sec"], st["nanosec"]

    #: wire.ingest_tf itself, not a method around it (one call less per message on the listener's thread)
    ingest_tf = staticmethod(wire.ingest_tf)  # type: ignore[assignment]

    def tf_ingest(self, target: Any, buffer: Any, now_ns: Callable[[], int] | None, tolerance_ns: int,
                  is_static: bool) -> Any:
        return TfIngest(False, wire.ingest_tf, target, buffer, now_ns, tolerance_ns, is_static)

    def check_tf_encoding(self, encoding: Any) -> None:  # type: ignore[override]
        type_name = wire.type_name_from_encoding(encoding)
        if type_name is not None and type_name != _TF:
            raise ValueError(f"wrong type {type_name}, expected {_TF}")

    def one_transform_sender(self, put: Callable[..., Any], attacher: Attacher,
                             fallback: Callable[[Any], None]) -> Callable[[Any], None] | None:
        if attacher.constant is None:
            return None
        import zenoh

        return OneTransformSender(put, zenoh.ZBytes(attacher.constant), fallback)  # the attachment made once

    # ---- attachments
    def attacher(self, node: Any, token_key: str) -> Attacher:
        return _ConstAttacher(node.get_fully_qualified_name().encode())

    def attachment_for(self, attacher: Attacher, authority: str) -> bytes:
        return authority.encode() if authority else attacher()

    def authority(self, attachment: Any, fallback: str) -> str:
        return wire.authority_of(attachment, fallback)

    # ---- diagnostics
    def publisher_of(self, attachment: Any) -> tuple[str, int | None] | None:
        name = wire.authority_of(attachment, "")
        return (name, None) if name else None

    # ---- publishers
    def latched_history(self, depth: int) -> int:
        return 1  # ROS 1 latching: the last message (a StaticTransformBroadcaster resends its whole set)

    def latched_publisher_options(self) -> dict[str, Any]:
        import zenoh.ext as zx

        # sequence numbers let a late joiner's subscriber order the history reply against live samples: a
        # reply that left the cache before a newer put never overwrites it (a re-sent static stays re-sent)
        return {"sample_miss_detection": zx.MissDetectionConfig(sporadic_heartbeat=0.5)}

    # ---- services
    def service_query_options(self) -> dict[str, Any]:
        import zenoh

        return {"target": zenoh.QueryTarget.BEST_MATCHING}

    def request_caller(self, attachment: Any) -> tuple[str, Any]:
        return wire.authority_of(attachment, "unknown caller"), None

    def decode_request(self, payload: bytes, encoding: Any, key: str, request_type: type[Message]) -> Message:
        """An empty payload is the default request (a bare ``get`` on the service's key)."""
        return self.decode(payload, encoding, key, request_type) if payload else request_type()

    def decode_response(self, payload: bytes, encoding: Any, response_type: type[Message]) -> Message:
        return self.decode(payload, encoding, "", response_type)

    def reply(self, query: Any, payload: bytes, context: Any, response_type: str) -> None:
        query.reply(query.key_expr, payload, encoding=wire.encoding_for(response_type))

    def check_reply(self, attachment: Any, request_attachment: bytes) -> None:
        return None  # one best-matching server answers each query

    # ---- graph
    def node_token(self, node: Any) -> str:
        return node_token(node.get_namespace(), node.get_name())

    def entity_token(self, node: Any, kind: str, fq_topic: str, type_name: str, key: str, *,
                     depth: int, latched: bool = False) -> str:
        return entity_token(kind, node.get_namespace(), node.get_name(), type_name, key)

    def liveliness_selector(self, namespace: str | None) -> str:
        return selector(namespace)

    def parse_token(self, key: str) -> GraphEntry | None:
        return parse_token(key)

    def unique_name_selector(self, namespace: str, name: str) -> str | None:
        return node_token(namespace, name)
