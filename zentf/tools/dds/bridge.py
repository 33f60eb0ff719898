"""``zentf bridge dds``: relay between a DDS ROS 2 domain (Fast DDS, Cyclone DDS robots) and a zentf graph.

The bridge is one zentf node (either wire profile) and one Cyclone DDS participant that ROS 2 sees as a
node (it publishes ``ros_discovery_info`` as every rmw does). Each bridged topic is a route: a DDS reader
whose CDR samples are republished on the zentf side, and a zentf subscriber whose samples are written
to DDS. Routes come from the defaults (tf, tf_static, /clock, joint_states, robot_description), from
``topics`` (``NAME[:TYPE]``) and, with ``all_topics``, from DDS discovery (every ROS topic of a type zentf
knows). QoS is ROS 2's default for each topic (tf: reliable, volatile, depth 100; tf_static and
robot_description: reliable, transient local, keep last 1; /clock: best effort, keep last 1).

No echo loops: the bridge's DDS readers ignore its own participant's writers and every writer marked as
a zentf bridge's (USER_DATA), its zentf subscribers drop what its own node published. Two bridges
between the same DDS domain and the same zentf graph would deliver everything twice, so they elect one:
each announces itself on the zentf side (a liveliness token with its DDS participant's GUID); a bridge
stands by while another with a smaller GUID is there and visible on its DDS side, and takes over when
that one goes. Latched topics keep their last state (tf_static: every child frame) on both sides, so a
late joiner on either side gets them, also after the original publisher is gone.
"""
from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

from ...core.messages import MESSAGE_TYPES, TFMessage
from ...transport.entities import undeclare_all
from ...transport.names import encode_chunk, normalize_namespace, validate_node_name
from ...core.ratelimit import RateLimitedLogger
from ...transport.node import Node, RawSample
from ...transport.wire.profiles import ROS2_DEFAULT_DEPTH
from ...ros import UnknownTypeError, encode_tf, ros_type_name, type_hash
from ...ros.cdr import deserialize, serialize
from ..bridge import _Side
from .convert import cdr_to_message, check_cdr, message_to_cdr, tf_cdr_to_msgpack
from .cyclone import BRIDGE_MARK, DISCOVERY, DdsDomain, Endpoint, RawReader, RawWriter, TopicQos
from .idl import DISCOVERY_INFO, dds_topic, discovery_definition, ros_topic

__all__ = ["DdsBridge", "DdsBridgeStats", "DEFAULT_TOPICS", "parse_topic_spec", "bridgeable"]

log = logging.getLogger("zentf.bridge.dds")

_TF = TFMessage.TYPE_NAME
#: (topic, type, QoS) bridged by default: ROS 2's defaults for each (rclcpp/rclpy, tf2_ros, robot_state_publisher)
DEFAULT_TOPICS: tuple[tuple[str, str, TopicQos], ...] = (
    ("tf", _TF, TopicQos(reliable=True, transient_local=False, depth=100)),
    ("tf_static", _TF, TopicQos(reliable=True, transient_local=True, depth=1)),
    ("/clock", "rosgraph_msgs/msg/Clock", TopicQos(reliable=False, transient_local=False, depth=1)),
    ("joint_states", "sensor_msgs/msg/JointState", TopicQos(reliable=True, transient_local=False, depth=10)),
    ("robot_description", "std_msgs/msg/String", TopicQos(reliable=True, transient_local=True, depth=1)),
)
_DEFAULT_QOS = TopicQos(reliable=True, transient_local=False, depth=10)
_ROS_DISCOVERY_INFO = "ros_discovery_info"
_DISCOVERY_QOS = TopicQos(reliable=True, transient_local=True, depth=1)
#: how long a newly seen bridge with a smaller GUID may take to show up on the DDS side before this one
#: concludes that it serves another DDS network and relays anyway
ELECTION_GRACE = 3.0
_TOKEN_ROOT = "@zentf/bridge_dds"
_INFO_ATTACH = -3
#: Bounds on what the DDS side can make the bridge hold (anything on the network may announce topics
#: and nodes): routes made by --all, nodes kept per participant, endpoints and participants tracked.
MAX_DISCOVERED_ROUTES = 256
MAX_NODES_PER_PARTICIPANT = 256
MAX_ENDPOINTS_PER_NODE = 4096
#: static child frames kept per direction (what a takeover republishes, what zentf's tf_static writes whole)
MAX_STATIC_FRAMES = 10_000
MAX_TRACKED = 20_000


