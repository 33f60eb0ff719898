"""Node: a named participant with a Zenoh session, publishers, subscriptions, timers and parameters.

Callbacks (subscriptions and timers) run on the node's own executor thread, one at a time, so Zenoh's
threads only copy bytes and return; raw subscriptions (payloads as they travel) call back on Zenoh's
thread. Everything goes through the node's wire profile (``node.wire``: keys, payloads, attachments);
liveliness tokens announce the node and each of its topics in the profile's layout (docs/protocol.md,
docs/ros2.md, ``zentf.transport.graph``).
"""
from __future__ import annotations

import functools
import logging
import queue
import signal
import threading
import time as _time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

from .clock import MAX_TIMER_PERIOD_NS, Clock, ClockType, Rate
from ..core.messages import Clock as ClockMsg
from ..core.messages import Message
from .names import (fully_qualified_node_name, is_concrete_key, normalize_namespace, resolve_topic,
                    validate_node_name)
from .options import NodeOptions
from .wire.profiles import make_profile
from ..core.ratelimit import RateLimitedLogger
from ..core.text import parse_bool, stderr_log_handler
from ..core.time import Duration, to_duration
from .entities import undeclare_all

__all__ = ["Node", "Publisher", "Subscription", "RawSubscription", "RawPublisher", "RawSample", "GraphToken",
           "Timer", "Parameter", "NodeNameError", "ParameterNotDeclaredException", "spin", "init_logging"]

log = logging.getLogger("zentf.transport.node")


class NodeNameError(ValueError):
    """Another live node already has this name in this namespace."""


class ParameterNotDeclaredException(KeyError):
    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "parameter not declared"


#: ROS-like log lines: ``[WARNING] [zentf.transport.listener]: ...``
LOG_FORMAT = "[%(levelname)s] [%(name)s]: %(message)s"


def init_logging(level: int = logging.INFO) -> None:
    """ROS-like one-line log records on stderr, names from outside escaped, unless the program configured
    logging already."""
    logging.basicConfig(level=level, handlers=[stderr_log_handler(LOG_FORMAT)])


@dataclass
class Parameter:
    """A node parameter (rclpy-like: ``node.get_parameter('x').value``)."""

    name: str
    value: Any = None


class GraphToken:
    """The liveliness token announcing one graph entity (``Node.declare_entity``); ``key`` is '' when the
    wire cannot announce it (a ROS 2 subscriber of any type, a pattern)."""

    __slots__ = ("key", "_token")

    def __init__(self, key: str, token: Any) -> None:
        self.key = key
        self._token = token

    def undeclare(self) -> None:
        token, self._token = self._token, None
        if token is not None:
            token.undeclare()


class RawPublisher:
    """Publishes payloads already encoded for the node's wire on one topic (a bag player's, a relay's):
    the profile's key, encoding (or the given one), attachment and graph token."""

    def __init__(self, node: "Node", topic: str, type_name: str, *, latched: bool = False, history: int = 1,
                 depth: int = 10, encoding: Any = None) -> None:
        import zenoh
        import zenoh.ext as zx

        self.node = node
        self.topic_name = topic
        self.type_name = type_name
        profile = node.wire
        self.key = profile.data_key(topic, type_name)
        self.latched = latched
        enc = encoding if encoding is not None else profile.encoding(type_name)
        if latched:
            self._pub = zx.declare_advanced_publisher(
                node.session, self.key, encoding=enc, cache=zx.CacheConfig(max_samples=max(1, history)),
                publisher_detection=True, **profile.latched_publisher_options())
        else:
            self._pub = node.session.declare_publisher(self.key, encoding=enc,
                                                       congestion_control=zenoh.CongestionControl.BLOCK)
        self._token = node.declare_entity("pub", topic, type_name, key=self.key,
                                          depth=max(1, history) if latched else depth, latched=latched)
        self._attach = profile.attacher(node, self._token.key)
        #: the attachment as Zenoh bytes, made once, when it is the same on every sample (zentf's wire:
        #: the node name); None when the wire makes one per sample (ROS 2: sequence number, time)
        self._const_attachment = None if self._attach.constant is None else zenoh.ZBytes(self._attach.constant)
        if self._const_attachment is not None and type(self).publish_bytes is _publish_bytes:
            # publish_bytes is Zenoh's put with it bound: no Python frame per message (a subclass's
            # override is kept)
            self.publish_bytes = functools.partial(  # type: ignore[method-assign]
                self._pub.put, attachment=self._const_attachment)

    @property
    def sender_id(self) -> bytes:
        """This publisher's identity in its samples' attachments (``node.wire.sender_id`` reads it back)."""
        return self._attach.sender_id

    def wait_for_subscribers(self, timeout: float = 5.0) -> bool:
        """Block until at least one subscriber matches (event-driven); True at once for latched topics."""
        if self.latched:
            return True
        if self._pub.matching_status.matching:
            return True
        ev = threading.Event()
        listener = self._pub.declare_matching_listener(lambda st: st.matching and ev.set())
        try:
            return self._pub.matching_status.matching or ev.wait(timeout)
        finally:
            try:
                listener.undeclare()
            except Exception:
                pass

    def publish_bytes(self, payload: bytes) -> None:
        """Send an already encoded payload (e.g. from ``node.wire.encode_tf``)."""
        self._pub.put(payload, attachment=self._attach())

    def publish_as(self, payload: bytes, authority: str) -> None:
        """Send a payload on behalf of ``authority`` (a recorded sender) where the wire carries one."""
        self._pub.put(payload, attachment=self.node.wire.attachment_for(self._attach, authority))

    def compiled_tf_sender(self, fallback: Callable[[Any], None]) -> Callable[[Any], None] | None:
        """The wire's compiled ``send_transform`` of one TransformStamped on this publisher (None: none)."""
        return self.node.wire.one_transform_sender(self._pub.put, self._attach, fallback)

    def get_subscription_count(self) -> int:
        """Subscriptions of this topic and type (or of any type) in the graph, this node's included."""
        return self.node._graph_view().count("sub", self.topic_name, self.type_name)

    def destroy(self) -> None:
        undeclare_all((self._pub, self._token))
        self.node._publishers.discard(self)


