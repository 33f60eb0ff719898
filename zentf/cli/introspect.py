"""A settled snapshot of the liveliness graph for one-shot tools (node list, topic list, graph)."""
from __future__ import annotations

import threading
import time
from typing import Any, Optional

from .common import CliError, CliOptions, node_options, open_graph_session, status, wire_profile

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


#: How long a tool asks the graph whether its server exists before failing fast (the local profile's
#: listings answer in ~0.2 s; a peer-mode session settles within MIN_WAIT + QUIET).
PRESENCE_WAIT = 1.0


#: Every node's parameter services (rcl_interfaces): left out of "what is offered" lists.
PARAMETER_SERVICES = frozenset(("get_parameters", "set_parameters", "list_parameters", "describe_parameters",
                                "get_parameter_types", "set_parameters_atomically"))


def _hidden(name: str) -> bool:
    return any(part.startswith("_") for part in name.split("/"))


def name_list(names: Any, shown: int = 8, none: str = "none", first_under: str = "") -> str:
    """'a, b, c and 4 more' (escaped names; those under ``first_under`` first), or ``none``: what is there,
    in a failure line."""
    from .format import printable

    names = sorted(names, key=lambda n: (not n.startswith(first_under + "/"), n))
    if not names:
        return none
    more = f" and {len(names) - shown} more" if len(names) > shown else ""
    return ", ".join(printable(n) for n in names[:shown]) + more


def require_service(opts: CliOptions, full: str) -> None:
    """CliError at once when no node in the graph serves ``full``, naming the services that are offered:
    a call to a service nobody offers must not wait out its timeout."""
    nodes, _ = graph_snapshot(opts, PRESENCE_WAIT, None)
    offered = {name for info in nodes.values() for name, _ in info.services}
    if full in offered:
        return
    shown = {s for s in offered if not _hidden(s) and s.rsplit("/", 1)[-1] not in PARAMETER_SERVICES}
    none = "only the nodes' parameter services" if offered else "none"
    from .format import printable

    near = full.rsplit("/", 1)[0]
    raise CliError(f"service {printable(full)} is not offered by any node (offered: "
                   f"{name_list(shown, none=none, first_under=near)}; "
                   "see 'zentf service list')")


def require_node(opts: CliOptions, fq: str) -> None:
    """CliError at once when node ``fq`` is not in the graph, naming the nodes that are."""
    nodes, _ = graph_snapshot(opts, PRESENCE_WAIT, None)
    if fq in nodes:
        return
    from .format import printable

    running = [n for n in nodes if not n.rsplit("/", 1)[-1].startswith("_")]
    raise CliError(f"node {printable(fq)} is not running (running: {name_list(running, first_under=fq.rsplit('/', 1)[0])}; "
                   "see 'zentf node list')")
