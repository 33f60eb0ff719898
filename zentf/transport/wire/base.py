"""The wire profile interface: everything that differs between the wires a node can speak on Zenoh.

A node chooses one profile (``--wire`` / ``ZENTF_WIRE``) and every publisher, subscription, raw
subscription, service server and client, graph token and listener of it asks the profile, never the
profile's name: which key a topic or service lives on, how payloads are written and read, what the
attachment of a sample carries, how a graph token looks and what it says, what a session needs. Two
siblings implement it: ``ZentfProfile`` (zentf's own msgpack wire, ``zentf_wire.py``, docs/protocol.md)
and ``Ros2Profile`` (rmw_zenoh's, ``ros2.py``, docs/ros2.md); ``make_profile`` (``profiles.py``) picks one.

Callers hold a profile per node (``node.wire``); a profile keeps only caches of its own (key strings,
per-node ids), never state of the objects it is given.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ...core.messages import Message
from ..names import fully_qualified_node_name

__all__ = ["WireProfile", "Attacher", "GraphEntry"]


@dataclass(frozen=True)
class GraphEntry:
    """What one graph token says: kind is 'node', 'pub', 'sub', 'srv' (service server) or 'cli' (client)."""

    kind: str
    namespace: str
    name: str
    type_name: str = ""
    topic: str = ""

    @property
    def node(self) -> str:
        return fully_qualified_node_name(self.namespace, self.name)


class Attacher:
    """Makes the attachment of each sample (or request) one publisher (or client) sends."""

    #: the attachment when it is the same on every sample (zentf's: the node name), else None
    constant: bytes | None = None
    #: what ``WireProfile.sender_id`` reads back from this attacher's attachments: the sender's identity
    sender_id: bytes = b""

    def __call__(self) -> bytes:  # pragma: no cover - interface
        raise NotImplementedError


class WireProfile(ABC):
    """How a node's topics, payloads, attachments, services and graph tokens look on Zenoh."""

    #: the profile's name as ``--wire`` spells it (for messages; code asks the methods, not the name)
    name: str = ""
    #: ROS_DOMAIN_ID the profile's keys and tokens are scoped to (0 where the wire has no domains)
    domain_id: int = 0
    #: the serialization of payloads, as MCAP names message encodings ('msgpack', 'cdr'): code that
    #: writes or reads payload bytes itself (compiled encoders, bag writers) checks it
    payload_format: str = ""
    #: the authority every received transform gets when the wire carries no sender name, else None
    fixed_authority: str | None = None
    #: attachment bytes -> the sending publisher's identity (for per-sender queues); None when the bytes
    #: are the identity themselves (saves a call per message on the listener's thread)
    sender_of: Callable[[bytes], bytes] | None = None
    #: whether a service call's selector may carry parameters (``deadline_ms``: when its caller gives up);
    #: False where the other side's servers are not zentf's (rmw_zenoh's)
    query_parameters: bool = False
    #: ``check_tf_encoding(encoding)`` raises ValueError when a sample's encoding names another type than
    #: TFMessage; None when the wire carries the type in the key (the listener then never reads it)
    check_tf_encoding: Callable[[Any], None] | None = None

    # ---- keys
    @abstractmethod
    def data_key(self, fq_topic: str, type_name: str | None) -> str:
        """Key of a topic's samples of one type (any type when ``type_name`` is None); ValueError when the
        type cannot travel on this wire."""

    @abstractmethod
    def topic_of_key(self, key: str) -> tuple[str, str | None]:
        """(fully qualified topic, type name if the key carries it) of a data key."""

    @abstractmethod
    def service_key(self, fq_service: str, srv_type: str) -> str:
        """Key of a service's queryable; UnknownTypeError when the wire cannot carry the service type."""

    @abstractmethod
    def encoding(self, type_name: str) -> Any:
        """The Zenoh encoding samples of a type carry (None: the wire sets none)."""

    @abstractmethod
    def encoded_type(self, encoding: Any) -> str | None:
        """The type name a sample's (or query's) encoding states, None when it states none."""

    def sample_type(self, key: str, encoding: Any) -> str | None:
        """The type a received sample carries: in its encoding or in its key; None if neither says."""
        return self.encoded_type(encoding) or self.topic_of_key(key)[1]

    # ---- payloads
    @abstractmethod
    def encode(self, msg: Message | dict, type_name: str = "") -> bytes:
        """A message (or its plain-dict form, typed by ``type_name``) -> payload; TypeError says why not."""

    @abstractmethod
    def encode_tf(self, transforms: Any) -> bytes:
        """A TFMessage payload from TransformStamped objects or plain dicts."""

    @abstractmethod
    def decode(self, payload: bytes, encoding: Any, key: str, msg_type: type[Message] | None) -> Any:
        """Payload -> message (any type when msg_type is None); ValueError says what was wrong."""

    @abstractmethod
    def decode_any(self, payload: bytes, encoding: Any, key: str) -> tuple[str | None, Any, bool]:
        """(type name, value, known format) for generic tools; the raw bytes when the format is unknown."""

    @abstractmethod
    def decode_clock(self, payload: bytes, key: str) -> tuple[Any, Any]:
        """(sec, nanosec) of a rosgraph_msgs/Clock payload, unchecked; ValueError (or any error) if unreadable."""

    @abstractmethod
    def ingest_tf(self, payload: bytes, core: Any, authority: str, is_static: bool) -> tuple[int, int, int, str | None]:
        """Decode a TFMessage into ``core`` (set_transforms_raw): (accepted, rejected, malformed, first problem);
        ValueError when the payload is not a TFMessage at all."""

    @abstractmethod
    def tf_ingest(self, target: Any, buffer: Any, now_ns: Callable[[], int] | None, tolerance_ns: int,
                  is_static: bool) -> Any:
        """A listener topic's compiled ``ingest(payload, authority)`` into ``target`` (zentf/transport/ingest),
        with the future guard's clock (``now_ns`` None: no guard); ``ingest_tf`` is its slow path."""

    def one_transform_sender(self, put: Callable[..., Any], attacher: Attacher,
                             fallback: Callable[[Any], None]) -> Callable[[Any], None] | None:
        """A compiled ``send_transform`` for one TransformStamped straight to ``put`` with the attachments
        ``attacher`` makes (anything else to ``fallback``), or None when the wire has none (the
        broadcaster's Python method is then used)."""
        return None

    # ---- attachments
    @abstractmethod
    def attacher(self, node: Any, token_key: str) -> Attacher:
        """The attachment maker of one publisher (or client) of ``node`` whose graph token is ``token_key``."""

    @abstractmethod
    def attachment_for(self, attacher: Attacher, authority: str) -> bytes:
        """The attachment of a sample republished on behalf of ``authority`` (a bag player's recorded
        sender), where the wire carries one; else the attacher's own."""

    @abstractmethod
    def authority(self, attachment: Any, fallback: str) -> str:
        """The sender's name for logs and tf authorities (``fallback`` when the attachment names none)."""

    def sender_id(self, attachment: bytes) -> bytes:
        """The sending publisher's identity in an attachment (``Attacher.sender_id`` of its attacher)."""
        return attachment if self.sender_of is None else self.sender_of(attachment)

    # ---- diagnostics: who sent a sample (tf doctor, tf monitor)
    @abstractmethod
    def publisher_of(self, attachment: Any) -> tuple[str, int | None] | None:
        """(the publisher that sent a sample, its clock when it sent in ns if the attachment says), from the
        attachment (bytes or Zenoh's); None when it names no publisher. zentf names a publisher by its node's
        name; ROS 2 by its GID in hex, which ``token_publisher`` reads from the graph's tokens."""

    def token_publisher(self, key: str) -> str | None:
        """The publisher (as ``publisher_of`` names it) a graph token announces, when that is not its node's
        name; None when it is, or when the key is no publisher's token."""
        return None

    def token_session(self, key: str) -> str:
        """The Zenoh session id a graph token names; '' when the wire's tokens name none."""
        return ""

    def publisher_label(self, publisher: str) -> str:
        """How a line names a publisher ``publisher_of`` gave whose node the graph does not know."""
        return publisher

    # ---- publishers
    @abstractmethod
    def latched_history(self, depth: int) -> int:
        """Samples a latched publisher with history ``depth`` keeps for late joiners."""

    def latched_publisher_options(self) -> dict[str, Any]:
        """Extra arguments of a latched (advanced) publisher on this wire."""
        return {}

    # ---- services
    @abstractmethod
    def service_query_options(self) -> dict[str, Any]:
        """Zenoh ``target`` and ``consolidation`` of a client's queries."""

    @abstractmethod
    def request_caller(self, attachment: Any) -> tuple[str, Any]:
        """(caller's name for logs, reply context) of a request; ValueError when the wire requires an
        attachment the request lacks."""

    @abstractmethod
    def decode_request(self, payload: bytes, encoding: Any, key: str, request_type: type[Message]) -> Message:
        """A service request received on ``key``; ValueError says what was wrong."""

    @abstractmethod
    def decode_response(self, payload: bytes, encoding: Any, response_type: type[Message]) -> Message:
        """A service response; ValueError says what was wrong."""

    @abstractmethod
    def reply(self, query: Any, payload: bytes, context: Any, response_type: str) -> None:
        """Answer a query with an encoded response (``context`` from ``request_caller``)."""

    @abstractmethod
    def check_reply(self, attachment: Any, request_attachment: bytes) -> None:
        """ValueError when a reply does not answer the request that carried ``request_attachment``."""

    # ---- graph
    @abstractmethod
    def node_token(self, node: Any) -> str:
        """The liveliness token announcing ``node``."""

    @abstractmethod
    def entity_token(self, node: Any, kind: str, fq_topic: str, type_name: str, key: str, *,
                     depth: int, latched: bool = False) -> str:
        """The token of a publisher ('pub'), subscriber ('sub'), server ('srv') or client ('cli') of
        ``node``; '' when the wire cannot announce it (e.g. a subscriber of any type on ROS 2)."""

    @abstractmethod
    def liveliness_selector(self, namespace: str | None) -> str:
        """Selector of the graph tokens (of one namespace, or all with None; callers filter ``parse_token``'s
        entries by namespace too)."""

    @abstractmethod
    def parse_token(self, key: str) -> GraphEntry | None:
        """A token key -> what it says; None for keys that are not this wire's tokens."""

    @abstractmethod
    def unique_name_selector(self, namespace: str, name: str) -> str | None:
        """Selector of live nodes a new node of this name would clash with; None when the wire allows
        duplicate names (ROS 2 does)."""

    # ---- sessions
    def session_defaults(self, zenoh_options: Any) -> Any:
        """The Zenoh options a node's own session opens with on this wire."""
        return zenoh_options

    def __eq__(self, other: object) -> bool:
        """Two profiles are one wire when they are of one kind on one domain (their keys and tokens meet)."""
        return type(other) is type(self) and other.domain_id == self.domain_id  # type: ignore[attr-defined]

    def __hash__(self) -> int:
        return hash((type(self), self.domain_id))

    def __repr__(self) -> str:
        return f"{type(self).__name__}(domain_id={self.domain_id})"