_publish_bytes = RawPublisher.publish_bytes


class Publisher(RawPublisher):
    """Publishes messages of one type on one topic; ``publish`` also takes a plain dict."""

    def __init__(self, node: "Node", topic: str, msg_type: type[Message], *, latched: bool = False,
                 history: int = 1, depth: int = 10) -> None:
        super().__init__(node, topic, msg_type.TYPE_NAME, latched=latched, history=history, depth=depth)
        self.msg_type = msg_type
        self._encode = node.wire.encode

    def publish(self, msg: Message | dict) -> None:
        if isinstance(msg, Message) and not isinstance(msg, self.msg_type):
            raise TypeError(f"publisher on {self.topic_name} takes {self.msg_type.__name__}, "
                            f"got {type(msg).__name__}")
        self.publish_bytes(self._encode(msg, self.type_name))


class RawSample(NamedTuple):
    """One sample as it travelled (a raw subscription's callback gets it)."""

    payload: bytes
    #: the attachment's bytes (``node.wire.authority``/``sender_id`` read the sender from it), or None
    attachment: bytes | None
    #: the key expression it was published on
    key: str
    #: the type it carries (in its encoding or its key, as the wire does), None if it names none
    type_name: str | None
    #: its Zenoh encoding, as text
    encoding: str


class RawSubscription:
    """Payloads of a topic as they travel on the node's wire, undecoded (bridges, recorders, viewers, programs
    with their own decoders): ``callback(RawSample)`` runs on Zenoh's thread, so it must be short; one that
    raises is counted in ``errors`` and logged (rate-limited). ``topic`` may hold '*' / '**' parts (no graph
    token then); ``type_name`` narrows the key where the wire puts types in keys (ROS 2), None takes any
    type; ``latched`` also fetches what latched publishers keep for late joiners."""

    def __init__(self, node: "Node", topic: str, callback: Callable[[RawSample], Any], *,
                 type_name: str | None = None, latched: bool = False, depth: int = 100) -> None:
        import zenoh.ext as zx

        self.node = node
        self.topic_name = topic
        self.callback = callback
        self.type_name = type_name
        # a pattern is resolved here (its parts kept); a plain topic comes resolved
        self.key = node.topic_key(topic, type_name) if "*" in topic else node.wire.data_key(topic, type_name)
        self.received = 0
        self.errors = 0
        self._type_of = node.wire.sample_type
        if latched:
            self._sub = zx.declare_advanced_subscriber(node.session, self.key, self._on_sample,
                                                       history=zx.HistoryConfig(detect_late_publishers=True))
        else:
            self._sub = node.session.declare_subscriber(self.key, self._on_sample)
        self._token = None if "*" in topic else node.declare_entity(
            "sub", topic, type_name or "", key=self.key, depth=depth, latched=latched)

    def _on_sample(self, sample: Any) -> None:  # Zenoh thread
        try:
            att = sample.attachment
            key = str(sample.key_expr)
            enc = str(sample.encoding)
            self.received += 1
            if not is_concrete_key(key):  # a put on `**` reaches every subscriber it intersects: no topic's message
                raise ValueError("sent on a key expression with wildcards, not on the topic")
            self.callback(RawSample(sample.payload.to_bytes(), att.to_bytes() if att is not None else None, key,
                                    self._type_of(key, enc), enc))
        except Exception as e:  # noqa: BLE001 - never raise into Zenoh's thread
            self.errors += 1
            self.node._bad_input.log(logging.WARNING, ("raw", self.key, type(e).__name__),
                                     "raw subscription on '%s': %s: %s", self.key, type(e).__name__, e)

    def destroy(self) -> None:
        undeclare_all((self._sub, self._token))
        self.node._subscriptions.discard(self)