def bridgeable(type_name: str) -> bool:
    """A type the bridge can carry: zentf has its ROS 2 definition and a message class."""
    if type_name not in MESSAGE_TYPES:
        return False
    try:
        type_hash(type_name)
        return True
    except (UnknownTypeError, ValueError):
        return False


def parse_topic_spec(spec: str) -> tuple[str, str | None]:
    """'NAME[:TYPE]' -> (name, type or None); ValueError names what is wrong."""
    name, sep, type_name = spec.partition(":")
    name = name.strip()
    if not name or any(c.isspace() for c in name) or "//" in name or name.endswith("/") and name != "/":
        raise ValueError(f"bad topic name {name!r} in {spec!r}")
    if not sep:
        return name, None
    type_name = type_name.strip()
    if type_name.count("/") == 1:  # 'geometry_msgs/Point' as ROS 2 tools accept it
        pkg, _, short = type_name.partition("/")
        type_name = f"{pkg}/msg/{short}"
    if not bridgeable(type_name):
        raise ValueError(f"cannot bridge topic {name}: zentf has no ROS 2 message type {type_name!r}")
    return name, type_name


@dataclass
class DdsBridgeStats:
    """Messages relayed per direction and topic, echoes dropped, messages that could not be relayed."""

    to_dds: dict[str, int] = field(default_factory=dict)
    to_zentf: dict[str, int] = field(default_factory=dict)
    echoes: int = 0
    dropped: int = 0


class _Route:
    """One topic bridged both ways (DDS reader -> zentf, zentf subscriber -> DDS writer)."""

    def __init__(self, name: str, zentf_topic: str, dds_name: str, type_name: str, qos: TopicQos) -> None:
        self.name = name
        self.zentf_topic = zentf_topic
        self.dds_name = dds_name
        self.type_name = type_name
        self.qos = qos
        self.latched = qos.transient_local
        self.reader: RawReader | None = None
        self.writer: RawWriter | None = None
        self.zsub: Any = None  # the zentf side's raw subscription
        #: tf_static from zentf, by child frame: written whole to DDS (what a StaticTransformBroadcaster sends)
        self.statics: dict[str, Any] = {}
        #: tf_static from DDS, by child frame (published on the zentf side when this bridge takes over)
        self.statics_from_dds: dict[str, Any] = {}
        #: the last latched value from each side (written again when this bridge takes over)
        self.last_to_dds: bytes | None = None
        self.last_to_zentf: bytes | None = None
        self.lock = threading.Lock()


