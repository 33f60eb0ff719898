"""One Cyclone DDS participant for the bridge: raw CDR readers and writers, a waitset, built-in discovery.

Uses the Eclipse Cyclone DDS Python binding (``pip install zentf[dds]``) for entities and QoS, and its
C library through ctypes where the binding's Python layer is in the way:

- samples move as serialized CDR (the binding's ``ddspy_take``/``ddspy_write``), never as Python objects;
- one waitset wakes the bridge's thread with the attach value of each triggered reader (no polling);
- discovery (DCPSParticipant, DCPSPublication, DCPSSubscription) is read with ``dds_take`` into the C
  structs and only their GUIDs, names and user data are copied out: the binding's own conversion of a
  publication sample also serializes the peer's XTypes type identifier, and a peer whose type
  information has no complete identifier (seen with Fast DDS 3) crashes the process there.

Loopback-only by default: the participant uses the 127.0.0.1 interface, no multicast, and unicast
discovery to 127.0.0.1 (every participant index of this machine); ``lan=True`` uses Cyclone's defaults
(multicast discovery on the machine's network), ``peers`` adds unicast discovery addresses.
"""
from __future__ import annotations

import ctypes as ct
import logging
import threading
from dataclasses import dataclass
from typing import Any, Iterable
from xml.sax.saxutils import quoteattr

__all__ = ["DdsDomain", "TopicQos", "RawReader", "RawWriter", "Endpoint", "Participant", "BRIDGE_MARK",
           "config_xml", "DdsError"]

log = logging.getLogger("zentf.bridge.dds")

#: In the USER_DATA of the bridge's participant and writers: other zentf bridges recognise both.
BRIDGE_MARK = b"zentf_bridge=dds;"
#: Participant indices probed on 127.0.0.1 (each is a port pair; Fast DDS numbers a host's participants from 0).
MAX_LOCAL_PARTICIPANTS = 32

_ANY_STATE = 127                     # DDS_ANY_STATE: every sample, view and instance state
_PSEUDO = 0x7FFF0000                 # DDS_MIN_PSEUDO_HANDLE
DCPS_PARTICIPANT, DCPS_PUBLICATION, DCPS_SUBSCRIPTION = _PSEUDO + 1, _PSEUDO + 3, _PSEUDO + 4
_IST_ALIVE = 16                      # DDS_IST_ALIVE


class DdsError(RuntimeError):
    """A DDS call failed (the message names the call and Cyclone's return code)."""


class _SampleInfo(ct.Structure):  # dds_sample_info_t (dds/dds.h)
    _fields_ = [("sample_state", ct.c_int), ("view_state", ct.c_int), ("instance_state", ct.c_int),
                ("valid_data", ct.c_bool), ("source_timestamp", ct.c_int64), ("instance_handle", ct.c_uint64),
                ("publication_handle", ct.c_uint64), ("disposed_generation_count", ct.c_uint32),
                ("no_writers_generation_count", ct.c_uint32), ("sample_rank", ct.c_uint32),
                ("generation_rank", ct.c_uint32), ("absolute_generation_rank", ct.c_uint32)]


class _Guid(ct.Structure):
    _fields_ = [("v", ct.c_ubyte * 16)]


class _BuiltinParticipant(ct.Structure):  # dds_builtintopic_participant_t
    _fields_ = [("key", _Guid), ("qos", ct.c_void_p)]


class _BuiltinEndpoint(ct.Structure):  # dds_builtintopic_endpoint_t
    _fields_ = [("key", _Guid), ("participant_key", _Guid), ("participant_instance_handle", ct.c_uint64),
                ("topic_name", ct.c_char_p), ("type_name", ct.c_char_p), ("qos", ct.c_void_p)]


_lib: Any = None