class Subscription:
    """Receives one topic; decoding and the callback run on the node's executor thread."""

    def __init__(self, node: "Node", topic: str, msg_type: type[Message] | None,
                 callback: Callable[[Any], None], *, depth: int = 100, latched: bool = False) -> None:
        import zenoh.ext as zx

        self.node = node
        self.topic_name = topic
        self.msg_type = msg_type
        self.callback = callback
        self.key = node.wire.data_key(topic, msg_type.TYPE_NAME if msg_type is not None else None)
        self.received = 0
        self.errors = 0
        self.overflows = 0
        self._queue: deque = deque(maxlen=depth if depth > 0 else None)
        self._scheduled = False
        self._lock = threading.Lock()
        if latched:
            self._sub = zx.declare_advanced_subscriber(
                node.session, self.key, self._on_sample,
                history=zx.HistoryConfig(detect_late_publishers=True))
        else:
            self._sub = node.session.declare_subscriber(self.key, self._on_sample)
        self._token = node.declare_entity("sub", topic, msg_type.TYPE_NAME if msg_type is not None else "",
                                          key=self.key, depth=depth, latched=latched)

    def _on_sample(self, sample: Any) -> None:  # Zenoh thread: copy and hand over
        try:
            item = (sample.payload.to_bytes(), str(sample.encoding), sample.attachment, str(sample.key_expr))
        except Exception:
            return
        with self._lock:
            if self._queue.maxlen is not None and len(self._queue) == self._queue.maxlen:
                self.overflows += 1
            self._queue.append(item)
            if self._scheduled:
                return
            self._scheduled = True
        self.node._post(self._drain)

    def _drain(self) -> None:
        while True:
            with self._lock:
                if not self._queue:
                    self._scheduled = False
                    return
                payload, enc, att, key = self._queue.popleft()
            self.received += 1
            try:
                if not is_concrete_key(key):
                    raise ValueError("sent on a key expression with wildcards, not on the topic")
                msg = self.node.wire.decode(payload, enc, key, self.msg_type)
            except ValueError as e:
                self.errors += 1
                sender = self.node.wire.authority(att, "unknown sender")
                self.node._bad_input.log(logging.WARNING, ("bad", key, sender),
                                         "dropped bad message on '%s' from %s: %s", key, sender, e)
                continue
            self.callback(msg)

    def destroy(self) -> None:
        undeclare_all((self._sub, self._token))
        self.node._subscriptions.discard(self)


class Timer:
    """Calls ``callback()`` every ``period`` of the node's clock (sim time when active)."""

    def __init__(self, node: "Node", period: Duration, callback: Callable[[], None]) -> None:
        if not 0 < period.nanoseconds <= MAX_TIMER_PERIOD_NS:
            raise ValueError(f"timer period must be > 0 and at most {MAX_TIMER_PERIOD_NS // 1_000_000_000} s, "
                             f"got {period.nanoseconds / 1e9:g} s")
        self.node = node
        self.timer_period_ns = period.nanoseconds
        self.callback = callback
        self._canceled = False
        self._next = node._timer_now() + self.timer_period_ns

    def cancel(self) -> None:
        self._canceled = True

    def is_canceled(self) -> bool:
        return self._canceled

    def reset(self) -> None:
        self._canceled = False
        self._next = self.node._timer_now() + self.timer_period_ns
        self.node._post(None)

    def destroy(self) -> None:
        self.cancel()
        self.node._timers.discard(self)


