"""`zentf node list | info`: the live nodes and their topics, from liveliness tokens (no master)."""
from __future__ import annotations

import click

from .common import CONTEXT_SETTINGS, liveliness_wait_option, CliError, CliOptions, finite_float, with_options

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
@click.option("--no-params", is_flag=True, help="Do not ask the node for its parameters.")
@click.option("--timeout", type=finite_float(min=0.0, min_open=True), default=3.0, show_default=True,
              help="Seconds to wait for the node's parameter services.")
@liveliness_wait_option
@with_options
def node_info(name: str, no_params: bool, timeout: float, wait: float, *, opts: CliOptions) -> None:
    """Publishers, subscribers, service servers and clients, and parameters of one node (NAME, or /NS/NAME)."""
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
    print("  Service Servers:")
    for service, type_name in info.services:
        print(f"    {printable(service)}: {printable(type_name)}")
    print("  Service Clients:")
    for service, type_name in info.clients:
        print(f"    {printable(service)}: {printable(type_name)}")
    if no_params or not any(s.endswith("/list_parameters") for s, _ in info.services):
        return
    print("  Parameters:")
    for pname, value in _parameters(opts, info.fq_name, timeout):
        print(f"    {printable(pname)}: {printable(value)}")


def _parameters(opts: CliOptions, fq: str, timeout: float) -> list[tuple[str, str]]:
    """(name, value as YAML) of a node's parameters, through its parameter services."""
    import yaml

    from zentf.transport.parameters import ParameterClient
    from zentf.transport.service import ServiceException

    from .common import open_node

    tool = open_node(opts, "node_info")
    try:
        client = ParameterClient(tool, fq)
        if not client.wait(timeout):
            raise CliError(f"node {fq}: its parameter services did not answer within {timeout:g} s (--no-params "
                           "skips them)")
        try:
            names = client.list(timeout)
            values = client.get(names, timeout) if names else []
        except ServiceException as exc:
            raise CliError(f"node {fq}: {exc}") from exc
    finally:
        tool.shutdown()
    return [(n, yaml.safe_dump(v, default_flow_style=True, width=1 << 20).strip().removesuffix("...").strip())
            for n, v in zip(names, values)]
