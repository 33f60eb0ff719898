"""A settled snapshot of the liveliness graph for one-shot tools (node list, topic list, graph)."""
from __future__ import annotations

import threading
import time
from typing import Any, Optional

from .common import CliOptions, node_options, open_graph_session, status, wire_profile

__all__ = ["graph_snapshot", "graph_namespace"]

#: A fresh peer-mode session may answer a liveliness query before the router has sent it the
#: current tokens (an empty reply, or tokens arriving up to about a quarter of a second late), so
#: one-shot peer listings also watch token arrivals and wait until they stop for this long.
#: Client sessions (the local profile's listings: a client of the rendezvous) need no such wait:
#: their router or peer answers the query from every token it holds.
QUIET = 0.25
MIN_WAIT = 0.35


def graph_namespace(opts: CliOptions) -> Optional[str]:
    """Namespace to filter graph listings by (--namespace / ZENTF_NAMESPACE); None lists all."""
    ns = node_options(opts, "_zentf_cli").namespace
    return ns.strip("/") if ns and ns.strip("/") else None


def graph_snapshot(opts: CliOptions, wait: float, namespace: Optional[str] = None) -> tuple[dict, dict]:
    """(nodes, topics) as zentf.transport.graph.build_graph returns them, once token arrivals have settled."""
    from zentf.transport.graph import GraphWatcher, build_graph, list_tokens

    profile = wire_profile(opts)
    session, mode = open_graph_session(opts)
    opened = time.monotonic()
    last_change = [opened]
    lock = threading.Lock()

    def on_change(_entry: Any, _alive: bool) -> None:
        with lock:
            last_change[0] = time.monotonic()

    watcher = None
    try:
        with status("Querying the graph"):
            if mode != "client":
                watcher = GraphWatcher(session, on_change=on_change, namespace=namespace, profile=profile)
            entries = set(list_tokens(session, namespace, timeout=max(0.1, wait), profile=profile))
            if watcher is not None:
                deadline = opened + wait
                while True:
                    now = time.monotonic()
                    with lock:
                        quiet_since = last_change[0]
                    settled = now - opened >= MIN_WAIT and now - quiet_since >= QUIET
                    if settled or now >= deadline:
                        break
                    time.sleep(0.02)
                # the watcher's live view is current: it also drops tokens that vanished meanwhile
                nodes, topics = watcher.snapshot()
                if nodes or not entries:
                    return nodes, topics
        return build_graph(entries)
    finally:
        if watcher is not None:
            watcher.close()
        session.close()