_STOP = object()
#: Longest single wait of the executor (s): a thread's limit, well above any timer's period.
_MAX_WAIT = float(int(threading.TIMEOUT_MAX) // 2)

# Signal handling: like rclpy.init(), the first node created in the main thread owns SIGINT/SIGTERM.
# The first signal shuts every node down (spin() returns, ok() turns False, exit code stays 0); a
# second SIGINT interrupts for real. The previous handlers come back when the last node shuts down.
_live_nodes: "set[Node]" = set()
_saved_handlers: dict[int, Any] = {}
_signal_count = 0
_signals_lock = threading.Lock()


def _on_signal(signum: int, frame: Any) -> None:
    global _signal_count
    _signal_count += 1
    if _signal_count > 1 and signum == signal.SIGINT:
        raise KeyboardInterrupt
    for node in list(_live_nodes):
        node.request_shutdown()


def _shutdown_all_nodes() -> None:
    """At interpreter exit (before non-daemon threads are joined): close what programs left open,
    otherwise Zenoh's callback threads would keep the process alive."""
    for node in list(_live_nodes):
        try:
            node.shutdown()
        except Exception:
            pass


try:  # runs before threading joins non-daemon threads, unlike atexit
    threading._register_atexit(_shutdown_all_nodes)  # type: ignore[attr-defined]
except Exception:  # pragma: no cover - other interpreters
    import atexit

    atexit.register(_shutdown_all_nodes)


def _register_node(node: "Node") -> None:
    global _signal_count
    with _signals_lock:
        _live_nodes.add(node)
        if _saved_handlers or threading.current_thread() is not threading.main_thread():
            return
        _signal_count = 0
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                _saved_handlers[sig] = signal.signal(sig, _on_signal)
            except (ValueError, OSError):
                pass


def _unregister_node(node: "Node") -> None:
    with _signals_lock:
        _live_nodes.discard(node)
        if _live_nodes or not _saved_handlers or threading.current_thread() is not threading.main_thread():
            return
        for sig, old in _saved_handlers.items():
            try:
                signal.signal(sig, old)
            except (ValueError, OSError, TypeError):
                pass
        _saved_handlers.clear()


class Node:
    """A zentf node (rclpy.node.Node-like). Flags/env (``options``) override constructor arguments."""

    def __init__(self, name: str | None = None, namespace: str | None = None,
                 params: dict[str, Any] | None = None, *, options: NodeOptions | None = None,
                 session: Any = None, check_unique: bool = True,
                 start_parameter_services: bool | None = None) -> None:
        opts = options if options is not None else NodeOptions.from_env()
        self.options = opts
        self._name = validate_node_name(opts.name or name or "")
        self._namespace = normalize_namespace(opts.namespace if opts.namespace is not None else namespace)
        self._fq_name = fully_qualified_node_name(self._namespace, self._name)
        self._remappings = dict(opts.remappings)
        self._overrides: dict[str, Any] = dict(params or {})
        self._overrides.update(opts.resolved_params(self._name, self._namespace))
        self._params: dict[str, Parameter] = {}
        self._param_types: dict[str, int] = {}  # rcl_interfaces ParameterType, fixed at declaration
        self._param_callbacks: list[Callable[[list[Parameter]], Any]] = []
        self._logger = logging.getLogger(f"zentf.transport.node.{self._fq_name.strip('/').replace('/', '.')}")
        #: one line per (problem, key, sender) and period for bad input from the network, names escaped
        self._bad_input = RateLimitedLogger(self._logger)
        self._publishers: set[Publisher] = set()
        self._subscriptions: set[Subscription] = set()
        self._timers: set[Timer] = set()
        self._tokens: list[Any] = []
        self._on_shutdown: list[Callable[[], None]] = []
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._shutdown = threading.Event()
        self._closed = False
        self._lock = threading.Lock()
        #: the wire profile (zentf.transport.wire.profiles): keys, payloads, attachments and graph tokens of this node
        self.wire = make_profile(opts.wire, opts.domain_id)
        self._graph: Any = None  # the graph as the wire's tokens show it, watched from the first count_*
        self._owns_session = session is None
        self.session = session if session is not None else self.wire.session_defaults(opts.zenoh).open_session()
        try:
            if check_unique:
                self._check_unique()
            # SIGINT/SIGTERM are this node's before anything can see it: a Ctrl-C as soon as it shows up
            # in the graph stops it cleanly instead of interrupting the rest of this constructor
            _register_node(self)
            self._tokens.append(self.session.liveliness().declare_token(self.wire.node_token(self)))
            use_sim = parse_bool(self.declare_parameter("use_sim_time", False).value, "parameter use_sim_time")
            self._params["use_sim_time"].value = use_sim
            self._clock = Clock(ClockType.ROS_TIME if use_sim else ClockType.SYSTEM_TIME, sim=use_sim)
            self._clock_sub: RawSubscription | None = None
            self._clock_jump = None
            if use_sim:
                self._start_sim_clock()
            if not self._name.startswith("_") if start_parameter_services is None else start_parameter_services:
                from .parameters import ParameterService  # ~/get_parameters, ~/set_parameters, ...

                ParameterService(self)  # hidden (tool) nodes skip them unless asked
            self._executor = threading.Thread(target=self._run_executor, name=f"zentf-exec{self._fq_name}",
                                              daemon=True)
            self._executor.start()
        except BaseException:
            _unregister_node(self)
            self._close_session()
            raise

    # ---- identity
    def get_name(self) -> str:
        return self._name

    def get_namespace(self) -> str:
        return "/" + self._namespace

    def get_fully_qualified_name(self) -> str:
        return self._fq_name

    def get_logger(self) -> logging.Logger:
        return self._logger

    def get_clock(self) -> Clock:
        return self._clock

    def resolve_topic_name(self, topic: str) -> str:
        return resolve_topic(topic, self._namespace, self._name, self._remappings)

    def topic_key(self, topic: str, type_name: str | None = None) -> str:
        """The key expression a topic's samples of a type (any with None) travel on with this node's wire;
        a relative name is resolved, '*' / '**' parts stay patterns ('*/tf': the tf of every namespace)."""
        if "*" not in topic:
            return self.wire.data_key(self.resolve_topic_name(topic), type_name)
        marks = {"**": "zentf_wild2_", "*": "zentf_wild1_"}
        parts = topic.split("/")
        for part in parts:
            if "*" in part and part not in marks:
                raise ValueError(f"invalid topic {topic!r}: a wildcard must be a whole part ('*' or '**')")
        import zenoh

        key = self.wire.data_key(self.resolve_topic_name("/".join(marks.get(p, p) for p in parts)), type_name)
        # Zenoh takes a pattern in its canonical form only ('**/*' is written '*/**')
        return str(zenoh.KeyExpr.autocanonize("/".join({v: k for k, v in marks.items()}.get(c, c)
                                                         for c in key.split("/"))))

    def _check_unique(self) -> None:
        key = self.wire.unique_name_selector(self._namespace, self._name)
        if key is None:  # the wire allows nodes sharing a name
            return
        # A fresh peer session learns the network's declarations a few ms after open returns, so an
        # empty answer is asked again shortly (peer mode only; clients get them before open returns).
        delays = (0.0,) if self.options.zenoh.mode in ("client", "router") else (0.0, 0.02, 0.08)
        for delay in delays:
            _time.sleep(delay)
            try:
                replies = self.session.liveliness().get(key, timeout=2.0)
                if any(reply.ok is not None for reply in replies):
                    raise NodeNameError(f"a node named {self._fq_name} is already running; "
                                        "choose another --name or --namespace")
            except NodeNameError:
                raise
            except Exception as e:  # a failed query must not stop the node
                log.debug("liveliness query for %s failed: %s", key, e)
                return

    def declare_entity(self, kind: str, topic: str, type_name: str = "", *, key: str | None = None,
                       depth: int = 10, latched: bool = False) -> GraphToken:
        """Announce a publisher ('pub'), subscriber ('sub'), service server ('srv') or client ('cli') of this
        node in the graph, in the wire's token layout; ``topic`` is the fully qualified topic (or service)
        name, ``key`` the key expression it uses (default: the wire's for the topic and type), ``depth`` and
        ``latched`` the QoS that ROS 2 tokens show. ``undeclare()`` the returned token to withdraw it."""
        if not topic.startswith("/"):
            raise ValueError(f"declare_entity takes a fully qualified name, got {topic!r}")
        if key is None:
            key = (self.wire.service_key(topic, type_name) if kind in ("srv", "cli")
                   else self.wire.data_key(topic, type_name or None))
        token_key = self.wire.entity_token(self, kind, topic, type_name, key, depth=depth, latched=latched)
        return GraphToken(token_key, self.session.liveliness().declare_token(token_key) if token_key else None)

    def count_subscribers(self, topic: str) -> int:
        """Subscriptions of a topic (any type) in the graph, as the wire's tokens announce them (rclpy's)."""
        return self._graph_view().count("sub", self.resolve_topic_name(topic))

    def count_publishers(self, topic: str) -> int:
        """Publishers of a topic (any type) in the graph (rclpy's)."""
        return self._graph_view().count("pub", self.resolve_topic_name(topic))

    def _graph_view(self) -> Any:
        """The graph of this node's wire, watched from the first call on (one liveliness subscriber)."""
        with self._lock:
            if self._graph is None:
                self._check_open()
                from .graph import GraphWatcher

                self._graph = GraphWatcher(self.session, profile=self.wire, wait=2.0)
            return self._graph

    # ---- pub/sub
    def create_publisher(self, topic: str | type[Message], msg_type: type[Message] | str,
                         qos: int = 10, *, latched: bool = False) -> Publisher:
        """``create_publisher('tf', TFMessage)``; rclpy order ``(TFMessage, 'tf')`` works too.
        ``qos`` is the history depth (a latched topic keeps that many samples for late joiners)."""
        if isinstance(topic, type):
            topic, msg_type = msg_type, topic  # type: ignore[assignment]
        self._check_open()
        pub = Publisher(self, self.resolve_topic_name(topic), msg_type, latched=latched,  # type: ignore[arg-type]
                        history=self.wire.latched_history(qos), depth=qos)
        self._publishers.add(pub)
        return pub

    def create_raw_publisher(self, topic: str, type_name: str | type[Message], qos: int = 10, *,
                             latched: bool = False, encoding: Any = None) -> RawPublisher:
        """A publisher of payloads already encoded for this node's wire (``node.wire.encode``), e.g. a bag's;
        ``encoding`` overrides the wire's Zenoh encoding of the type (where the wire sets one)."""
        self._check_open()
        name = type_name if isinstance(type_name, str) else type_name.TYPE_NAME
        pub = RawPublisher(self, self.resolve_topic_name(topic), name, latched=latched,
                           history=self.wire.latched_history(qos), depth=qos, encoding=encoding)
        self._publishers.add(pub)  # type: ignore[arg-type]
        return pub

    def create_subscription(self, topic: str | type[Message], msg_type: type[Message] | str | None,
                            callback: Callable[[Any], None], qos: int = 100, *,
                            latched: bool = False) -> Subscription:
        """Callback gets decoded messages; with msg_type None, any type, decoded by the type name the
        sample carries (plain data for unknown types). Bad ones are counted, logged and dropped."""
        if isinstance(topic, type):
            topic, msg_type = msg_type, topic  # type: ignore[assignment]
        self._check_open()
        sub = Subscription(self, self.resolve_topic_name(topic), msg_type, callback,  # type: ignore[arg-type]
                           depth=qos, latched=latched)
        self._subscriptions.add(sub)
        return sub

    def create_raw_subscription(self, topic: str, callback: Callable[[RawSample], Any], *,
                                type_name: str | type[Message] | None = None, latched: bool = False,
                                qos: int = 100) -> RawSubscription:
        """Payloads as they travel on this node's wire, undecoded, on Zenoh's thread: ``callback(RawSample)``
        with the payload, attachment, key, carried type and encoding (see RawSubscription). ``topic`` is
        resolved like any topic and may hold '*' / '**' parts; ``node.wire.decode`` reads a payload."""
        self._check_open()
        name = type_name if type_name is None or isinstance(type_name, str) else type_name.TYPE_NAME
        sub = RawSubscription(self, topic if "*" in topic else self.resolve_topic_name(topic), callback,
                              type_name=name, latched=latched, depth=qos)
        self._subscriptions.add(sub)  # type: ignore[arg-type]
        return sub

    # ---- services (zentf.transport.service)
    def create_service(self, name: Any, srv_type: Any, callback: Callable[..., Any], qos: int = 10) -> Any:
        """A service server: ``create_service('spawn', Spawn, handler)``; rclpy's order works too.
        ``qos`` is the history depth ROS 2 tokens show (--wire ros2)."""
        from .service import Service

        if isinstance(name, type):
            name, srv_type = srv_type, name
        self._check_open()
        return Service(self, self.resolve_topic_name(name), srv_type, callback, depth=qos)

    def create_client(self, name: Any, srv_type: Any, qos: int = 10) -> Any:
        """A service client: ``create_client('spawn', Spawn)``; rclpy's order works too."""
        from .service import Client

        if isinstance(name, type):
            name, srv_type = srv_type, name
        self._check_open()
        return Client(self, self.resolve_topic_name(name), srv_type, depth=qos)

    def destroy_publisher(self, pub: Publisher) -> None:
        pub.destroy()

    def destroy_subscription(self, sub: Subscription) -> None:
        sub.destroy()

    # ---- timers and time
    def create_timer(self, period: Duration | float, callback: Callable[[], None]) -> Timer:
        self._check_open()
        t = Timer(self, to_duration(period), callback)
        self._timers.add(t)
        self._post(None)
        return t

    def destroy_timer(self, timer: Timer) -> None:
        timer.destroy()

    def create_rate(self, frequency: float) -> Rate:
        return Rate(frequency, self._clock)

    def _timer_now(self) -> int:
        clock = getattr(self, "_clock", None)
        if clock is not None and clock.ros_time_is_active:
            return clock.now_ns()
        return _time.monotonic_ns()

    def _start_sim_clock(self) -> None:
        clock = self._clock
        profile = self.wire

        def on_clock(sample: RawSample) -> None:  # Zenoh thread: tiny and never raises
            try:
                sec, nsec = profile.decode_clock(sample.payload, sample.key)
                if type(sec) is not int or type(nsec) is not int or sec < 0 or not 0 <= nsec < 1_000_000_000:
                    raise ValueError(f"bad clock value {(sec, nsec)!r}"[:100])
            except Exception as e:
                sender = profile.authority(sample.attachment, "unknown sender")
                self._bad_input.log(logging.WARNING, ("bad", sample.key, sender),
                                    "dropped bad /clock message on '%s' from %s: %s", sample.key, sender, e)
                return
            clock.set_sim_time(sec * 1_000_000_000 + nsec)
            self._post(None)

        def on_jump(old: Any, new: Any) -> None:
            for t in list(self._timers):
                t._next = new.nanoseconds + t.timer_period_ns

        if self._clock_jump is None:
            self._clock_jump = clock.add_jump_callback(on_jump)
        self._clock_sub = RawSubscription(self, self.resolve_topic_name("/clock"), on_clock,
                                          type_name=ClockMsg.TYPE_NAME, depth=10)

    def _set_use_sim_time(self, active: bool) -> None:
        """``use_sim_time`` changed at run time: follow /clock (time 0 until the first) or the wall clock."""
        if active == self._clock.ros_time_is_active:
            return
        if active and self._clock_sub is None:
            self._start_sim_clock()
        elif not active and self._clock_sub is not None:
            self._clock_sub.destroy()
            self._clock_sub = None
        self._clock._set_ros_time_is_active(active)  # jump callbacks run: listeners clear their buffers
        now = self._timer_now()
        for t in list(self._timers):
            t._next = now + t.timer_period_ns
        self._post(None)

    # ---- parameters
    def declare_parameter(self, name: str, default: Any = None) -> Parameter:
        """Declare with a default (an override from flags/launch wins); the default's type is the
        parameter's type from now on (None: any type)."""
        from .parameters import declared_type

        self._param_types[name], value = declared_type(default, self._overrides.get(name, default))
        p = Parameter(name, value)
        self._params[name] = p
        return p

    def declare_parameters(self, namespace: str, parameters: list[tuple[str, Any]]) -> list[Parameter]:
        prefix = f"{namespace}." if namespace else ""
        return [self.declare_parameter(prefix + n, v) for n, v in parameters]

    def has_parameter(self, name: str) -> bool:
        return name in self._params

    def get_parameter(self, name: str) -> Parameter:
        p = self._params.get(name)
        if p is None:
            if name in self._overrides:
                return Parameter(name, self._overrides[name])
            raise ParameterNotDeclaredException(f"parameter {name!r} is not declared on {self._fq_name}")
        return p

    def get_parameter_value(self, name: str, default: Any = None) -> Any:
        try:
            return self.get_parameter(name).value
        except ParameterNotDeclaredException:
            return default

    def set_parameter(self, name: str, value: Any) -> None:
        """Set one parameter: a declared one through its type check and the on-set callbacks
        (InvalidParameterTypeException / InvalidParameterValueException); an undeclared one is created."""
        from .parameters import raise_for

        if name not in self._params:
            self._params[name] = Parameter(name, value)
            return
        raise_for(name, value, self.set_parameters([Parameter(name, value)])[0])

    def set_parameters(self, parameters: list[Parameter]) -> list[Any]:
        """rclpy's set_parameters: one SetParametersResult per parameter (each applied on its own)."""
        from .parameters import set_one

        return [set_one(self, p.name, p.value) for p in parameters]

    def add_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], Any]) -> None:
        """``callback(params) -> SetParametersResult`` (or bool) runs before a set; False rejects it."""
        self._param_callbacks.append(callback)

    def remove_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], Any]) -> None:
        self._param_callbacks.remove(callback)

    def get_parameters_dict(self) -> dict[str, Any]:
        return {n: p.value for n, p in self._params.items()}

    # ---- executor
    def _post(self, fn: Callable[[], None] | None) -> None:
        self._queue.put(fn)

    def _run_executor(self) -> None:
        """The executor thread: nothing a callback or timer does ends it (it is the node's only server of
        services and parameters); each failure is logged, rate-limited per callback."""
        q = self._queue
        while True:
            try:
                timeout = self._due_timers()
            except Exception as e:  # the timer bookkeeping itself: say so and keep serving
                self._callback_failed("timers", e)
                timeout = 0.1
            try:
                item = q.get(timeout=timeout)
            except queue.Empty:
                continue
            if item is _STOP:
                return
            if item is not None:
                try:
                    item()
                except Exception as e:
                    self._callback_failed(item, e)

    def _callback_failed(self, callback: Any, e: BaseException) -> None:
        """One log line with the traceback per callback and exception type and period; then a count."""
        name = callback if isinstance(callback, str) else (getattr(callback, "__qualname__", None)
                                                            or type(callback).__name__)
        self._bad_input.log(logging.ERROR, ("raised", name, type(e).__name__), "%s raised %s: %s", name,
                            type(e).__name__, e, exc_info=e)

    def _due_timers(self) -> float | None:
        """Run due timers; return seconds to the next one (None: wait for an event)."""
        if not self._timers:
            return None
        sim = self._clock.ros_time_is_active
        while True:
            now = self._timer_now()
            live = [t for t in self._timers if not t._canceled]
            if not live:
                return None
            t = min(live, key=lambda x: x._next)
            if t._next > now:  # (Timer bounds its period: the wait is one a thread can take)
                return None if sim else min((t._next - now) / 1e9, _MAX_WAIT)
            t._next += t.timer_period_ns
            if t._next <= now:
                t._next = now + t.timer_period_ns
            try:
                t.callback()
            except Exception as e:
                self._callback_failed(t.callback, e)
            if self._shutdown.is_set():
                return None

    # ---- life cycle
    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError(f"node {self._fq_name} is shut down")

    def ok(self) -> bool:
        return not self._shutdown.is_set()

    def request_shutdown(self) -> None:
        """Make spin() return and ok() False (safe from signal handlers and other threads)."""
        self._shutdown.set()
        clock = self.__dict__.get("_clock")  # None while the constructor has not made it yet
        if clock is not None:
            clock.wake()

    def spin(self, timeout_sec: float | None = None) -> None:
        """Block until shutdown, SIGINT or SIGTERM (then shut down cleanly) or ``timeout_sec``."""
        deadline = None if timeout_sec is None else _time.monotonic() + timeout_sec
        while not self._shutdown.is_set():
            left = 0.5 if deadline is None else min(0.5, deadline - _time.monotonic())
            if left <= 0:
                return
            self._shutdown.wait(left)
        self.shutdown()

    def shutdown(self) -> None:
        """Undeclare everything and close the session; safe to call twice."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._shutdown.set()
        _unregister_node(self)
        self._clock.wake()
        self._queue.put(_STOP)
        if threading.current_thread() is not self._executor:
            self._executor.join(timeout=2.0)
        for cb in reversed(self._on_shutdown):
            try:
                cb()
            except Exception:
                log.debug("on-shutdown callback failed", exc_info=True)
        self._on_shutdown.clear()
        for obj in [*self._subscriptions, *self._publishers]:
            obj.destroy()
        self._timers.clear()
        if self._clock_sub is not None:
            self._clock_sub.destroy()
        if self._graph is not None:
            self._graph.close()
        undeclare_all(self._tokens)
        self._tokens.clear()
        self._close_session()

    destroy_node = shutdown

    def add_on_shutdown(self, callback: Callable[[], None]) -> None:
        """Run ``callback()`` when the node shuts down (listeners, filters... undeclare themselves)."""
        self._on_shutdown.append(callback)

    def _close_session(self) -> None:
        if self._owns_session:
            try:
                self.session.close()
            except Exception:
                pass

    def __enter__(self) -> "Node":
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()

    def __repr__(self) -> str:
        return f"Node({self._fq_name!r})"


def spin(node: Node, timeout_sec: float | None = None) -> None:
    """rclpy.spin(node) look-alike."""
    node.spin(timeout_sec)

