"""`zentf node list | info`: the live nodes and their topics, from liveliness tokens (no master)."""
from __future__ import annotations

import click

from .common import CONTEXT_SETTINGS, liveliness_wait_option, CliError, CliOptions, with_options

__all__ = ["node"]


@click.group("node", context_settings=CONTEXT_SETTINGS)
def node() -> None:
    """Nodes: list, info."""


def is_hidden(fq_name: str) -> bool:
    """Hidden nodes (CLI tools) start with '_', as in ROS 2."""
    return fq_name.rsplit("/", 1)[-1].startswith("_")


@node.command("list", context_settings=CONTEXT_SETTINGS)
@click.option("--all", "-a", "show_all", is_flag=True, help="Include hidden nodes (names starting with '_').")
@click.option("--count", "count_only", is_flag=True, help="Print only the number of nodes.")
@liveliness_wait_option
@with_options
def node_list(show_all: bool, count_only: bool, wait: float, *, opts: CliOptions) -> None:
    """List the live nodes (fully qualified names), one per line."""
    from .introspect import graph_namespace, graph_snapshot

    from .format import printable

    nodes, _ = graph_snapshot(opts, wait, graph_namespace(opts))
    names = [fq for fq in sorted(nodes) if show_all or not is_hidden(fq)]
    if count_only:
        print(len(names))
        return
    for name in names:
        print(printable(name))


@node.command("info", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@liveliness_wait_option
@with_options
def node_info(name: str, wait: float, *, opts: CliOptions) -> None:
    """Publications and subscriptions of one node (NAME, or /NS/NAME)."""
    from zentf.transport.names import fully_qualified_node_name

    from .introspect import graph_namespace, graph_snapshot

    if name.startswith("/"):
        fq = name.rstrip("/")
    else:
        try:
            fq = fully_qualified_node_name(graph_namespace(opts) or "", name)
        except ValueError as exc:
            raise CliError(str(exc), code=2) from exc
    from .format import printable

    nodes, _ = graph_snapshot(opts, wait, None)
    info = nodes.get(fq)
    if info is None:
        raise CliError(f"unknown node {fq}: no live node has that name (see 'zentf node list')")
    print(printable(info.fq_name))
    print("  Subscribers:")
    for topic, type_name in info.subscriptions:
        print(f"    {printable(topic)}: {printable(type_name)}")
    print("  Publishers:")
    for topic, type_name in info.publishers:
        print(f"    {printable(topic)}: {printable(type_name)}")
