"""rmw_zenoh's wire (``--wire ros2``), so zentf and ROS 2 (Jazzy, Kilted, Rolling with
``RMW_IMPLEMENTATION=rmw_zenoh_cpp``) see each other (docs/ros2.md):

- data key ``<ROS_DOMAIN_ID>/<topic without leading '/'>/<DDS type>/<RIHS01 hash>``;
- payload CDR (XCDR1 little-endian, header ``00 01 00 00``), no Zenoh encoding (rmw_zenoh sets none);
- attachment on every sample, zenoh-ext serialized: int64 sequence number (per publisher, from 1),
  int64 source timestamp (ns), 16-byte GID (rmw_zenoh >= Jazzy 0.2.4 / Kilted 0.6.0 / Rolling); the
  older string-keyed layout of Jazzy 0.2.0-0.2.3 is read too;
- liveliness ``@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS|SS|SC>/<enclave>/<ns>/<node>
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
import weakref
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from . import codec as wire
from .base import Attacher, GraphEntry, WireProfile
from ...core.messages import Message
from ..names import normalize_namespace, topic_to_key
from ...ros import CdrError, UnknownTypeError, dds_type_name, ros_type_name, tf_samples, type_hash
from ...ros import codec as cdr_codec
from ...ros.tf import encode_tf as cdr_encode_tf
from ..ingest.decoders import cdr_tf  # the compiled decoder (zentf/transport/ingest/decoders.pyx)
from ..ingest.handler import SenderTail, TfIngest
from ..ingest.tf_encoder import OneTransformSenderCdr

__all__ = ["Ros2Profile", "qos_string", "parse_ros2_token", "ros2_attachment", "parse_ros2_attachment",
           "ROS2_DEFAULT_DEPTH", "ROS2_AUTHORITY", "ROS2_ROUTER", "ROS2_SERVICE_DEPTH",
           "ROS2_PARAMETER_SERVICE_DEPTH"]

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
_KIND_OF = {v: k for k, v in _KINDS.items()}

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


def _as_class(value: Any, cls: type[Message]) -> Any:
    """A decoded CDR value as the service's own class: the codec returns a plain dict for a type that has no
    registered class (one made from its definition, zentf.ros.classes), and handlers and callers get instances."""
    if isinstance(value, dict):
        try:
            return cls.from_dict(cdr_codec.fit_plain(cls, value))
        except (ValueError, TypeError) as e:
            raise CdrError(f"{cls.TYPE_NAME}: {e}") from None
    return value


def _raw(attachment: Any) -> bytes:
    return attachment.to_bytes() if hasattr(attachment, "to_bytes") else bytes(attachment)


class _Ros2Attacher(Attacher):
    """Per publisher (or client): sequence number from 1, source timestamp, GID (XXH3-128 of the token,
    as rmw_zenoh computes it when the xxhash module is there, else random)."""

    __slots__ = ("gid", "seq", "sender_id")

    def __init__(self, token_key: str) -> None:
        self.gid = self.sender_id = _gid_of(token_key)
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
    """rmw_zenoh's wire (see the module docstring)."""

    name = "ros2"
    payload_format = "cdr"
    fixed_authority = ROS2_AUTHORITY  # as tf2_ros in ROS 2 (ROS 1 used the sender's node name)
    check_tf_encoding = None  # the type is in the key: a subscriber only ever gets TFMessages

    def __init__(self, domain_id: int = 0) -> None:
        self.domain_id = int(domain_id)
        self._keys: dict[tuple[str, str | None], str] = {}
        self._types: dict[str, str | None] = {}  # data key -> type name, for raw samples
        #: rmw_zenoh's node id of each node this profile announced (the entity counter's first value)
        self._node_ids: "weakref.WeakKeyDictionary[Any, int]" = weakref.WeakKeyDictionary()

    # ---- keys
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

    def encoded_type(self, encoding: Any) -> str | None:
        return None

    def sample_type(self, key: str, encoding: Any) -> str | None:
        t = self._types.get(key, "")
        if t == "":
            t = self.topic_of_key(key)[1]
            if len(self._types) >= 4096:  # keys come from the network: stay bounded
                self._types.clear()
            self._types[key] = t
        return t

    # ---- payloads
    def encode(self, msg: Message | dict, type_name: str = "") -> bytes:
        try:
            return cdr_codec.encode(msg, type_name or None)
        except CdrError as e:
            raise TypeError(str(e)) from None

    def encode_tf(self, transforms: Any) -> bytes:
        return cdr_encode_tf(transforms)

    def decode(self, payload: bytes, encoding: Any, key: str, msg_type: type[Message] | None) -> Any:
        _, type_name = self.topic_of_key(key)
        if msg_type is not None:
            if type_name is not None and type_name != msg_type.TYPE_NAME:
                raise ValueError(f"wrong type {type_name}, expected {msg_type.TYPE_NAME}")
            return cdr_codec.decode(payload, msg_type.TYPE_NAME)
        if type_name is None:
            raise ValueError(f"key {key} names no ROS 2 type")
        return cdr_codec.decode(payload, type_name)

    def decode_any(self, payload: bytes, encoding: Any, key: str) -> tuple[str | None, Any, bool]:
        _, type_name = self.topic_of_key(key)
        if type_name is None or not cdr_codec.is_known(type_name):
            return type_name, payload, False
        return type_name, cdr_codec.decode(payload, type_name), True

    def decode_clock(self, payload: bytes, key: str) -> tuple[Any, Any]:
        st = cdr_codec.decode(payload, "rosgraph_msgs/msg/Clock").clock
        return st.sec, st.nanosec

    def ingest_tf(self, payload: bytes, core: Any, authority: str, is_static: bool) -> tuple[int, int, int, str | None]:
        # compiled; None (anything doubtful) sends the payload to tf_samples, which names the problem
        samples = cdr_tf(payload)
        if samples is None:
            samples, malformed, problem = tf_samples(payload)
            return wire.insert_samples(samples, core, authority, is_static, malformed, problem)
        return wire.insert_samples(samples, core, authority, is_static)

    def tf_ingest(self, target: Any, buffer: Any, now_ns: Callable[[], int] | None, tolerance_ns: int,
                  is_static: bool) -> Any:
        return TfIngest(True, self.ingest_tf, target, buffer, now_ns, tolerance_ns, is_static)

    def one_transform_sender(self, put: Callable[..., Any], attacher: Attacher,
                             fallback: Callable[[Any], None]) -> Callable[[Any], None] | None:
        # the CDR payload and rmw_zenoh's attachment (the publisher's own sequence) written in C; a
        # subclass that writes TFMessages its own way keeps its encode_tf
        if type(self).encode_tf is not Ros2Profile.encode_tf or not isinstance(attacher, _Ros2Attacher):
            return None
        return OneTransformSenderCdr(put, attacher.seq, attacher.gid, fallback)

    # ---- attachments
    def attacher(self, node: Any, token_key: str) -> Attacher:
        return _Ros2Attacher(token_key)

    def attachment_for(self, attacher: Attacher, authority: str) -> bytes:
        return attacher()  # ROS 2 carries no sender name: every sample is the republisher's own

    def authority(self, attachment: Any, fallback: str) -> str:
        return ROS2_AUTHORITY

    #: The publisher GID of an attachment (after its sequence number, time and the GID's length 16, which
    #: change with every sample or say nothing); read in C by the listener's thread.
    sender_of = SenderTail(33, 16, 16)

    # ---- diagnostics
    def publisher_of(self, attachment: Any) -> tuple[str, int | None] | None:
        if attachment is None:
            return None
        try:
            _, source_ns, gid = parse_ros2_attachment(_raw(attachment))
        except ValueError:  # a foreign attachment
            return None
        return gid.hex(), source_ns or None

    def token_publisher(self, key: str) -> str | None:
        """The GID of the publisher a token announces: XXH3-128 of the token key, as rmw_zenoh computes it
        (None without the xxhash module: a random GID would match nothing)."""
        if f"/{_KINDS['pub']}/" not in key:
            return None
        try:
            import xxhash
        except ImportError:
            return None
        return xxhash.xxh3_128_digest(key.encode())[::-1].hex()

    def token_session(self, key: str) -> str:
        parts = key.split("/")
        return parts[2] if len(parts) > 2 and parts[0] == _ADMIN else ""

    def publisher_label(self, publisher: str) -> str:
        return f"publisher gid {publisher}"

    # ---- publishers
    def latched_history(self, depth: int) -> int:
        return max(1, depth)  # TRANSIENT_LOCAL keeps the publisher's history depth

    def latched_publisher_options(self) -> dict[str, Any]:
        import zenoh.ext as zx

        # as rmw_zenoh's RELIABLE + TRANSIENT_LOCAL publishers
        return {"sample_miss_detection": zx.MissDetectionConfig(sporadic_heartbeat=0.5)}

    # ---- services
    def service_query_options(self) -> dict[str, Any]:
        import zenoh

        # rmw_zenoh: every complete queryable, no consolidation
        return {"target": zenoh.QueryTarget.ALL_COMPLETE, "consolidation": zenoh.ConsolidationMode.NONE}

    def request_caller(self, attachment: Any) -> tuple[str, Any]:
        try:
            seq, _, gid = parse_ros2_attachment(_raw(attachment) if attachment is not None else b"")
        except ValueError as e:
            raise ValueError(f"request without rmw_zenoh attachment ({e})") from None
        return f"client {gid.hex()}", (seq, gid)

    def decode_request(self, payload: bytes, encoding: Any, key: str, request_type: type[Message]) -> Message:
        return _as_class(cdr_codec.decode(payload, request_type.TYPE_NAME), request_type)  # the key names the type

    def decode_response(self, payload: bytes, encoding: Any, response_type: type[Message]) -> Message:
        return _as_class(cdr_codec.decode(payload, response_type.TYPE_NAME), response_type)

    def reply(self, query: Any, payload: bytes, context: Any, response_type: str) -> None:
        seq, gid = context  # rmw_zenoh's reply: no encoding; the request's sequence number and GID
        query.reply(query.key_expr, payload, attachment=ros2_attachment(seq, time.time_ns(), gid))

    def check_reply(self, attachment: Any, request_attachment: bytes) -> None:
        if attachment is None:
            return
        seq = int.from_bytes(request_attachment[:8], "little", signed=True)
        got = parse_ros2_attachment(_raw(attachment))[0]  # rmw_zenoh pairs reply and request by it
        if got != seq:
            raise ValueError(f"reply to request {got}, expected {seq}")

    # ---- graph
    def _node_id(self, node: Any) -> int:
        nid = self._node_ids.get(node)
        if nid is None:
            nid = self._node_ids[node] = next(_ids)
        return nid

    def _node_part(self, node: Any, entity_id: int) -> str:
        return f"{_ADMIN}/{self.domain_id}/{node.session.info.zid()}/{self._node_id(node)}/{entity_id}"

    def node_token(self, node: Any) -> str:
        return f"{self._node_part(node, self._node_id(node))}/NN/%/{_mangle(node.get_namespace())}/{node.get_name()}"

    def entity_token(self, node: Any, kind: str, fq_topic: str, type_name: str, key: str, *,
                     depth: int, latched: bool = False) -> str:
        if not type_name:  # a token holds no wildcard: an any-type subscriber stays unlisted
            return ""
        return (f"{self._node_part(node, next(_ids))}/{_KINDS[kind]}/%/{_mangle(node.get_namespace())}/"
                f"{node.get_name()}/{_mangle(fq_topic)}/{dds_type_name(type_name)}/{type_hash(type_name)}/"
                f"{qos_string(depth=depth, latched=latched)}")

    def liveliness_selector(self, namespace: str | None) -> str:
        return f"{_ADMIN}/{self.domain_id}/**"

    def parse_token(self, key: str) -> GraphEntry | None:
        e = parse_ros2_token(key)
        if e is None or str(key).split("/")[1] != str(self.domain_id):
            return None
        return e

    def unique_name_selector(self, namespace: str, name: str) -> str | None:
        return None  # ROS 2 allows (and warns about) nodes sharing a name

    # ---- sessions
    def session_defaults(self, zenoh_options: Any) -> Any:
        """A ROS 2 machine's session: peer, connected to rmw_zenohd on localhost:7447, no multicast
        (only where nothing was given: flags, env vars and config files win)."""
        z = zenoh_options
        if z.config_file or z.connect or z.mode:
            return z
        return replace(z, connect=[ROS2_ROUTER], mode="peer", no_multicast=True)
