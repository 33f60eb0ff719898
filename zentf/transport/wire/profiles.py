"""Wire profiles: how a node's topics, payloads, attachments and graph tokens look on Zenoh.

Chosen once per Node (``--wire`` / ``ZENTF_WIRE``): ``zentf`` (the default: msgpack, ``@zentf`` tokens,
see docs/protocol.md) or ``ros2``, which speaks rmw_zenoh's format so zentf and ROS 2 (Jazzy, Kilted,
Rolling with ``RMW_IMPLEMENTATION=rmw_zenoh_cpp``) see each other (docs/ros2.md):

- data key ``<ROS_DOMAIN_ID>/<topic without leading '/'>/<DDS type>/<RIHS01 hash>``;
- payload CDR (XCDR1 little-endian, header ``00 01 00 00``), no Zenoh encoding (rmw_zenoh sets none);
- attachment on every sample, zenoh-ext serialized: int64 sequence number (per publisher, from 1),
  int64 source timestamp (ns), 16-byte GID (rmw_zenoh >= Jazzy 0.2.4 / Kilted 0.6.0 / Rolling); the
  older string-keyed layout of Jazzy 0.2.0-0.2.3 is read too;
- liveliness ``@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS>/<enclave>/<ns>/<node>
  [/<topic>/<DDS type>/<hash>/<qos>]`` with '/' mangled to '%' and rmw_zenoh's compact QoS string;
- transient local (latched) topics through zenoh-ext advanced publishers/subscribers, as rmw_zenoh does;
- services as rmw_zenoh's: a complete queryable on ``<domain>/<service>/<DDS service type>/<RIHS01 hash of
  the service type>``, CDR request and response, the request's attachment (sequence number, time, client
  GID) and the reply's (same sequence number and GID, the server's time), ``SS``/``SC`` tokens.
"""
from __future__ import annotations

import itertools
import os
import struct
import time
from typing import Any

from . import codec as wire
from ...core.messages import Message, TFMessage
from ..graph import GraphEntry
from ..names import encode_chunk, key_to_topic, normalize_namespace, topic_to_key
from ...ros import CdrError, UnknownTypeError, dds_type_name, ros_type_name, tf_samples, type_hash
from ...ros import codec as cdr_codec
from ...ros.tf import encode_tf as cdr_encode_tf

from ..ingest.decoders import cdr_tf  # the compiled decoder (zentf/transport/ingest/decoders.pyx)
from ..ingest.handler import SenderTail

__all__ = ["WireProfile", "ZentfProfile", "Ros2Profile", "make_profile", "PROFILES", "qos_string",
           "parse_ros2_token", "ros2_attachment", "parse_ros2_attachment", "ROS2_DEFAULT_DEPTH",
           "ROS2_AUTHORITY", "ROS2_ROUTER", "ROS2_SERVICE_DEPTH", "ROS2_PARAMETER_SERVICE_DEPTH",
           "zentf_node_token", "zentf_entity_token"]

PROFILES = ("zentf", "ros2")
#: rmw_zenoh's default history depth: a depth equal to it is left out of the QoS string.
ROS2_DEFAULT_DEPTH = 42
#: History depth of rmw_qos_profile_services_default and of rmw_qos_profile_parameters (parameter services).
ROS2_SERVICE_DEPTH = 10
ROS2_PARAMETER_SERVICE_DEPTH = 1000
#: tf2_ros (ROS 2) cannot tell who sent a transform; its listener records this authority.
ROS2_AUTHORITY = "Authority undetectable"
#: Where a ROS 2 machine's rmw_zenohd router listens (DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5).
ROS2_ROUTER = "tcp/localhost:7447"
_ADMIN = "@ros2_lv"
_KINDS = {"node": "NN", "pub": "MP", "sub": "MS", "srv": "SS", "cli": "SC"}
_KIND_OF = {"NN": "node", "MP": "pub", "MS": "sub", "SS": "srv", "SC": "cli"}