def _c() -> Any:
    """The binding's own libddsc (one library in the process), with the prototypes used here."""
    global _lib
    if _lib is None:
        from cyclonedds.internal import load_cyclonedds

        lib = load_cyclonedds()
        ent, i32 = ct.c_int32, ct.c_int32
        for name, res, args in (
            ("dds_create_reader", ent, [ent, ent, ct.c_void_p, ct.c_void_p]),
            ("dds_create_readcondition", ent, [ent, ct.c_uint32]),
            ("dds_create_waitset", ent, [ent]),
            ("dds_waitset_attach", i32, [ent, ent, ct.c_ssize_t]),
            ("dds_waitset_detach", i32, [ent, ent]),
            ("dds_waitset_wait", i32, [ent, ct.POINTER(ct.c_ssize_t), ct.c_size_t, ct.c_int64]),
            ("dds_create_guardcondition", ent, [ent]),
            ("dds_set_guardcondition", i32, [ent, ct.c_bool]),
            ("dds_take_guardcondition", i32, [ent, ct.POINTER(ct.c_bool)]),
            ("dds_take", i32, [ent, ct.POINTER(ct.c_void_p), ct.POINTER(_SampleInfo), ct.c_size_t, ct.c_uint32]),
            ("dds_return_loan", i32, [ent, ct.POINTER(ct.c_void_p), i32]),
            ("dds_qget_userdata", ct.c_bool, [ct.c_void_p, ct.POINTER(ct.c_void_p), ct.POINTER(ct.c_size_t)]),
            ("dds_qget_reliability", ct.c_bool, [ct.c_void_p, ct.POINTER(ct.c_int), ct.POINTER(ct.c_int64)]),
            ("dds_qget_durability", ct.c_bool, [ct.c_void_p, ct.POINTER(ct.c_int)]),
            ("dds_free", None, [ct.c_void_p]),
            ("dds_get_matched_publication_data", ct.c_void_p, [ent, ct.c_uint64]),
            ("dds_builtintopic_free_endpoint", None, [ct.c_void_p]),
            ("dds_delete", i32, [ent]),
        ):
            fn = getattr(lib, name)
            fn.restype = res
            fn.argtypes = args
        _lib = lib
    return _lib


def _check(ret: int, what: str) -> int:
    if ret < 0:
        raise DdsError(f"{what} failed (Cyclone DDS return code {ret})")
    return ret


def _userdata(qos: int | None) -> bytes:
    if not qos:
        return b""
    lib = _c()
    value = ct.c_void_p()
    size = ct.c_size_t()
    if not lib.dds_qget_userdata(qos, ct.byref(value), ct.byref(size)) or not value.value:
        return b""
    try:
        return ct.string_at(value.value, size.value)
    finally:
        lib.dds_free(value)


def _qos_kinds(qos: int | None) -> tuple[bool, bool]:
    """(reliable, transient local or more durable) of a discovered endpoint's QoS (DDS's defaults when
    absent: a writer reliable, a reader best effort; both volatile)."""
    if not qos:
        return False, False
    lib = _c()
    rel = ct.c_int(0)
    blocking = ct.c_int64(0)
    dur = ct.c_int(0)
    reliable = bool(lib.dds_qget_reliability(qos, ct.byref(rel), ct.byref(blocking))) and rel.value == 1
    durable = bool(lib.dds_qget_durability(qos, ct.byref(dur))) and dur.value >= 1
    return reliable, durable


def config_xml(*, lan: bool = False, peers: Iterable[str] = (), interfaces: Iterable[str] = ()) -> str:
    """Cyclone's configuration: loopback only (127.0.0.1, no multicast, unicast discovery of this
    machine's participants) unless ``lan``: then the named ``interfaces`` (Cyclone picks one when none is
    named); ``peers`` adds unicast discovery addresses either way."""
    peer_list = list(peers)
    names = list(interfaces)
    if lan:
        general = ("<General><Interfaces>" + "".join(f"<NetworkInterface name={quoteattr(n)}/>" for n in names)
                   + "</Interfaces></General>") if names else ""
    else:
        general = ('<General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
                   "<AllowMulticast>false</AllowMulticast></General>")
        peer_list = ["127.0.0.1", *peer_list]
    discovery = "<ParticipantIndex>auto</ParticipantIndex>"
    discovery += f"<MaxAutoParticipantIndex>{MAX_LOCAL_PARTICIPANTS}</MaxAutoParticipantIndex>"
    if peer_list:
        discovery += "<Peers>" + "".join(f"<Peer address={quoteattr(p)}/>" for p in peer_list) + "</Peers>"
    return f'<CycloneDDS><Domain Id="any">{general}<Discovery>{discovery}</Discovery></Domain></CycloneDDS>'