class DdsBridge:
    """Relays between the DDS domain ``domain_id`` and the zentf graph of ``node`` (either wire);
    ``close()`` stops it (the node stays yours)."""

    def __init__(self, node: Node, *, domain_id: int = 0, topics: Iterable[str] = (), all_topics: bool = False,
                 defaults: bool = True, clock: bool = True, dds_namespace: str | None = None, lan: bool = False,
                 peers: Sequence[str] = (), interfaces: Sequence[str] = (), on_state: Any = None) -> None:
        self.node = node
        self.stats = DdsBridgeStats()
        self._z = _Side(node)
        self._complain = RateLimitedLogger(log)
        self._dds_ns = normalize_namespace(dds_namespace)
        self._all = all_topics
        self._on_state = on_state
        self._routes: dict[str, _Route] = {}       # by DDS topic name
        self._by_attach: dict[int, _Route] = {}
        self._wanted: dict[str, str | None] = {}   # --topic NAME (fq on the DDS side) without a type yet
        self._lock = threading.RLock()
        self._closed = False
        self._active = False
        self._state = "starting"
        self._participants: dict[bytes, bytes] = {}   # guid -> user data
        self._endpoints: dict[bytes, Endpoint] = {}
        self._ros_nodes: dict[bytes, list[tuple[str, str, list[bytes], list[bytes]]]] = {}
        self._from_bridge: dict[int, bool] = {}       # publication handle -> a zentf bridge's writer
        self._proxy_tokens: dict[str, Any] = {}
        self._proxies: dict[tuple[str, str], _ProxyNode] = {}
        self._peers: dict[bytes, float] = {}          # other bridges on this graph: guid -> first seen
        self._peers_lock = threading.Lock()
        self._next_attach = 0
        self._discovered_routes = 0
        self._info_dirty = True
        self.domain = DdsDomain(domain_id, lan=lan, peers=peers, interfaces=interfaces)
        try:
            self.guid = self.domain.guid
            self._info_writer = self.domain.writer(_ROS_DISCOVERY_INFO, DISCOVERY_INFO, _DISCOVERY_QOS)
            self._info_reader = self.domain.reader(_ROS_DISCOVERY_INFO, DISCOVERY_INFO,
                                                   TopicQos(reliable=True, transient_local=True, depth=64),
                                                   _INFO_ATTACH)
            specs: list[tuple[str, str | None, TopicQos | None]] = []
            if defaults:
                specs += [(n, t, q) for n, t, q in DEFAULT_TOPICS if clock or n != "/clock"]
            for spec in topics:
                name, type_name = parse_topic_spec(spec)
                specs.append((name, type_name, None))
            for name, type_name, qos in specs:
                dds_fq = self._dds_fq(name)
                if type_name is None:
                    self._wanted[dds_fq] = name
                    continue
                self._add_route(name, dds_fq, type_name, qos or self._qos_for(type_name))
            self._declare_election()
            self._thread = threading.Thread(target=self._run, name="zentf-dds-bridge", daemon=True)
            self._thread.start()
        except BaseException:
            self._teardown()
            raise

    # ---- names
    def _dds_fq(self, name: str) -> str:
        """A topic name on the DDS side: relative names under --dds-namespace (else the root)."""
        if name.startswith("/"):
            return name
        return ("/" + self._dds_ns + "/" if self._dds_ns else "/") + name

    def _mount(self, dds_fq: str) -> str | None:
        """The name (relative to the zentf node's namespace) of a DDS topic found by discovery; None if it
        is outside --dds-namespace."""
        rel = dds_fq.lstrip("/")
        if self._dds_ns:
            if not rel.startswith(self._dds_ns + "/"):
                return None
            rel = rel[len(self._dds_ns) + 1:]
        return rel or None

    @classmethod
    def _qos_like(cls, e: Endpoint, type_name: str) -> TopicQos:
        """The QoS of a route found by discovery: what matches the endpoint found (a best-effort
        writer needs a best-effort reader; a transient-local reader a transient-local writer)."""
        base = cls._qos_for(type_name)
        return TopicQos(reliable=e.reliable if e.kind == "pub" else True, transient_local=e.transient_local,
                        depth=1 if e.transient_local else base.depth)

    @staticmethod
    def _qos_for(type_name: str) -> TopicQos:
        return TopicQos(reliable=True, transient_local=False, depth=100 if type_name == _TF else 10)

    # ---- routes
    def _add_route(self, name: str, dds_fq: str, type_name: str, qos: TopicQos) -> _Route | None:
        dds_name = dds_topic(dds_fq)
        with self._lock:
            if self._closed or dds_name in self._routes:
                return None
            zentf_topic = self.node.resolve_topic_name(name)
            r = _Route(name, zentf_topic, dds_name, type_name, qos)
            attach = self._next_attach
            self._next_attach += 1
            r.writer = self.domain.writer(dds_name, type_name, qos)
            r.reader = self.domain.reader(dds_name, type_name, qos, attach)
            self._subscribe_zentf(r)
            self._routes[dds_name] = r
            self._by_attach[attach] = r
            self.stats.to_dds.setdefault(zentf_topic, 0)
            self.stats.to_zentf.setdefault(zentf_topic, 0)
            self._info_dirty = True
        self.domain.wake()
        log.info("bridging %s (%s) <-> DDS %s", zentf_topic, type_name, dds_fq)
        return r

    def _subscribe_zentf(self, r: _Route) -> None:
        r.zsub = self.node.create_raw_subscription(r.zentf_topic, self._zentf_relay(r), type_name=r.type_name,
                                                   latched=r.latched, qos=r.qos.depth)

    # ---- zentf -> DDS (Zenoh's threads)
    def _zentf_relay(self, r: _Route) -> Any:
        wire = self.node.wire
        cdr_wire = wire.payload_format == "cdr"  # the wire's payloads are DDS's own: relayed as they are
        counts = self.stats.to_dds

        def relay(sample: RawSample) -> None:  # never raises: one bad message must not stop the bridge
            try:
                if self._z.is_own(sample):
                    self.stats.echoes += 1
                    return
                payload = sample.payload
                if cdr_wire:
                    check_cdr(payload, r.type_name)
                    cdr = payload
                    msg = None
                else:
                    type_name, msg, known = wire.decode_any(payload, sample.encoding, sample.key)
                    if type_name is not None and type_name != r.type_name:
                        raise ValueError(f"a {type_name} on a {r.type_name} topic")
                    if not known or isinstance(msg, (bytes, dict)) or type(msg) is not MESSAGE_TYPES[r.type_name]:
                        raise ValueError("not a zentf message")
                    cdr = None
                if r.latched and r.type_name == _TF:
                    if msg is None:
                        msg = cdr_to_message(cdr, _TF)
                    with r.lock:
                        for t in msg.transforms:
                            if len(r.statics) < MAX_STATIC_FRAMES or t.child_frame_id in r.statics:
                                r.statics[t.child_frame_id] = t
                        cdr = encode_tf(list(r.statics.values()))
                elif cdr is None:
                    cdr = message_to_cdr(msg, r.type_name)
                if r.latched:
                    r.last_to_dds = cdr
                if not self._active or self._closed:
                    return
                r.writer.write(cdr)
                counts[r.zentf_topic] += 1
            except Exception as e:  # noqa: BLE001
                self.stats.dropped += 1
                self._warn(f"z:{r.zentf_topic}:{type(e).__name__}",
                               f"not relayed to DDS from '{r.zentf_topic}': {e}")

        return relay

    # ---- DDS -> zentf (the bridge's thread)
    def _dds_relay(self, r: _Route) -> None:
        samples = r.reader.take()
        if not samples:
            return
        wire = self.node.wire
        for cdr, info in samples:
            try:
                ph = info.publication_handle
                fb = self._from_bridge.get(ph)
                if fb is None:
                    fb = self.domain.is_bridge_writer(r.reader, ph)
                    if len(self._from_bridge) > 4096:
                        self._from_bridge.clear()
                    self._from_bridge[ph] = fb
                if fb:
                    self.stats.echoes += 1
                    continue
                if r.latched:
                    if r.type_name == _TF:  # every child frame the DDS side has sent, for a takeover
                        with r.lock:
                            for t in cdr_to_message(cdr, _TF).transforms:
                                if len(r.statics_from_dds) < MAX_STATIC_FRAMES or t.child_frame_id in r.statics_from_dds:
                                    r.statics_from_dds[t.child_frame_id] = t
                    else:
                        r.last_to_zentf = cdr
                if not self._active:
                    continue
                self._to_zentf(r, cdr, wire)
                self.stats.to_zentf[r.zentf_topic] += 1
            except Exception as e:  # noqa: BLE001
                self.stats.dropped += 1
                self._warn(f"d:{r.dds_name}:{type(e).__name__}", f"not relayed from DDS '{r.dds_name}': {e}")

    def _to_zentf(self, r: _Route, cdr: bytes, wire: Any) -> None:
        if r.type_name == _TF:
            if r.latched:
                msg = cdr_to_message(cdr, _TF)
                self._z.static(r.zentf_topic).send_transform(list(msg.transforms))
            elif wire.payload_format == "cdr":
                self._z.publisher(r.zentf_topic, _TF).publish_bytes(cdr)
            else:
                payload, _bad = tf_cdr_to_msgpack(cdr)
                self._z.publisher(r.zentf_topic, _TF).publish_bytes(payload)
            return
        pub = self._z.publisher(r.zentf_topic, r.type_name, latched=r.latched)
        if wire.payload_format == "cdr":
            pub.publish_bytes(cdr)
        else:
            pub.publish(cdr_to_message(cdr, r.type_name))

    def _run(self) -> None:
        while not self._closed:
            try:
                xs = self.domain.wait(0.25)
                for x in xs:
                    if x >= 0:
                        r = self._by_attach.get(x)
                        if r is not None:
                            self._dds_relay(r)
                    elif x == DISCOVERY:
                        self._discover()
                    elif x == _INFO_ATTACH:
                        self._read_discovery_info()
                if self._closed:
                    return
                self._elect()
                if self._info_dirty:
                    self._publish_discovery_info()
            except Exception as e:  # noqa: BLE001 - the loop must go on
                if self._closed:
                    return
                self._warn(f"loop:{type(e).__name__}", f"DDS bridge: {e}")
                time.sleep(0.05)

    # ---- discovery (the bridge's thread)
    def _discover(self) -> None:
        seen, gone = self.domain.take_participants()
        for p in seen:
            if len(self._participants) < MAX_TRACKED or p.guid in self._participants:
                self._participants[p.guid] = p.user_data
        for g in gone:
            self._participants.pop(g, None)
            self._ros_nodes.pop(g, None)
        eps, left = self.domain.take_endpoints()
        for e in eps:
            if len(self._endpoints) < MAX_TRACKED or e.guid in self._endpoints:
                self._endpoints[e.guid] = e
        for g in left:
            self._endpoints.pop(g, None)
        if seen or gone or eps or left:
            self._routes_from_discovery(eps)
            self._sync_proxies()

    def _is_foreign(self, participant: bytes) -> bool:
        """A participant other than this bridge and other zentf bridges (a ROS 2 node's)."""
        if participant == self.guid:
            return False
        return BRIDGE_MARK not in self._participants.get(participant, b"")

    def _routes_from_discovery(self, eps: list[Endpoint]) -> None:
        for e in eps:
            try:
                self._route_for(e)
            except Exception as ex:  # noqa: BLE001 - a name zentf cannot use must not stop the others
                self._warn(f"route:{type(ex).__name__}", f"cannot bridge DDS topic {e.topic!r}: {ex}")

    def _route_for(self, e: Endpoint) -> None:
        if not self._is_foreign(e.participant):
            return
        fq = ros_topic(e.topic)
        if fq is None:
            return
        type_name = ros_type_name(e.type_name)
        dds_name = e.topic
        if dds_name in self._routes:
            return
        spec_name = self._wanted.get(fq)
        if spec_name is not None:
            if bridgeable(type_name):
                self._wanted.pop(fq, None)
                self._add_route(spec_name, fq, type_name, self._qos_like(e, type_name))
            else:
                self._warn(f"type:{fq}", f"cannot bridge {fq}: zentf has no ROS 2 message type {type_name}")
            return
        if self._all and bridgeable(type_name):
            name = self._mount(fq)
            if name is None:
                return
            if self._discovered_routes >= MAX_DISCOVERED_ROUTES:
                self._warn("routes", f"not bridging {fq}: --all already bridges "
                                         f"{MAX_DISCOVERED_ROUTES} discovered topics")
                return
            if self._add_route(name, fq, type_name, self._qos_like(e, type_name)) is not None:
                self._discovered_routes += 1

    def _read_discovery_info(self) -> None:
        for cdr, _info in self._info_reader.take():
            try:
                msg = deserialize(cdr, DISCOVERY_INFO, discovery_definition)
                gid = bytes(msg["gid"]["data"])
                nodes = [(n["node_namespace"], n["node_name"],
                          [bytes(x["data"]) for x in n["reader_gid_seq"][:MAX_ENDPOINTS_PER_NODE]],
                          [bytes(x["data"]) for x in n["writer_gid_seq"][:MAX_ENDPOINTS_PER_NODE]])
                         for n in msg["node_entities_info_seq"][:MAX_NODES_PER_PARTICIPANT]]
            except Exception as e:  # noqa: BLE001
                self._warn("info", f"bad ros_discovery_info sample: {e}")
                continue
            if gid == self.guid or (len(self._ros_nodes) >= MAX_TRACKED and gid not in self._ros_nodes):
                continue
            self._ros_nodes[gid] = nodes
        self._sync_proxies()

    def _publish_discovery_info(self) -> None:
        """This bridge as a ROS 2 node (rmw_dds_common's ParticipantEntitiesInfo), so ROS 2 lists it."""
        with self._lock:
            self._info_dirty = False
            readers = [r.reader.guid for r in self._routes.values() if r.reader is not None]
            writers = [r.writer.guid for r in self._routes.values() if r.writer is not None]
        ns = "/" + self._dds_ns if self._dds_ns else "/"
        value = {"gid": {"data": self.guid},
                 "node_entities_info_seq": [{"node_namespace": ns, "node_name": self.node.get_name(),
                                             "reader_gid_seq": [{"data": g} for g in readers],
                                             "writer_gid_seq": [{"data": g} for g in writers]}]}
        self._info_writer.write(serialize(value, DISCOVERY_INFO, discovery_definition))

    # ---- the DDS graph on the zentf side (topic list, node list)
    def _sync_proxies(self) -> None:
        """Tokens for the DDS side's nodes and their topics, so zentf's graph tools list them (active only)."""
        want: dict[str, None] = {}
        if self._active:
            for participant, nodes in self._ros_nodes.items():
                if not self._is_foreign(participant):
                    continue
                for ns, name, readers, writers in nodes:
                    want.update(dict.fromkeys(self._proxy_keys(ns, name, readers, writers)))
        session = self.node.session
        for key in [k for k in self._proxy_tokens if k not in want]:
            undeclare_all([self._proxy_tokens.pop(key)])
        for key in want:
            if key not in self._proxy_tokens:
                try:
                    self._proxy_tokens[key] = session.liveliness().declare_token(key)
                except Exception as e:  # noqa: BLE001
                    self._warn("proxy", f"cannot announce {key}: {e}")

    def _proxy_keys(self, ns: str, name: str, readers: list[bytes], writers: list[bytes]) -> list[str]:
        rest = ns.strip("/")
        if self._dds_ns:
            if rest != self._dds_ns and not rest.startswith(self._dds_ns + "/"):
                return []
            rest = rest[len(self._dds_ns):].strip("/")
        try:
            validate_node_name(name)
            zns = normalize_namespace("/".join(p for p in (normalize_namespace(self.node.get_namespace()), rest) if p))
        except ValueError:  # not a ROS name: nothing to announce
            return []
        proxy = self._proxies.get((zns, name))
        if proxy is None:
            proxy = self._proxies[(zns, name)] = _ProxyNode(zns, name, self.node.session)
        wire = self.node.wire
        try:
            keys = [wire.node_token(proxy)]
        except Exception:  # noqa: BLE001 - a name zentf cannot announce
            return []
        for kind, gids in (("pub", writers), ("sub", readers)):
            for g in gids:
                e = self._endpoints.get(g)
                fq = ros_topic(e.topic) if e is not None else None
                rel = self._mount(fq) if fq is not None else None
                if rel is None:
                    continue
                type_name = ros_type_name(e.type_name)
                topic = self.node.resolve_topic_name(rel)
                try:  # the endpoint's history depth is not discovered: rmw_zenoh's default
                    keys.append(wire.entity_token(proxy, kind, topic, type_name, wire.data_key(topic, type_name),
                                                  depth=ROS2_DEFAULT_DEPTH))
                except Exception:  # noqa: BLE001 - ROS 2's wire names no type zentf has no definition of
                    continue
        return keys

    # ---- one active bridge per DDS domain and zentf graph
    def _graph_key(self) -> str:
        wire = self.node.wire
        return (f"{_TOKEN_ROOT}/{wire.name}/{wire.domain_id}/{encode_chunk(self.node.get_namespace())}/"
                f"{self.domain.domain_id}")

    def _declare_election(self) -> None:
        liveliness = self.node.session.liveliness()
        prefix = self._graph_key()
        self._token = liveliness.declare_token(f"{prefix}/{self.guid.hex()}")
        now = time.monotonic()
        try:  # the bridges already there, before relaying anything
            for reply in liveliness.get(f"{prefix}/*", timeout=2.0):
                if reply.ok is not None:
                    self._peer_event(str(reply.ok.key_expr), True, now)
        except Exception as e:  # noqa: BLE001
            log.debug("liveliness query failed: %s", e)
        self._peer_sub = liveliness.declare_subscriber(f"{prefix}/*", self._on_peer, history=True)

    def _on_peer(self, sample: Any) -> None:
        import zenoh

        self._peer_event(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT, time.monotonic())
        self.domain.wake()

    def _peer_event(self, key: str, alive: bool, now: float) -> None:
        try:
            guid = bytes.fromhex(key.rsplit("/", 1)[-1])
        except ValueError:
            return
        if guid == self.guid:
            return
        with self._peers_lock:
            if alive:
                self._peers.setdefault(guid, now)
            else:
                self._peers.pop(guid, None)

    def _elect(self) -> None:
        now = time.monotonic()
        with self._peers_lock:
            smaller = {g: t for g, t in self._peers.items() if g < self.guid}
        relaying = next((g for g in smaller if g in self._participants), None)
        if relaying is not None:
            state = "standby"
        elif any(now - t < ELECTION_GRACE for t in smaller.values()):
            state = "waiting"
        else:
            state = "active"
        if state != self._state:
            self._state = state
            self._set_active(state == "active", relaying)

    def _set_active(self, active: bool, other: bytes | None) -> None:
        was = self._active
        self._active = active
        if active and not was:
            self._republish_latched()
        self._sync_proxies()
        if self._on_state is not None:
            self._on_state(self._state, other.hex() if other else None)
        elif self._state != "waiting":
            log.info("DDS bridge %s: %s", self.guid.hex(), self._state)

    def _republish_latched(self) -> None:
        """On taking over: the latched state each side gave while this bridge stood by."""
        for r in list(self._routes.values()):
            try:
                if r.last_to_dds is not None:
                    r.writer.write(r.last_to_dds)
                if r.last_to_zentf is not None:
                    self._to_zentf(r, r.last_to_zentf, self.node.wire)
                with r.lock:
                    statics = list(r.statics_from_dds.values())
                if statics:
                    self._z.static(r.zentf_topic).send_transform(statics)
            except Exception as e:  # noqa: BLE001
                self._warn(f"latched:{r.dds_name}", f"cannot republish {r.dds_name}: {e}")

    @property
    def state(self) -> str:
        """'active' (relaying), 'standby' (another bridge relays) or 'waiting' (starting, or deciding)."""
        return "starting" if self._state == "starting" else self._state

    def routes(self) -> list[tuple[str, str, str]]:
        """(zentf topic, DDS topic, type) of every bridged topic."""
        with self._lock:
            return [(r.zentf_topic, "/" + r.dds_name[3:], r.type_name) for r in self._routes.values()]

    # ---- closing
    def _warn(self, key: str, msg: str) -> None:
        """One rate-limited, escaped warning per kind of problem (names in it came from the network)."""
        self._complain.log(logging.WARNING, key, "%s", msg)

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self.domain.wake()
        if threading.current_thread() is not getattr(self, "_thread", None):
            t = getattr(self, "_thread", None)
            if t is not None:
                t.join(timeout=2.0)
        self._teardown()

    def _teardown(self) -> None:
        self._closed = True
        objs: list[Any] = [getattr(self, "_peer_sub", None), getattr(self, "_token", None)]
        for r in self._routes.values():
            if r.zsub is not None:
                r.zsub.destroy()
        objs += list(self._proxy_tokens.values())
        self._proxy_tokens.clear()
        undeclare_all(objs)
        self.domain.close()


class _ProxyNode:
    """What a wire profile reads of a node to write its graph tokens: a DDS node shown on the zentf side."""

    def __init__(self, namespace: str, name: str, session: Any) -> None:
        self._namespace = namespace
        self._name = name
        self.session = session

    def get_namespace(self) -> str:
        return "/" + self._namespace

    def get_name(self) -> str:
        return self._name
