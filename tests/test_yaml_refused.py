"""Every YAML zentf reads refuses aliases, anchors and tags, and is bounded in size and depth: command-line
data (`topic pub`, `service call`, `param set`, `-p name:=value`), params files, launch files and bag
metadata, each with one line, at once (an alias bomb used to spin at 100% CPU, growing ~30 MB/s)."""
from __future__ import annotations

import textwrap

import pytest
from cli_helpers import assert_one_line_error, zentf

#: The "billion laughs" in one flow mapping (about 300 characters): 9^9 strings once walked.
BOMB = "{" + "a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol], " + ", ".join(
    f"{b}: &{b} [{', '.join(['*' + a] * 9)}]" for a, b in zip("abcdefgh", "bcdefghi")) + ", data: *i}"


@pytest.mark.parametrize("args", [
    ["topic", "pub", "--once", "chatter", "std_msgs/msg/String", BOMB],
    ["service", "call", "spawn", "turtlesim/srv/Spawn", BOMB],
    ["param", "set", "/turtlesim", "rate", BOMB],
], ids=["topic-pub", "service-call", "param-set"])
def test_cli_data_with_aliases_is_refused_in_one_line(zenoh_env, args):
    r = zentf(args, zenoh_env, timeout=30)  # (before: still spinning at the timeout)
    assert_one_line_error(r, "YAML alias *a is not allowed", code=2)


@pytest.mark.parametrize("data, needle", [
    ("{data: !!binary aGVsbG8=}", "YAML tag !!binary is not allowed"),
    ("{data: &x hi}", "YAML anchor &x is not allowed"),
    ("{data: " + "[" * 100 + "]" * 100 + "}", "YAML nested deeper than 64 levels"),
], ids=["tag", "anchor", "deep"])
def test_cli_data_with_tags_anchors_depth_or_size_is_refused(zenoh_env, data, needle):
    assert_one_line_error(zentf(["topic", "pub", "--once", "chatter", "std_msgs/msg/String", data], zenoh_env),
                          needle, code=2)


def test_a_node_parameter_with_aliases_is_refused_in_one_line(spawn):
    p = spawn.python("-m", "nodes.frames_publisher", "-p", f"frame_prefix:={BOMB}")
    assert p.wait(30) in (1, 2)
    out = [line for line in p.lines if line.strip()]
    assert len(out) == 1 and "parameter frame_prefix: YAML alias *a is not allowed" in out[0], out


@pytest.mark.parametrize("text, needle", [
    ("/**:\n  ros__parameters:\n" + "".join(
        f"    {b}: &{b} [{', '.join(['*' + a] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi"))
     .replace("    b: &b", "    a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n    b: &b"),
     "YAML alias *a is not allowed"),
    ("/**:\n  ros__parameters:\n    rate: !!python/object/apply:os.system [true]\n", "YAML tag !!python/object"),
    ("/**:\n  ros__parameters:\n    big: " + "x" * (16 * 1024 * 1024) + "\n", "over the 16777216-character limit"),
], ids=["aliases", "tag", "huge"])
def test_a_params_file_with_aliases_or_tags_is_refused_in_one_line(spawn, tmp_path, text, needle):
    path = tmp_path / "params.yaml"
    path.write_text(text)
    p = spawn.python("-m", "nodes.frames_publisher", "--params-file", str(path))
    assert p.wait(30) in (1, 2)
    out = [line for line in p.lines if line.strip()]
    assert len(out) == 1 and needle in out[0] and "params.yaml:" in out[0], out


def test_bag_metadata_with_aliases_is_refused_in_one_line(tmp_path, zenoh_env):
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text(textwrap.dedent(f"""\
        rosbag2_bagfile_information:
          storage_identifier: sqlite3
          laughs: {BOMB}
        """))
    (bag / "bag_0.db3").write_bytes(b"")
    for args in (["bag", "info", str(bag)], ["tf", "echo", "--bag", str(bag), "a", "b"]):
        assert_one_line_error(zentf(args, zenoh_env, timeout=30), "metadata.yaml", "YAML alias *a is not allowed")


def test_a_launch_file_with_a_tag_or_an_anchor_is_refused(tmp_path, zenoh_env):
    for i, (text, needle) in enumerate([("nodes:\n  - cmd: !!python/name:os.system [true]\n", "YAML tag"),
                                        ("nodes:\n  - &n {cmd: [true]}\n", "YAML anchor &n")]):
        f = tmp_path / f"l{i}.launch.yaml"
        f.write_text(text)
        r = zentf(["launch", str(f)], zenoh_env, timeout=30)
        lines = r.stderr.strip().splitlines()
        assert r.returncode != 0 and len(lines) == 1 and f"l{i}.launch.yaml:2: {needle}" in lines[0], r.stderr