@dataclass(frozen=True)
class TopicQos:
    """The QoS of one bridged topic, as ROS 2 gives it (rmw's reliability, durability, history depth)."""

    reliable: bool = True
    transient_local: bool = False
    depth: int = 10


@dataclass(frozen=True)
class Participant:
    guid: bytes
    user_data: bytes


@dataclass(frozen=True)
class Endpoint:
    """A discovered reader or writer: its GUID, its participant's, DDS topic and type names."""

    kind: str              # 'pub' or 'sub'
    guid: bytes
    participant: bytes
    topic: str
    type_name: str
    user_data: bytes
    reliable: bool = True
    transient_local: bool = False


class RawReader:
    """A DDS reader whose samples are taken as CDR bytes (with the encapsulation header)."""

    def __init__(self, domain: "DdsDomain", topic: Any, qos: TopicQos, attach: int) -> None:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.sub import DataReader
        from cyclonedds.util import duration

        pol = [Policy.Reliability.Reliable(duration(seconds=1)) if qos.reliable else Policy.Reliability.BestEffort,
               Policy.Durability.TransientLocal if qos.transient_local else Policy.Durability.Volatile,
               Policy.History.KeepLast(max(1, qos.depth)), Policy.IgnoreLocal.Participant,
               Policy.DataRepresentation(use_cdrv0_representation=True)]
        self.reader = DataReader(domain.participant, topic, qos=Qos(*pol))
        self.ref = self.reader._ref
        self.guid = self.reader.guid.bytes
        self.attach = attach
        lib = _c()
        self._cond = _check(lib.dds_create_readcondition(self.ref, _ANY_STATE), "dds_create_readcondition")
        _check(lib.dds_waitset_attach(domain.waitset, self._cond, attach), "dds_waitset_attach")
        self._domain = domain
        from cyclonedds._clayer import ddspy_take

        self._take = ddspy_take

    def take(self, n: int = 256) -> list[tuple[bytes, Any]]:
        """Up to n (CDR bytes, SampleInfo) pairs; samples without data (disposals) are skipped."""
        ret = self._take(self.ref, _ANY_STATE, n)
        if type(ret) is int:
            raise DdsError(f"dds_take failed (Cyclone DDS return code {ret})")
        return [(data, info) for data, info in ret if info.valid_data]

    def close(self) -> None:
        lib = _c()
        lib.dds_waitset_detach(self._domain.waitset, self._cond)
        lib.dds_delete(self._cond)
        lib.dds_delete(self.ref)


class RawWriter:
    """A DDS writer of CDR bytes (with the encapsulation header), marked as a zentf bridge's unless
    ``mark`` is false."""

    def __init__(self, domain: "DdsDomain", topic: Any, qos: TopicQos, *, mark: bool = True) -> None:
        from cyclonedds._clayer import ddspy_write
        from cyclonedds.core import Policy, Qos
        from cyclonedds.pub import DataWriter
        from cyclonedds.util import duration

        pol = [Policy.Reliability.Reliable(duration(seconds=1)) if qos.reliable else Policy.Reliability.BestEffort,
               Policy.Durability.TransientLocal if qos.transient_local else Policy.Durability.Volatile,
               Policy.History.KeepLast(max(1, qos.depth)),
               Policy.DataRepresentation(use_cdrv0_representation=True)]
        if mark:
            pol.append(Policy.Userdata(BRIDGE_MARK))
        self.writer = DataWriter(domain.participant, topic, qos=Qos(*pol))
        self.ref = self.writer._ref
        self.guid = self.writer.guid.bytes
        self._write = ddspy_write

    def write(self, cdr: bytes) -> None:
        ret = self._write(self.ref, cdr)
        if ret < 0:
            raise DdsError(f"dds_write failed (Cyclone DDS return code {ret})")

    def close(self) -> None:
        _c().dds_delete(self.ref)