def zentf_node_token(namespace: str, name: str) -> str:
    """``@zentf/node/<ns>/<name>`` (docs/protocol.md)."""
    return f"@zentf/node/{encode_chunk(namespace)}/{name}"


def zentf_entity_token(kind: str, namespace: str, name: str, type_name: str, key: str) -> str:
    """``@zentf/<pub|sub>/<ns>/<name>/<type>/<key>`` (docs/protocol.md)."""
    return f"@zentf/{kind}/{encode_chunk(namespace)}/{name}/{encode_chunk(type_name)}/{key}"


class WireProfile:
    """zentf's own wire format (msgpack payloads, node name as attachment, ``@zentf`` tokens)."""

    name = "zentf"
    domain_id = 0

    # ---- keys
    def data_key(self, fq_topic: str, type_name: str | None) -> str:
        """Key of a topic (a subscriber's key for any type when ``type_name`` is None)."""
        return topic_to_key(fq_topic)

    def topic_of_key(self, key: str) -> tuple[str, str | None]:
        """(fully qualified topic, type name if the key carries it) of a data key."""
        return key_to_topic(key), None

    def encoding(self, type_name: str) -> Any:
        return wire.encoding_for(type_name)

    def service_key(self, fq_service: str, srv_type: str) -> str:
        """Key of a service's queryable: the resolved name, as a topic's."""
        return topic_to_key(fq_service)

    # ---- payloads
    def encode(self, msg: Message | dict, type_name: str = "") -> bytes:
        return wire.encode(msg)

    def encode_tf(self, transforms: Any) -> bytes:
        return wire.encode_tf(transforms)

    def decode(self, payload: bytes, encoding: str, key: str, msg_type: type[Message] | None) -> Any:
        """Bytes -> message (any type when msg_type is None); ValueError says what was wrong."""
        type_name = wire.type_name_from_encoding(encoding)
        if msg_type is None:
            return wire.decode_any(payload, encoding)[1]
        if type_name is not None and type_name != msg_type.TYPE_NAME:
            raise ValueError(f"wrong type {type_name}, expected {msg_type.TYPE_NAME}")
        return wire.decode(payload, msg_type)

    def decode_any(self, payload: bytes, encoding: str, key: str) -> tuple[str | None, Any, bool]:
        """(type name, value, known format) for generic tools."""
        known = str(encoding).startswith(wire.ENCODING)
        type_name, value = wire.decode_any(payload, encoding)
        return type_name, value, known

    #: (payload, core, authority, is_static) -> (accepted, rejected, malformed, problem); wire.ingest_tf
    #: itself, not a method around it (one call less per message on the listener's thread)
    ingest_tf = staticmethod(wire.ingest_tf)

    def check_tf_encoding(self, encoding: Any) -> None:
        type_name = wire.type_name_from_encoding(encoding)
        if type_name is not None and type_name != TFMessage.TYPE_NAME:
            raise ValueError(f"wrong type {type_name}, expected {TFMessage.TYPE_NAME}")

    # ---- attachments
    def attacher(self, node: Any, token_key: str) -> "Attacher":
        return _ConstAttacher(node.get_fully_qualified_name().encode())

    def authority(self, attachment: Any, fallback: str) -> str:
        return wire.authority_of(attachment, fallback)

    #: Attachment bytes -> the sending publisher's identity, for per-sender queues; None: the bytes are it
    #: (zentf's attachment is the sender's node name).
    sender_of: Any = None

    # ---- graph
    def node_token(self, node: Any) -> str:
        return zentf_node_token(node._namespace, node.get_name())

    def entity_token(self, node: Any, kind: str, fq_topic: str, type_name: str, key: str, *,
                     depth: int = ROS2_DEFAULT_DEPTH, latched: bool = False) -> str:
        return zentf_entity_token(kind, node._namespace, node.get_name(), type_name, key)

    def liveliness_selector(self, namespace: str | None) -> str:
        from ..graph import _selector

        return _selector(namespace)

    def parse_token(self, key: str) -> GraphEntry | None:
        from ..graph import parse_token

        return parse_token(key)

    # ---- sessions
    def session_defaults(self, zenoh_options: Any) -> Any:
        return zenoh_options


