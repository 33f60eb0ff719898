"""`zentf interface list | show | proto` against the definitions zentf ships (zentf.ros)."""
from __future__ import annotations

import yaml
from click.testing import CliRunner

from cli_helpers import zentf
from zentf.cli.interface import interface
from zentf.ros import definition, message_types, parse_msg, register_definition, service_types
from zentf.ros.cdr import serialize


def _run(*args: str) -> str:
    res = CliRunner().invoke(interface, list(args))
    assert res.exit_code == 0, res.output
    return res.output


def _blocks(text: str) -> list[tuple[int, str]]:
    """(depth, field line without comment) of every field line of a `show` output."""
    out = []
    for line in text.splitlines():
        body = line.split("#", 1)[0].rstrip()
        if body.strip() and body.strip() != "---":
            out.append((len(body) - len(body.lstrip("\t")), body.strip()))
    return out


def _check_expanded(type_name: str, lines: list[tuple[int, str]], i: int, depth: int) -> int:
    """The lines from i describe type_name's fields at depth, each nested type expanded beneath: returns the
    index after them."""
    fields = [f for f in definition(type_name).fields]
    got = []
    while i < len(lines) and lines[i][0] == depth:
        parsed = parse_msg(type_name, lines[i][1]).fields
        i += 1
        if not parsed:
            continue  # a constant
        got.append(parsed[0])
        if parsed[0].nested:
            i = _check_expanded(parsed[0].base, lines, i, depth + 1)
    assert got == fields, (type_name, got, fields)
    return i


def test_show_expands_every_message_as_its_definition():
    for type_name in message_types():
        lines = _blocks(_run("show", type_name))
        assert _check_expanded(type_name, lines, 0, 0) == len(lines)


def test_show_prints_every_service_request_and_response():
    for type_name in service_types():
        _check_service(type_name)


def _check_service(type_name: str) -> None:
    lines = _run("show", type_name).splitlines()
    assert lines.count("---") == 1, lines
    i = lines.index("---")
    req, resp = "\n".join(lines[:i]), "\n".join(lines[i + 1:])
    for part, name in ((req, f"{type_name}_Request"), (resp, f"{type_name}_Response")):
        lines = _blocks(part)
        assert _check_expanded(name, lines, 0, 0) == len(lines)


def test_proto_is_a_value_of_every_type():
    for type_name in [*message_types(), *service_types()]:
        _check_proto(type_name)


def _check_proto(type_name: str) -> None:
    text = _run("proto", type_name).strip()
    assert text.startswith('"') and text.endswith('"')
    value = yaml.safe_load(text[1:-1])
    name = f"{type_name}_Request" if type_name in service_types() else type_name
    assert serialize(value or {}, name, definition)  # every field there, of its type


def test_proto_keeps_declared_defaults():
    value = yaml.safe_load(_run("proto", "geometry_msgs/msg/Quaternion", "--no-quotes"))
    assert value == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def test_list_and_a_type_registered_at_run_time():
    register_definition("my_msgs/msg/Probe", "float64 depth\ngeometry_msgs/Point where  # seen\n")
    text = _run("list")
    msgs, _, srvs = text.partition("Services:\n")
    assert [ln.strip() for ln in msgs.splitlines()[1:]] == message_types()
    assert [ln.strip() for ln in srvs.splitlines()] == service_types()
    assert "my_msgs/msg/Probe" in msgs
    assert _run("show", "my_msgs/Probe").splitlines() == ["float64 depth", "geometry_msgs/Point where  # seen",
                                                          "\tfloat64 x", "\tfloat64 y", "\tfloat64 z"]


def test_interface_cli_as_a_process():
    proc = zentf(["interface", "show", "geometry_msgs/TransformStamped"], None)
    assert proc.returncode == 0, proc.stderr
    assert "\tbuiltin_interfaces/Time stamp" in proc.stdout and "\t\tfloat64 w 1" in proc.stdout
    bad = zentf(["interface", "show", "geometry_msgs/msg/Pointt"], None)
    assert bad.returncode == 2 and "did you mean geometry_msgs/msg/Point" in bad.stderr, bad.stderr
