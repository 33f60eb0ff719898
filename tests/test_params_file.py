"""Params files are read once, by ROS 2's rules, for node programs (--params-file, ZENTF_PARAMS_FILE) and
launch files (params_file:) alike: which sections apply to which node, in which order, and one line (with
the file's line where known) for what cannot be used."""
from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from zentf.launch import load_launch
from zentf.launch.errors import LaunchError
from zentf.transport.options import NodeOptions, OptionsError, ParamsFileError, load_params_file

RULES = """
/**:
  ros__parameters: {a: 0, every: 1}
talker:                    # no leading '/': the root namespace's talker only
  ros__parameters: {a: 1, root_talker: true}
/robot1/talker:
  ros__parameters: {a: 2}
robot1:                    # nested keys join with '/': /robot1/listener
  listener:
    ros__parameters: {a: 3, gains: {p: 1.5, i: 0.0}}
/**/talker:
  ros__parameters: {any_talker: true}
/robot1/*:
  ros__parameters: {in_robot1: true}
"""

EXPECTED = {
    "/talker": {"a": 1, "every": 1, "root_talker": True, "any_talker": True},
    "/robot1/talker": {"a": 2, "every": 1, "any_talker": True, "in_robot1": True},
    "/robot1/listener": {"a": 3, "every": 1, "gains.p": 1.5, "gains.i": 0.0, "in_robot1": True},
    "/robot2/talker": {"a": 0, "every": 1, "any_talker": True},
    "/robot1/arm/talker": {"a": 0, "every": 1, "any_talker": True},   # '*' is one name, '**' any number
    "/robot1": {"a": 0, "every": 1},
}


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return str(path)


@pytest.mark.parametrize("fqn", sorted(EXPECTED))
def test_sections_apply_to_the_nodes_their_keys_name(tmp_path, fqn) -> None:
    assert load_params_file(write(tmp_path, "p.yaml", RULES), fqn) == EXPECTED[fqn]


def test_matching_sections_apply_in_file_order_a_later_one_wins(tmp_path) -> None:
    wildcard_last = write(tmp_path, "p.yaml", """
        /robot1/talker: {ros__parameters: {a: 2}}
        /**: {ros__parameters: {a: 0}}
        """)
    assert load_params_file(wildcard_last, "/robot1/talker") == {"a": 0}


def test_a_flat_file_is_every_nodes(tmp_path) -> None:
    flat = write(tmp_path, "p.yaml", "rate: 5\ngains: {p: 1}\n")
    assert load_params_file(flat, "/a/b") == load_params_file(flat, "/c") == {"rate": 5, "gains.p": 1}


@pytest.mark.parametrize("text,line,what", [
    ("a: [1\n", 2, "bad YAML"),
    ("base: &b {x: 1}\ntalker: {ros__parameters: *b}\n", 2, "YAML alias *b is not allowed"),
    ("- 1\n", None, "expected a mapping at top level"),
    ("talker: {ros__parameters: [1, 2]}\n", None, "ros__parameters of 'talker' must be a mapping"),
    ("talker: {ros__parameters: {a: 1}}\nrate: 5\n", None, "'rate' is outside any ros__parameters section"),
    ("ros__parameters: {a: 1}\n", None, "ros__parameters must be under a node name"),
    ("'/ns/tal ker': {ros__parameters: {a: 1}}\n", None, "bad node name '/ns/tal ker'"),
])
def test_what_cannot_be_used_is_one_line_naming_the_file(tmp_path, text, line, what) -> None:
    path = write(tmp_path, "bad.yaml", text)
    with pytest.raises(ParamsFileError) as info:
        load_params_file(path, "/talker")
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"params file {path}{f':{line}' if line else ''}: ")
    assert what in message, message


def test_node_options_and_launch_files_read_the_same_sections(tmp_path) -> None:
    params = write(tmp_path, "p.yaml", RULES)
    launch = write(tmp_path, "a.yaml", f"""
        nodes:
          - {{cmd: [true], name: talker, params_file: {params}}}
          - {{cmd: [true], name: talker, namespace: robot1, params_file: {params}}}
          - {{cmd: [true], name: listener, namespace: robot1, params_file: {params}}}
          - {{cmd: [true], name: talker, namespace: robot2, params_file: {params}}}
        """)
    nodes = {f"/{n.full_name}": n for n in load_launch(launch).nodes}
    assert set(nodes) == {"/talker", "/robot1/talker", "/robot1/listener", "/robot2/talker"}
    for fqn, node in nodes.items():
        assert node.parameters == EXPECTED[fqn], fqn
        name, ns = fqn.rsplit("/", 1)[1], fqn.rsplit("/", 1)[0]
        opts = NodeOptions.from_env({"ZENTF_PARAMS_FILE": params, "ZENTF_NODE_NAME": name, "ZENTF_NAMESPACE": ns})
        assert opts.resolved_params() == EXPECTED[fqn], fqn


def test_a_launch_file_names_the_params_files_own_line(tmp_path) -> None:
    write(tmp_path, "bad.yaml", "a: 1\nb: &x 2\nc: *x\n")
    launch = write(tmp_path, "a.yaml", "nodes:\n  - {cmd: [true], name: n, params_file: bad.yaml}\n")
    with pytest.raises(LaunchError) as info:
        load_launch(launch)
    assert info.value.file.endswith("bad.yaml") and info.value.line == 3, str(info.value)
    assert "alias *x is not allowed" in info.value.message


def test_a_node_in_a_namespace_takes_its_sections(node_options, test_namespace, tmp_path) -> None:
    from zentf.transport.node import Node

    path = write(tmp_path, "p.yaml", """
        talker: {ros__parameters: {rate: 1.0}}
        /**/talker: {ros__parameters: {frame: map}}
        """)
    with Node("talker", options=node_options.with_(params_file=path)) as node:
        assert node.get_namespace() == f"/{test_namespace}"
        assert node.declare_parameter("frame", "").value == "map"
        assert node.declare_parameter("rate", 5.0).value == 5.0  # `talker` is /talker, not this one


def test_a_missing_params_file_is_refused_before_start() -> None:
    with pytest.raises(OptionsError, match="params file not found: /nowhere.yaml"):
        NodeOptions.from_env({"ZENTF_PARAMS_FILE": "/nowhere.yaml"})