ZentfProfile = WireProfile


class Attacher:
    """Makes the attachment of each sample a publisher sends."""

    #: the attachment when it is the same for every sample (zentf's: the node name), else None
    constant: bytes | None = None

    def __call__(self) -> bytes:  # pragma: no cover - interface
        raise NotImplementedError


class _ConstAttacher(Attacher):
    __slots__ = ("constant",)

    def __init__(self, value: bytes) -> None:
        self.constant = value

    def __call__(self) -> bytes:
        return self.constant


_ATT = struct.Struct("<qqB16s")


def ros2_attachment(sequence_number: int, source_timestamp_ns: int, gid: bytes) -> bytes:
    """rmw_zenoh's attachment: zenoh-ext serialization of (int64, int64, uint8[16]) = 33 bytes."""
    return _ATT.pack(sequence_number, source_timestamp_ns, 16, gid)


_KEYED = (b"\x0fsequence_number", b"\x10source_timestamp", b"\x0asource_gid")


def parse_ros2_attachment(raw: bytes) -> tuple[int, int, bytes]:
    """(sequence number, source timestamp, gid) of either rmw_zenoh layout; ValueError if neither."""
    if len(raw) == 33 and raw[16] == 16:
        seq, ts, _, gid = _ATT.unpack(raw)
        return seq, ts, gid
    if raw.startswith(_KEYED[0]):  # Jazzy 0.2.0-0.2.3: "name", value, ... with zenoh-ext strings
        off = len(_KEYED[0])
        (seq,) = struct.unpack_from("<q", raw, off)
        off += 8
        if raw[off:off + len(_KEYED[1])] == _KEYED[1]:
            off += len(_KEYED[1])
            (ts,) = struct.unpack_from("<q", raw, off)
            off += 8
            if raw[off:off + len(_KEYED[2])] == _KEYED[2] and raw[off + len(_KEYED[2])] == 16:
                off += len(_KEYED[2]) + 1
                gid = raw[off:off + 16]
                if len(gid) == 16:
                    return seq, ts, gid
    raise ValueError(f"not an rmw_zenoh attachment ({len(raw)} bytes)")


class _Ros2Attacher(Attacher):
    """Per publisher: sequence number from 1, source timestamp, GID (XXH3-128 of the token, as
    rmw_zenoh computes it when the xxhash module is there, else random)."""

    __slots__ = ("gid", "seq")

    def __init__(self, token_key: str) -> None:
        self.gid = _gid_of(token_key)
        self.seq = itertools.count(1)  # next() on a count is atomic under the GIL: no lock needed

    def __call__(self) -> bytes:
        return _ATT.pack(next(self.seq), time.time_ns(), 16, self.gid)


def _gid_of(token_key: str) -> bytes:
    try:
        import xxhash
    except ImportError:
        return os.urandom(16)
    # rmw_zenoh: memcpy(gid, &low64, 8); memcpy(gid + 8, &high64, 8) -> the 128-bit value little-endian
    return xxhash.xxh3_128_digest(token_key.encode())[::-1]


def qos_string(*, depth: int = ROS2_DEFAULT_DEPTH, latched: bool = False, best_effort: bool = False) -> str:
    """rmw_zenoh's compact QoS: '<rel>:<dur>:<hist>,<depth>:<deadline>:<lifespan>:<liveliness>',
    each part empty when it equals the default (reliable, volatile, keep last 42, infinite durations)."""
    rel = "2" if best_effort else ""
    dur = "1" if latched else ""
    dep = "" if depth == ROS2_DEFAULT_DEPTH else str(depth)
    return f"{rel}:{dur}:,{dep}:,:,:,,"


_ids = itertools.count(0)  # rmw_zenoh numbers nodes and entities per context; one context per process here


def _mangle(text: str) -> str:
    return text.replace("/", "%")


