"""Who is alive and what they publish/subscribe, from liveliness tokens (no central master).

Each node announces itself and each of its publishers, subscribers, service servers and clients with a
liveliness token in its wire profile's layout (zentf's ``@zentf/...``, docs/protocol.md; rmw_zenoh's
``@ros2_lv/<domain>/...``, docs/ros2.md); the profile reads them back (``parse_token``). A killed
process's session closes, so its tokens vanish and watchers see DELETE samples. Every function takes an
optional wire ``profile`` (zentf.transport.wire): zentf's by default.
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from .names import fully_qualified_node_name, normalize_namespace
from .wire.base import GraphEntry
from .wire.zentf_wire import ZentfProfile, parse_token

__all__ = ["GraphEntry", "NodeInfo", "TopicInfo", "parse_token", "list_tokens", "list_nodes", "node_info",
           "list_topics", "list_services", "GraphWatcher", "build_graph"]


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


_ZENTF = ZentfProfile()


def _parser(profile: Any, namespace: str | None) -> tuple[str, Callable[[str], GraphEntry | None]]:
    """(liveliness selector, token parser) of a wire profile (None: zentf's), for one namespace or all."""
    if profile is None:
        profile = _ZENTF
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
    """Live view of the graph: ``on_change(entry, alive)`` per token event; ``snapshot()`` any time.

    ``wait`` > 0: the constructor also asks the network for the live tokens and returns once they are
    known (at most ``wait`` seconds), so ``count`` and ``snapshot`` are right from the first call (those
    tokens are not reported to ``on_change``; the changes after them are).
    """

    def __init__(self, session: Any, on_change: Callable[[GraphEntry, bool], None] | None = None,
                 namespace: str | None = None, profile: Any = None, *, wait: float = 0.0) -> None:
        import zenoh

        self._by_key: dict[str, GraphEntry] = {}  # live token key -> what it says
        self._entries: set[GraphEntry] = set()    # what the live tokens say (two tokens may say one thing)
        self._cond = threading.Condition()
        self._on_change = on_change
        self._put = zenoh.SampleKind.PUT
        self._gone: set[str] | None = set() if wait > 0 else None  # tokens withdrawn while the query runs
        selector, self._parse = _parser(profile, namespace)
        # With wait: the changes from now on, then the live tokens asked of the network (a subscriber with
        # history would have the session answer such a query itself, before it has heard everything)
        self._sub = session.liveliness().declare_subscriber(selector, self._on_sample, history=wait <= 0)
        if wait > 0:
            try:
                replies = [r.ok for r in session.liveliness().get(selector, timeout=wait) if r.ok is not None]
            except Exception:  # noqa: BLE001 - the view then fills from the changes alone
                replies = []
            with self._cond:
                gone, self._gone = self._gone or set(), None
                for sample in replies:
                    key = str(sample.key_expr)
                    if key not in gone and key not in self._by_key:
                        e = self._parse(key)
                        if e is not None:
                            self._add(key, e)
                self._cond.notify_all()

    def _add(self, key: str, e: GraphEntry) -> None:
        """(lock held)"""
        self._by_key[key] = e
        self._entries.add(e)

    def _on_sample(self, sample: Any) -> None:
        key = str(sample.key_expr)
        e = self._parse(key)
        if e is None:
            return
        alive = sample.kind == self._put
        with self._cond:
            if alive:
                self._add(key, e)
            else:
                if self._gone is not None:
                    self._gone.add(key)
                if self._by_key.pop(key, None) is not None and e not in self._by_key.values():
                    self._entries.discard(e)
            self._cond.notify_all()
        if self._on_change is not None:
            try:
                self._on_change(e, alive)
            except Exception:
                pass

    def count(self, kind: str, topic: str, type_name: str | None = None) -> int:
        """Live tokens of ``kind`` ('pub', 'sub', 'srv', 'cli') on ``topic``, of ``type_name`` or of any
        type (an any-type entity counts for every type)."""
        with self._cond:
            return sum(1 for e in self._by_key.values()
                       if e.kind == kind and e.topic == topic
                       and (type_name is None or not e.type_name or e.type_name == type_name))

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