_DOMAINS: dict[int, tuple[Any, str, int]] = {}
_DOMAINS_LOCK = threading.Lock()


def _domain(domain_id: int, config: str) -> Any:
    """Cyclone's domain object (one per domain id in a process, shared: a second one fails)."""
    from cyclonedds.domain import Domain

    with _DOMAINS_LOCK:
        held = _DOMAINS.get(domain_id)
        if held is not None:
            dom, cfg, n = held
            if cfg != config:
                raise ValueError(f"DDS domain {domain_id} is already open in this process with another "
                                 "configuration (loopback vs --lan, or other peers)")
            _DOMAINS[domain_id] = (dom, cfg, n + 1)
            return dom
        dom = Domain(domain_id, config)
        _DOMAINS[domain_id] = (dom, config, 1)
        return dom


def _release_domain(domain_id: int) -> None:
    with _DOMAINS_LOCK:
        held = _DOMAINS.get(domain_id)
        if held is None:
            return
        dom, cfg, n = held
        if n > 1:
            _DOMAINS[domain_id] = (dom, cfg, n - 1)
        else:
            del _DOMAINS[domain_id]


#: attach values of the waitset's own conditions (readers get 0, 1, 2, ...)
WAKE, DISCOVERY = -1, -2


class DdsDomain:
    """A participant on one DDS domain; ``wait()`` blocks until readers have data (their attach values)."""

    def __init__(self, domain_id: int, *, lan: bool = False, peers: Iterable[str] = (),
                 interfaces: Iterable[str] = (), user_data: bytes = b"enclave=/;", mark: bool = True) -> None:
        from cyclonedds.core import Policy, Qos
        from cyclonedds.domain import DomainParticipant

        if not 0 <= domain_id <= 232:
            raise ValueError(f"ROS_DOMAIN_ID must be an integer 0-232, got {domain_id}")
        self.domain_id = domain_id
        self.config = config_xml(lan=lan, peers=peers, interfaces=interfaces)
        lib = _c()
        self._domain = _domain(domain_id, self.config)
        self.participant = DomainParticipant(domain_id, qos=Qos(Policy.Userdata(user_data + (BRIDGE_MARK if mark else b""))))
        self.guid = self.participant.guid.bytes
        pref = self.participant._ref
        self.waitset = _check(lib.dds_create_waitset(pref), "dds_create_waitset")
        self._guard = _check(lib.dds_create_guardcondition(pref), "dds_create_guardcondition")
        _check(lib.dds_waitset_attach(self.waitset, self._guard, WAKE), "dds_waitset_attach")
        self._builtin: dict[int, tuple[int, int]] = {}
        for pseudo in (DCPS_PARTICIPANT, DCPS_PUBLICATION, DCPS_SUBSCRIPTION):
            rd = _check(lib.dds_create_reader(pref, pseudo, None, None), "dds_create_reader (built-in topic)")
            cond = _check(lib.dds_create_readcondition(rd, _ANY_STATE), "dds_create_readcondition")
            _check(lib.dds_waitset_attach(self.waitset, cond, DISCOVERY), "dds_waitset_attach")
            self._builtin[pseudo] = (rd, cond)
        self._topics: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._xs = (ct.c_ssize_t * 256)()
        self._closed = False

    # ---- entities
    def topic(self, dds_name: str, type_name: str) -> Any:
        """The Cyclone topic of a DDS topic name and ROS type (made once)."""
        from cyclonedds.topic import Topic

        from .idl import idl_type

        with self._lock:
            t = self._topics.get(dds_name)
            if t is None:
                t = self._topics[dds_name] = Topic(self.participant, dds_name, idl_type(type_name))
            return t

    def reader(self, dds_name: str, type_name: str, qos: TopicQos, attach: int) -> RawReader:
        return RawReader(self, self.topic(dds_name, type_name), qos, attach)

    def writer(self, dds_name: str, type_name: str, qos: TopicQos, *, mark: bool = True) -> RawWriter:
        return RawWriter(self, self.topic(dds_name, type_name), qos, mark=mark)

    # ---- waiting
    def wait(self, timeout: float) -> list[int]:
        """Attach values of what triggered within ``timeout`` seconds (GIL released while blocked)."""
        n = _c().dds_waitset_wait(self.waitset, self._xs, len(self._xs), int(timeout * 1e9))
        if n < 0:
            if self._closed:
                return []
            raise DdsError(f"dds_waitset_wait failed (Cyclone DDS return code {n})")
        out = list(self._xs[:n])
        if WAKE in out:
            _c().dds_take_guardcondition(self._guard, ct.byref(ct.c_bool()))
        return out

    def wake(self) -> None:
        """Make a wait() return at once (new readers, closing)."""
        _c().dds_set_guardcondition(self._guard, True)

    # ---- discovery
    def take_participants(self) -> tuple[list[Participant], list[bytes]]:
        """(participants that appeared or changed, GUIDs of those that left) since the last call."""
        seen: list[Participant] = []
        gone: list[bytes] = []

        def one(ptr: int, info: _SampleInfo) -> None:
            p = ct.cast(ptr, ct.POINTER(_BuiltinParticipant)).contents
            guid = bytes(p.key.v)
            if info.instance_state != _IST_ALIVE:
                gone.append(guid)
            elif info.valid_data:
                seen.append(Participant(guid, _userdata(p.qos)))

        self._take_builtin(DCPS_PARTICIPANT, one)
        return seen, gone

    def take_endpoints(self) -> tuple[list[Endpoint], list[bytes]]:
        """(readers and writers that appeared, GUIDs of those that left) since the last call."""
        seen: list[Endpoint] = []
        gone: list[bytes] = []
        for pseudo, kind in ((DCPS_PUBLICATION, "pub"), (DCPS_SUBSCRIPTION, "sub")):
            def one(ptr: int, info: _SampleInfo, kind: str = kind) -> None:
                e = ct.cast(ptr, ct.POINTER(_BuiltinEndpoint)).contents
                guid = bytes(e.key.v)
                if info.instance_state != _IST_ALIVE:
                    gone.append(guid)
                elif info.valid_data:
                    seen.append(Endpoint(kind, guid, bytes(e.participant_key.v),
                                         (e.topic_name or b"").decode("utf-8", "replace"),
                                         (e.type_name or b"").decode("utf-8", "replace"), _userdata(e.qos),
                                         *_qos_kinds(e.qos)))

            self._take_builtin(pseudo, one)
        return seen, gone

    def _take_builtin(self, pseudo: int, one: Any) -> None:
        """Take a built-in reader's samples in batches: ``one(pointer, info)`` copies each out before
        its loan is returned."""
        lib = _c()
        rd = self._builtin[pseudo][0]
        n_max = 64
        while True:
            bufs = (ct.c_void_p * n_max)()
            infos = (_SampleInfo * n_max)()
            n = lib.dds_take(rd, bufs, infos, n_max, n_max)
            if n <= 0:
                return
            try:
                for i in range(n):
                    one(bufs[i], infos[i])
            finally:
                lib.dds_return_loan(rd, bufs, n)
            if n < n_max:
                return

    def is_bridge_writer(self, reader: RawReader, publication_handle: int) -> bool:
        """Whether a matched writer of ``reader`` is a zentf bridge's (its USER_DATA carries the mark)."""
        lib = _c()
        ptr = lib.dds_get_matched_publication_data(reader.ref, publication_handle)
        if not ptr:
            return False
        try:
            e = ct.cast(ptr, ct.POINTER(_BuiltinEndpoint)).contents
            return BRIDGE_MARK in _userdata(e.qos)
        finally:
            lib.dds_builtintopic_free_endpoint(ptr)

    def close(self) -> None:
        """Delete the participant and everything in it (readers, writers, waitset, conditions)."""
        if self._closed:
            return
        self._closed = True
        self.wake()
        _c().dds_delete(self.participant._ref)
        _release_domain(self.domain_id)