def parse_ros2_token(key: str) -> GraphEntry | None:
    """An ``@ros2_lv`` token -> GraphEntry (node, pub, sub, srv or cli), None if not one."""
    parts = str(key).split("/")
    if len(parts) < 9 or parts[0] != _ADMIN:
        return None
    kind = _KIND_OF.get(parts[5])
    if kind is None:
        return None
    try:
        ns = normalize_namespace(parts[7].replace("%", "/"))
    except ValueError:
        return None
    name = parts[8].replace("%", "/")
    if kind == "node":
        return GraphEntry("node", ns, name)
    if len(parts) < 13:
        return None
    topic = parts[9].replace("%", "/")
    return GraphEntry(kind, ns, name, ros_type_name(parts[10]), topic if topic.startswith("/") else "/" + topic)


class Ros2Profile(WireProfile):
    """rmw_zenoh's wire format (see the module docstring)."""

    name = "ros2"

    def __init__(self, domain_id: int = 0) -> None:
        self.domain_id = int(domain_id)
        self._keys: dict[tuple[str, str | None], str] = {}

    def data_key(self, fq_topic: str, type_name: str | None) -> str:
        k = self._keys.get((fq_topic, type_name))
        if k is None:
            topic = topic_to_key(fq_topic)
            if type_name is None:
                k = f"{self.domain_id}/{topic}/*/*"
            else:
                try:
                    k = f"{self.domain_id}/{topic}/{dds_type_name(type_name)}/{type_hash(type_name)}"
                except UnknownTypeError:
                    raise ValueError(f"no ROS 2 definition for {type_name}: it cannot travel with --wire ros2") from None
            self._keys[(fq_topic, type_name)] = k
        return k

    def service_key(self, fq_service: str, srv_type: str) -> str:
        """``<domain>/<service>/<DDS service type>/<hash of the service type>`` (rmw_zenoh's service key);
        UnknownTypeError when zentf has no .srv definition of the type."""
        k = self._keys.get((fq_service, "srv:" + srv_type))
        if k is None:
            try:
                k = f"{self.domain_id}/{topic_to_key(fq_service)}/{dds_type_name(srv_type)}/{type_hash(srv_type)}"
            except (UnknownTypeError, ValueError):
                raise UnknownTypeError(f"no ROS 2 definition for {srv_type}") from None
            self._keys[(fq_service, "srv:" + srv_type)] = k
        return k

    def topic_of_key(self, key: str) -> tuple[str, str | None]:
        parts = str(key).split("/")
        if len(parts) >= 4 and parts[-1].startswith("RIHS"):
            return "/" + "/".join(parts[1:-2]), ros_type_name(parts[-2])
        return "/" + "/".join(parts[1:]), None

    def encoding(self, type_name: str) -> Any:
        return None

    def encode(self, msg: Message | dict, type_name: str = "") -> bytes:
        try:
            return cdr_codec.encode(msg, type_name or None)
        except CdrError as e:
            raise TypeError(str(e)) from None

    def encode_tf(self, transforms: Any) -> bytes:
        return cdr_encode_tf(transforms)

    def decode(self, payload: bytes, encoding: str, key: str, msg_type: type[Message] | None) -> Any:
        _, type_name = self.topic_of_key(key)
        if msg_type is not None:
            if type_name is not None and type_name != msg_type.TYPE_NAME:
                raise ValueError(f"wrong type {type_name}, expected {msg_type.TYPE_NAME}")
            return cdr_codec.decode(payload, msg_type.TYPE_NAME)
        if type_name is None:
            raise ValueError(f"key {key} names no ROS 2 type")
        return cdr_codec.decode(payload, type_name)

    def decode_any(self, payload: bytes, encoding: str, key: str) -> tuple[str | None, Any, bool]:
        _, type_name = self.topic_of_key(key)
        if type_name is None or not cdr_codec.is_known(type_name):
            return type_name, payload, False
        return type_name, cdr_codec.decode(payload, type_name), True

    def ingest_tf(self, payload: bytes, core: Any, authority: str, is_static: bool) -> tuple[int, int, int, str | None]:
        # compiled; None (anything doubtful) sends the payload to tf_samples, which names the problem
        samples = cdr_tf(payload)
        if samples is None:
            samples, malformed, problem = tf_samples(payload)
            return wire.insert_samples(samples, core, authority, is_static, malformed, problem)
        return wire.insert_samples(samples, core, authority, is_static)

    def check_tf_encoding(self, encoding: Any) -> None:
        return None  # the type is in the key: a subscriber only ever gets TFMessages

    def attacher(self, node: Any, token_key: str) -> Attacher:
        return _Ros2Attacher(token_key)

    def authority(self, attachment: Any, fallback: str) -> str:
        return ROS2_AUTHORITY  # as tf2_ros in ROS 2 (ROS 1 used the sender's node name)

    #: The publisher GID of an attachment (after its sequence number, time and the GID's length 16, which
    #: change with every sample or say nothing); read in C by the listener's thread.
    sender_of = SenderTail(33, 16, 16)

    def _node_part(self, node: Any, entity_id: int) -> str:
        return f"{_ADMIN}/{self.domain_id}/{node.session.info.zid()}/{node._ros2_id}/{entity_id}"

    def node_token(self, node: Any) -> str:
        if getattr(node, "_ros2_id", None) is None:
            node._ros2_id = next(_ids)
        ns = "/" + node._namespace if node._namespace else "/"
        return f"{self._node_part(node, node._ros2_id)}/NN/%/{_mangle(ns)}/{node.get_name()}"

    def entity_token(self, node: Any, kind: str, fq_topic: str, type_name: str, key: str, *,
                     depth: int = ROS2_DEFAULT_DEPTH, latched: bool = False) -> str:
        if not type_name:  # a token holds no wildcard: an any-type subscriber stays unlisted
            return ""
        if getattr(node, "_ros2_id", None) is None:
            node._ros2_id = next(_ids)
        ns = "/" + node._namespace if node._namespace else "/"
        dds = dds_type_name(type_name)
        hsh = type_hash(type_name)
        return (f"{self._node_part(node, next(_ids))}/{_KINDS[kind]}/%/{_mangle(ns)}/{node.get_name()}/"
                f"{_mangle(fq_topic)}/{dds}/{hsh}/{qos_string(depth=depth, latched=latched)}")

    def liveliness_selector(self, namespace: str | None) -> str:
        return f"{_ADMIN}/{self.domain_id}/**"

    def parse_token(self, key: str) -> GraphEntry | None:
        e = parse_ros2_token(key)
        if e is None or str(key).split("/")[1] != str(self.domain_id):
            return None
        return e

    def session_defaults(self, zenoh_options: Any) -> Any:
        """A ROS 2 machine's session: peer, connected to rmw_zenohd on localhost:7447, no multicast
        (only where nothing was given: flags, env vars and config files win)."""
        z = zenoh_options
        if z.config_file or z.connect or z.mode:
            return z
        from dataclasses import replace

        return replace(z, connect=[ROS2_ROUTER], mode="peer", no_multicast=True)


def make_profile(wire_name: str | None = None, domain_id: int | str | None = None) -> WireProfile:
    """The profile by name ('zentf' default, 'ros2'); ValueError names a bad name or domain."""
    name = (wire_name or "zentf").strip().lower()
    if name == "zentf":
        return WireProfile()
    if name != "ros2":
        raise ValueError(f"unknown wire profile {wire_name!r} (choose zentf or ros2)")
    try:
        dom = int(domain_id) if domain_id not in (None, "") else 0
    except (TypeError, ValueError):
        raise ValueError(f"ROS_DOMAIN_ID must be an integer 0-232, got {domain_id!r}") from None
    if not 0 <= dom <= 232:
        raise ValueError(f"ROS_DOMAIN_ID must be an integer 0-232, got {dom}")
    return Ros2Profile(dom)

