"""Who is alive and what they publish/subscribe, from liveliness tokens (no central master).

Token layout (see docs/protocol.md); ``<ns>`` is ``%`` for the root namespace, else ``%`` + the
namespace with '/' replaced by '%' (``%robot1``, ``%a%b``); ``<type>`` is encoded the same way:

    @zentf/node/<ns>/<name>
    @zentf/pub/<ns>/<name>/<type>/<topic key...>
    @zentf/sub/<ns>/<name>/<type>/<topic key...>
    @zentf/srv/<ns>/<name>/<type>/<service key...>   (service server, zentf.transport.service)
    @zentf/cli/<ns>/<name>/<type>/<service key...>   (service client)

A killed process's session closes, so its tokens vanish and watchers see DELETE samples.
Every function takes an optional wire ``profile`` (zentf.transport.wire.profiles): with the ``ros2`` one the graph is
read from rmw_zenoh's ``@ros2_lv/<domain>/...`` tokens instead (docs/ros2.md).
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from .names import decode_chunk, fully_qualified_node_name, key_to_topic, normalize_namespace

__all__ = ["GraphEntry", "NodeInfo", "TopicInfo", "parse_token", "list_tokens", "list_nodes", "node_info",
           "list_topics", "list_services", "GraphWatcher", "build_graph"]

PREFIX = "@zentf"


@dataclass(frozen=True)
class GraphEntry:
    """One parsed token: kind is 'node', 'pub', 'sub', 'srv' (service server) or 'cli' (client)."""

    kind: str
    namespace: str
    name: str
    type_name: str = ""
    topic: str = ""

    @property
    def node(self) -> str:
        return fully_qualified_node_name(self.namespace, self.name)


@dataclass
class NodeInfo:
    name: str
    namespace: str
    fq_name: str
    publishers: list[tuple[str, str]] = field(default_factory=list)  # (topic, type)
    subscriptions: list[tuple[str, str]] = field(default_factory=list)
    services: list[tuple[str, str]] = field(default_factory=list)  # (service, type) it serves
    clients: list[tuple[str, str]] = field(default_factory=list)


@dataclass
class TopicInfo:
    name: str
    types: list[str] = field(default_factory=list)
    publishers: list[str] = field(default_factory=list)  # node fq names
    subscribers: list[str] = field(default_factory=list)


def parse_token(key: str) -> GraphEntry | None:
    """A token key -> GraphEntry; None for keys that are not zentf tokens."""
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


def _selector(namespace: str | None) -> str:
    if namespace is None:
        return f"{PREFIX}/**"
    ns = normalize_namespace(namespace)
    return f"{PREFIX}/*/{'%' + ns.replace('/', '%') if ns else '%'}/**"


def _parser(profile: Any, namespace: str | None) -> tuple[str, Callable[[str], GraphEntry | None]]:
    """(liveliness selector, token parser) of a wire profile (None: zentf's own tokens)."""
    if profile is None or profile.name == "zentf":
        return _selector(namespace), parse_token
    ns = normalize_namespace(namespace) if namespace is not None else None
    parse = profile.parse_token

    def parse_in_ns(key: str) -> GraphEntry | None:
        e = parse(key)
        return e if e is not None and (ns is None or e.namespace == ns) else None

    return profile.liveliness_selector(namespace), parse_in_ns


def list_tokens(session: Any, namespace: str | None = None, timeout: float = 2.0,
                profile: Any = None) -> list[GraphEntry]:
    """Every live token of the wire profile (zentf's by default; optionally one namespace, not its children)."""
    selector, parse = _parser(profile, namespace)
    out = []
    for reply in session.liveliness().get(selector, timeout=timeout):
        sample = reply.ok
        if sample is None:
            continue
        e = parse(str(sample.key_expr))
        if e is not None:
            out.append(e)
    return sorted(set(out), key=lambda e: (e.kind, e.namespace, e.name, e.topic, e.type_name))


def build_graph(entries: Iterable[GraphEntry]) -> tuple[dict[str, NodeInfo], dict[str, TopicInfo]]:
    nodes: dict[str, NodeInfo] = {}
    topics: dict[str, TopicInfo] = {}
    entries = list(entries)
    for e in entries:
        if e.kind == "node":
            nodes.setdefault(e.node, NodeInfo(e.name, "/" + e.namespace, e.node))
    for e in entries:
        if e.kind == "node":
            continue
        info = nodes.setdefault(e.node, NodeInfo(e.name, "/" + e.namespace, e.node))
        if e.kind in ("srv", "cli"):
            (info.services if e.kind == "srv" else info.clients).append((e.topic, e.type_name))
            continue
        (info.publishers if e.kind == "pub" else info.subscriptions).append((e.topic, e.type_name))
        t = topics.setdefault(e.topic, TopicInfo(e.topic))
        if e.type_name and e.type_name not in t.types:
            t.types.append(e.type_name)
        (t.publishers if e.kind == "pub" else t.subscribers).append(e.node)
    for info in nodes.values():
        info.publishers.sort()
        info.subscriptions.sort()
        info.services.sort()
        info.clients.sort()
    for t in topics.values():
        t.publishers.sort()
        t.subscribers.sort()
    return nodes, topics


def list_nodes(session: Any, namespace: str | None = None, timeout: float = 2.0, profile: Any = None) -> list[NodeInfo]:
    """Live nodes with their publications and subscriptions, sorted by fully qualified name."""
    nodes, _ = build_graph(list_tokens(session, namespace, timeout, profile))
    return [nodes[k] for k in sorted(nodes)]


def node_info(session: Any, fq_name: str, timeout: float = 2.0, profile: Any = None) -> NodeInfo | None:
    """One node by fully qualified name ('/robot1/talker' or 'talker' for the root); None if not alive."""
    fq = fq_name if fq_name.startswith("/") else "/" + fq_name
    ns, _, name = fq.rpartition("/")
    nodes, _ = build_graph(list_tokens(session, ns, timeout, profile))
    return nodes.get(fully_qualified_node_name(ns, name))


def list_services(session: Any, namespace: str | None = None, timeout: float = 2.0,
                  profile: Any = None) -> dict[str, list[tuple[str, str]]]:
    """Live service servers: {service name: [(type, node fq name)...]}, sorted by name."""
    out: dict[str, list[tuple[str, str]]] = {}
    for e in list_tokens(session, namespace, timeout, profile):
        if e.kind == "srv":
            out.setdefault(e.topic, []).append((e.type_name, e.node))
    return {k: sorted(out[k]) for k in sorted(out)}


def list_topics(session: Any, namespace: str | None = None, timeout: float = 2.0,
                profile: Any = None) -> list[TopicInfo]:
    _, topics = build_graph(list_tokens(session, namespace, timeout, profile))
    return [topics[k] for k in sorted(topics)]


class GraphWatcher:
    """Live view of the graph: ``on_change(entry, alive)`` per token event; ``snapshot()`` any time."""

    def __init__(self, session: Any, on_change: Callable[[GraphEntry, bool], None] | None = None,
                 namespace: str | None = None, profile: Any = None) -> None:
        import zenoh

        self._entries: set[GraphEntry] = set()
        self._cond = threading.Condition()
        self._on_change = on_change
        self._put = zenoh.SampleKind.PUT
        selector, self._parse = _parser(profile, namespace)
        self._sub = session.liveliness().declare_subscriber(selector, self._on_sample, history=True)

    def _on_sample(self, sample: Any) -> None:
        e = self._parse(str(sample.key_expr))
        if e is None:
            return
        alive = sample.kind == self._put
        with self._cond:
            if alive:
                self._entries.add(e)
            else:
                self._entries.discard(e)
            self._cond.notify_all()
        if self._on_change is not None:
            try:
                self._on_change(e, alive)
            except Exception:
                pass

    def snapshot(self) -> tuple[dict[str, NodeInfo], dict[str, TopicInfo]]:
        with self._cond:
            entries = list(self._entries)
        return build_graph(entries)

    def wait_for(self, predicate: Callable[[set[GraphEntry]], bool], timeout: float) -> bool:
        """Block until predicate(entries) holds (re-checked on every change) or timeout."""
        with self._cond:
            return self._cond.wait_for(lambda: predicate(self._entries), timeout)

    def close(self) -> None:
        try:
            self._sub.undeclare()
        except Exception:
            pass

    def __enter__(self) -> "GraphWatcher":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
