"""`zentf param list | get | set | dump`: any node's parameters over its parameter services (ros2 param)."""
from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Iterator, Optional

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, finite_float, liveliness_wait_option, with_options
from .format import printable  # parameter names and values come from the node: never raw on the terminal

__all__ = ["param"]

timeout_option = click.option("--timeout", type=finite_float(min=0.0, min_open=True), default=5.0,
                              show_default=True, help="Seconds to wait for the node and for each answer.")

_KIND = {bool: "Boolean", int: "Integer", float: "Double", str: "String"}


@click.group("param", context_settings=CONTEXT_SETTINGS)
def param() -> None:
    """Node parameters over the network: list, get, set, dump."""


def _fq(opts: CliOptions, name: str) -> str:
    from zentf.transport.names import fully_qualified_node_name, normalize_namespace

    from .common import node_options

    if name.startswith("/"):
        return name.rstrip("/")
    try:
        return fully_qualified_node_name(normalize_namespace(node_options(opts, "_zentf_cli").namespace), name)
    except ValueError as exc:
        raise CliError(str(exc), code=2) from exc


@contextmanager
def _tool_node(opts: CliOptions) -> Iterator[Any]:
    from .common import open_node

    node = open_node(opts, "param")
    try:
        yield node
    finally:
        node.shutdown()


def _reach(node: Any, fq: str, timeout: float) -> Any:
    """A ParameterClient of node ``fq``, once its services answer; a clear line if it is not there."""
    from zentf.transport.parameters import ParameterClient

    client = ParameterClient(node, fq)
    if not client.wait(timeout):
        raise CliError(f"node {fq} is not running (no parameter services within {timeout:g} s; "
                       "see 'zentf node list')")
    return client


@contextmanager
def _client(opts: CliOptions, node_name: str, timeout: float) -> Iterator[Any]:
    """A ParameterClient of NODE (name in --namespace, or /ns/name)."""
    fq = _fq(opts, node_name)
    from .introspect import require_node

    require_node(opts, fq)  # not running: say so now, the timeout is for a node that is there
    with _tool_node(opts) as node:
        yield _reach(node, fq, timeout)


def _call(fn: Any, *args: Any) -> Any:
    from zentf.transport.service import ServiceException

    try:
        return fn(*args)
    except ServiceException as exc:
        raise CliError(str(exc)) from exc


def _yaml(value: Any) -> str:
    import yaml

    return yaml.safe_dump(value, default_flow_style=True, width=1 << 20).strip().removesuffix("...").strip()


@param.command("list", context_settings=CONTEXT_SETTINGS)
@click.argument("node_name", metavar="[NODE]", required=False)
@timeout_option
@liveliness_wait_option
@with_options
def param_list(node_name: Optional[str], timeout: float, wait: float, *, opts: CliOptions) -> None:
    """Names of NODE's parameters (without NODE: of every live node, under its name)."""
    if node_name is not None:
        with _client(opts, node_name, timeout) as client:
            for name in _call(client.list, timeout):
                print(f"  {printable(name)}")
        return
    from .introspect import graph_namespace, graph_snapshot
    from .node import is_hidden

    nodes, _ = graph_snapshot(opts, wait, graph_namespace(opts))
    with _tool_node(opts) as tool:
        for fq in sorted(n for n in nodes if not is_hidden(n)):
            if not any(s.endswith("/list_parameters") for s, _ in nodes[fq].services):
                continue
            names = _call(_reach(tool, fq, timeout).list, timeout)
            print(f"{printable(fq)}:")
            for name in names:
                print(f"  {printable(name)}")


@param.command("get", context_settings=CONTEXT_SETTINGS)
@click.argument("node_name", metavar="NODE")
@click.argument("name")
@click.option("--hide-type", is_flag=True, help="Print only the value.")
@timeout_option
@with_options
def param_get(node_name: str, name: str, hide_type: bool, timeout: float, *, opts: CliOptions) -> None:
    """Print parameter NAME of NODE ('Double value is: 62.5', as ros2 param get)."""
    with _client(opts, node_name, timeout) as client:
        (value,) = _call(client.get, [name], timeout)
    if value is None:
        raise CliError(f"parameter {name} is not set on {_fq(opts, node_name)}")
    text = _yaml(value) if not isinstance(value, str) else value
    if hide_type:
        print(printable(text))
    else:
        kind = _KIND.get(type(value), "Array")
        print(f"{kind} value is: {printable(text)}")


@param.command("set", context_settings={**CONTEXT_SETTINGS, "ignore_unknown_options": True})  # VALUE may be -1
@click.argument("node_name", metavar="NODE")
@click.argument("name")
@click.argument("value")
@timeout_option
@with_options
def param_set(node_name: str, name: str, value: str, timeout: float, *, opts: CliOptions) -> None:
    """Set parameter NAME of NODE to VALUE (read as YAML: 20, 2.5, true, text, [1, 2])."""
    from zentf.transport.options import OptionsError, parse_scalar

    try:
        parsed = parse_scalar(value, "VALUE")
    except OptionsError as exc:
        raise CliError(str(exc), code=2) from None
    from zentf.core.parameters import type_of

    try:
        type_of(parsed)
    except ValueError as exc:
        raise CliError(f"bad value {value!r}: {exc}", code=2) from exc
    with _client(opts, node_name, timeout) as client:
        result = _call(client.set, name, parsed, timeout)
    if not result.successful:
        raise CliError(f"Setting parameter failed: {result.reason}")
    print("Set parameter successful")


@param.command("dump", context_settings=CONTEXT_SETTINGS)
@click.argument("node_name", metavar="NODE")
@timeout_option
@with_options
def param_dump(node_name: str, timeout: float, *, opts: CliOptions) -> None:
    """NODE's parameters as a ROS 2 params file (YAML; loads back with --params-file)."""
    import yaml

    with _client(opts, node_name, timeout) as client:
        names = _call(client.list, timeout)
        values = _call(client.get, names, timeout) if names else []
        fq = client.remote_node
    params = {n: v for n, v in zip(names, values) if v is not None}
    print(yaml.safe_dump({fq: {"ros__parameters": params}}, default_flow_style=False, sort_keys=True).rstrip())
