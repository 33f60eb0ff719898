"""`zentf service list | type | call`: the live services (ros2 service), from liveliness tokens."""
from __future__ import annotations

from typing import Any

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

    from zentf.transport.service import ServiceException

    from .common import open_node

    srv = known_service_type(type_name)
    request = _parse_request(srv, values)  # one CliError line (exit 2) naming what is wrong
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
        data = response.to_dict() if hasattr(response, "to_dict") else response
        text = yaml.safe_dump(data, default_flow_style=False, sort_keys=False, allow_unicode=True).rstrip()
        print("\n".join(printable(line) for line in text.split("\n")))
    finally:
        node.shutdown()


def known_service_types() -> list[str]:
    """Every service type `service call` takes: the registered classes and every .srv definition zentf has."""
    import zentf.core.parameters  # noqa: F401 - registers the rcl_interfaces parameter services
    from zentf.core.services import SERVICE_TYPES
    from zentf.ros import service_types

    return sorted(set(SERVICE_TYPES) | set(service_types()))


def known_service_type(text: str) -> Any:
    """TYPE of `service call` ('pkg/srv/Name' or 'pkg/Name') -> its service class; one line (exit 2) if unknown."""
    from zentf.ros import RosFormatError
    from zentf.ros.classes import service_class

    known = known_service_types()
    name = text.strip()
    parts = name.split("/")
    if len(parts) == 2:
        name = next((n for n in (f"{parts[0]}/srv/{parts[1]}", f"{parts[0]}/action/{parts[1]}") if n in known), name)
    if name not in known:
        raise CliError(f"unknown service type {printable(text)!r} (known: {', '.join(known)})", code=2)
    try:
        return service_class(name)
    except RosFormatError as exc:  # a definition zentf cannot make a class of
        raise CliError(f"service type {name}: {exc}", code=2) from exc


def _parse_request(srv: Any, values: str) -> Any:
    """The YAML request as srv.Request; one CliError line (exit 2) naming the bad field."""
    from .topic import parse_message_as

    return parse_message_as(srv.Request, values)
