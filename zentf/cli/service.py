"""`zentf service list | type | call`: the live services (ros2 service), from liveliness tokens."""
from __future__ import annotations

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, finite_float, liveliness_wait_option, with_options
from .format import printable  # service names and types come from the graph: never raw on the terminal

__all__ = ["service"]


@click.group("service", context_settings=CONTEXT_SETTINGS)
def service() -> None:
    """Services: list, type, call."""


def _hidden(name: str) -> bool:
    """Hidden services (a name part starting with '_', e.g. CLI tools' own), as in ROS 2."""
    return any(part.startswith("_") for part in name.split("/"))


def _services(opts: CliOptions, wait: float) -> dict[str, set[str]]:
    """{service name: {types}} of the live servers in the namespace (or everywhere)."""
    from .introspect import graph_namespace, graph_snapshot

    nodes, _ = graph_snapshot(opts, wait, graph_namespace(opts))
    out: dict[str, set[str]] = {}
    for info in nodes.values():
        for name, type_name in info.services:
            out.setdefault(name, set()).add(type_name)
    return out


def _full_name(opts: CliOptions, name: str) -> str:
    from zentf.transport.names import normalize_namespace, resolve_topic

    from .common import node_options

    try:
        ns = normalize_namespace(node_options(opts, "_zentf_cli").namespace)
        return resolve_topic(name, ns, "_zentf_cli", {})
    except ValueError as exc:
        raise CliError(str(exc), code=2) from exc


@service.command("list", context_settings=CONTEXT_SETTINGS)
@click.option("--show-types", "-t", is_flag=True, help="Also print each service's type.")
@click.option("--all", "-a", "show_all", is_flag=True, help="Include hidden services (a part starting with '_').")
@click.option("--count", "count_only", is_flag=True, help="Print only the number of services.")
@liveliness_wait_option
@with_options
def service_list(show_types: bool, show_all: bool, count_only: bool, wait: float, *, opts: CliOptions) -> None:
    """List the services that have a live server, one per line."""
    services = {k: v for k, v in _services(opts, wait).items() if show_all or not _hidden(k)}
    if count_only:
        print(len(services))
        return
    for name in sorted(services):
        print(printable(f"{name} [{', '.join(sorted(services[name]))}]" if show_types else name))


@service.command("type", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@liveliness_wait_option
@with_options
def service_type_cmd(name: str, wait: float, *, opts: CliOptions) -> None:
    """Print the type of service NAME."""
    full = _full_name(opts, name)
    types = _services(opts, wait).get(full)
    if not types:
        raise CliError(f"unknown service {full}: no live server has that name (see 'zentf service list')")
    for t in sorted(types):
        print(printable(t))


@service.command("call", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@click.argument("type_name", metavar="TYPE")
@click.argument("values", metavar="'YAML'", default="")
@click.option("--timeout", type=finite_float(min=0.0, min_open=True), default=10.0, show_default=True,
              help="Seconds to wait for the server and then for its response.")
@with_options
def service_call(name: str, type_name: str, values: str, timeout: float, *, opts: CliOptions) -> None:
    """Call service NAME of TYPE with a request given as YAML ('{x: 4.0, y: 2.0, name: t2}')."""
    import yaml

    from zentf.core.services import service_type
    from zentf.transport.service import ServiceException

    from .common import open_node

    try:
        srv = service_type(type_name)
    except KeyError as exc:
        raise CliError(str(exc.args[0]), code=2) from exc
    from .topic import parse_message

    request = parse_message(srv.Request.TYPE_NAME, values)  # one CliError line (exit 2) naming what is wrong
    full = _full_name(opts, name)
    from .introspect import require_service

    require_service(opts, full)  # nobody offers it: say so now, the timeout is for a server that is there
    node = open_node(opts, "service")
    try:
        client = node.create_client(full, srv)
        if not client.wait_for_service(timeout):
            raise CliError(f"service {printable(full)} is in the graph but not reachable (waited {timeout:g} s)")
        print(f"requester: making request: {request!r}")
        try:
            response = client.call(request, timeout=timeout)
        except ServiceException as exc:
            raise CliError(str(exc)) from exc
        print()
        print("response:")
        text = yaml.safe_dump(response.to_dict(), default_flow_style=False, sort_keys=False).rstrip()
        print(text if text != "{}" else "{}")
    finally:
        node.shutdown()
