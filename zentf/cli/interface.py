"""`zentf interface list | show | proto`: the ROS 2 message and service types zentf has a definition for.

As ``ros2 interface``: ``show`` prints the .msg/.srv text with every nested type expanded beneath its
field (a tab deeper, without its comments); ``proto`` prints a YAML prototype to paste into
``zentf topic pub`` or ``zentf service call``. The types are zentf's own definitions (zentf.ros) and
those a program registers at run time (``zentf.ros.register_definition``).
"""
from __future__ import annotations

from typing import Any

import click

from .common import CONTEXT_SETTINGS, CliError

__all__ = ["interface", "show_text", "proto_value", "normalize"]

#: Nesting beyond this is a definition error (ROS types are a few levels deep).
MAX_NESTING = 32


@click.group("interface", context_settings=CONTEXT_SETTINGS)
def interface() -> None:
    """ROS 2 interfaces zentf knows: list, show, proto (ros2 interface)."""


def normalize(type_name: str) -> str:
    """'geometry_msgs/Point' or 'geometry_msgs/msg/Point' -> the known full name; CliError if unknown."""
    from zentf.ros import message_types, service_types

    name = type_name.strip()
    known = set(message_types()) | set(service_types())
    if name in known:
        return name
    parts = name.split("/")
    if len(parts) == 2:
        for kind in ("msg", "srv"):
            if f"{parts[0]}/{kind}/{parts[1]}" in known:
                return f"{parts[0]}/{kind}/{parts[1]}"
    import difflib

    close = difflib.get_close_matches(name, sorted(known), n=3)
    hint = f" (did you mean {', '.join(close)}?)" if close else " (see 'zentf interface list')"
    raise CliError(f"unknown interface {name!r}{hint}", code=2)


def _strip_comment(line: str) -> str:
    return line.split("#", 1)[0].rstrip()


def _expand(type_name: str, text: str, depth: int, comments: bool, out: list[str]) -> None:
    """Lines of ``text`` (a definition of ``type_name``) at ``depth`` tabs, nested types expanded."""
    from zentf.ros import definition_text, parse_msg

    if depth > MAX_NESTING:
        raise CliError(f"{type_name}: nested more than {MAX_NESTING} levels", code=2)
    pad = "\t" * depth
    for raw in text.strip("\n").splitlines():
        line = raw.rstrip() if comments else _strip_comment(raw)
        if not line.strip():
            if comments:
                out.append(pad + line)
            continue
        out.append(pad + line)
        body = _strip_comment(raw).strip()
        if not body or body == "---":
            continue
        fields = parse_msg(type_name, body).fields
        if len(fields) == 1 and fields[0].nested:
            nested = fields[0].base
            _expand(nested, definition_text(nested), depth + 1, False, out)


def show_text(type_name: str, comments: bool = True) -> str:
    """What `zentf interface show` prints for a known type."""
    from zentf.ros import definition_text, service_types

    out: list[str] = []
    if type_name in service_types():
        req, _, resp = definition_text(type_name).partition("\n---\n")
        _expand(f"{type_name}_Request", req, 0, comments, out)
        out.append("---")
        _expand(f"{type_name}_Response", resp, 0, comments, out)
    else:
        _expand(type_name, definition_text(type_name), 0, comments, out)
    return "\n".join(out)


def _declared_defaults(type_name: str) -> dict[str, Any]:
    """Field name -> the default the definition declares ('float64 w 1'), as YAML reads it."""
    import re

    import yaml

    from zentf.core.safe_yaml import YamlRefused, load
    from zentf.ros import definition_text

    out: dict[str, Any] = {}
    for raw in definition_text(type_name).splitlines():
        m = re.match(r"^\s*\S+\s+([A-Za-z_]\w*)\s+([^=#\s][^#]*)$", _strip_comment(raw))
        if m:
            try:
                out[m.group(1)] = load(m.group(2).strip(), limit=4096)
            except (yaml.YAMLError, YamlRefused):
                pass
    return out


def proto_value(type_name: str, depth: int = 0) -> Any:
    """The default value of a type as plain data (what a prototype shows): declared defaults, else zeros."""
    from zentf.ros import definition, service_types
    from zentf.ros.cdr import default_value

    if depth > MAX_NESTING:
        raise CliError(f"{type_name}: nested more than {MAX_NESTING} levels", code=2)
    name = f"{type_name}_Request" if type_name in service_types() else type_name
    declared = _declared_defaults(name)
    out: dict[str, Any] = {}
    for f in definition(name).fields:
        if f.name in declared:
            v = declared[f.name]
            out[f.name] = float(v) if f.base.startswith("float") and isinstance(v, int) and not f.array else v
        elif f.nested and f.array is None:
            out[f.name] = proto_value(f.base, depth + 1)
        elif f.nested and f.array == "fixed":
            out[f.name] = [proto_value(f.base, depth + 1) for _ in range(f.length)]
        else:
            v = default_value(f, definition)
            out[f.name] = list(v) if isinstance(v, (bytes, bytearray)) else v
    return out


@interface.command("list", context_settings=CONTEXT_SETTINGS)
@click.option("--only-msgs", "-m", is_flag=True, help="Only message types.")
@click.option("--only-srvs", "-s", is_flag=True, help="Only service types.")
def interface_list(only_msgs: bool, only_srvs: bool) -> None:
    """Every message and service type zentf has a definition for."""
    from zentf.ros import message_types, service_types

    from .format import printable

    if not only_srvs:
        print("Messages:")
        for t in message_types():
            print(f"    {printable(t)}")
    if not only_msgs:
        print("Services:")
        for t in service_types():
            print(f"    {printable(t)}")


@interface.command("show", context_settings=CONTEXT_SETTINGS)
@click.argument("type_name", metavar="TYPE")
@click.option("--no-comments", is_flag=True, help="Leave out comments and blank lines.")
def interface_show(type_name: str, no_comments: bool) -> None:
    """The definition of TYPE, nested types expanded beneath their fields (ros2 interface show)."""
    from .format import printable

    for line in show_text(normalize(type_name), not no_comments).splitlines():
        print(printable(line).replace("\\t", "\t"))


@interface.command("proto", context_settings=CONTEXT_SETTINGS)
@click.argument("type_name", metavar="TYPE")
@click.option("--no-quotes", is_flag=True, help="Do not wrap the prototype in double quotes.")
def interface_proto(type_name: str, no_quotes: bool) -> None:
    """A YAML prototype of TYPE (a service: its request) to paste into topic pub / service call."""
    import yaml

    value = proto_value(normalize(type_name))
    text = yaml.safe_dump(value, sort_keys=False, default_flow_style=False) if value else "{}\n"
    print(text if no_quotes else f'"{text}"')
