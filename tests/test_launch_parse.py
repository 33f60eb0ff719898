"""Launch files: arguments, substitutions, groups, includes, params and the file:line refusals."""
from __future__ import annotations

import os
import resource
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from zentf.launch import LaunchError, load_launch
from zentf.launch.cli import format_description
from zentf.launch.description import resolve_launch_file

REPO = Path(__file__).resolve().parent.parent


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return str(path)


def refused(path: str, args: list[str] | None = None) -> LaunchError:
    with pytest.raises(LaunchError) as info:
        load_launch(path, args or [])
    return info.value


def by_name(desc) -> dict:
    return {n.full_name: n for n in desc.nodes}


def test_args_defaults_overrides_and_typed_substitution(tmp_path):
    f = write(tmp_path, "a.yaml", """
        args:
          static: {default: false, description: fly or not}
          rate: 50
          label: {default: "hello $(arg rate)"}
        nodes:
          - cmd: [true]
            name: n
            parameters: {static: $(arg static), rate: $(arg rate), quoted: "$(arg rate)", label: $(arg label)}
        """)
    p = by_name(load_launch(f))["n"].parameters
    assert p == {"static": False, "rate": 50, "quoted": "50", "label": "hello 50"}
    desc = load_launch(f, ["static:=true", "rate:=12.5"])
    assert by_name(desc)["n"].parameters["static"] is True
    assert by_name(desc)["n"].parameters["rate"] == 12.5
    assert desc.args == {"static": "true", "rate": "12.5", "label": "hello 12.5"}


def test_unknown_and_missing_args_are_refused_with_the_line(tmp_path):
    f = write(tmp_path, "a.yaml", """
        # comment
        args:
          need: {description: no default}
        nodes: []
        """)
    e = refused(f, ["need:=1", "nope:=2"])
    assert (e.line, "unknown argument 'nope'" in e.message) == (2, True)
    e = refused(f)
    assert e.line == 3 and "'need' is required" in e.message
    with pytest.raises(LaunchError, match="expected name:=value"):
        load_launch(f, ["need=1"])


def test_env_dirname_and_nested_substitutions(tmp_path, monkeypatch):
    monkeypatch.setenv("ZT_SET", "from-env")
    monkeypatch.delenv("ZT_UNSET", raising=False)
    f = write(tmp_path, "a.yaml", """
        args: {fallback: dflt}
        nodes:
          - cmd: [echo, $(env ZT_SET), $(env ZT_UNSET $(arg fallback)), $(optenv ZT_UNSET), $(dirname)/x]
            name: n
        """)
    n = by_name(load_launch(f))["n"]
    assert n.cmd == ["echo", "from-env", "dflt", "", f"{tmp_path}/x"]


@pytest.mark.parametrize("value, message", [
    ("$(arg nope)", "unknown argument 'nope'"),
    ("$(env ZT_SURELY_UNSET)", "is not set"),
    ("$(foo bar)", "unknown substitution"),
    ("$(arg x", "unclosed"),
    ("$()", "empty substitution"),
])
def test_bad_substitutions_name_their_line(tmp_path, value, message, monkeypatch):
    monkeypatch.delenv("ZT_SURELY_UNSET", raising=False)
    f = write(tmp_path, "a.yaml", f"""
        args: {{x: 1}}
        nodes:
          - name: n
            cmd: [echo, ok]
            parameters:
              p: "{value}"
        """)
    e = refused(f)
    assert e.line == 6 and message in e.message, str(e)
    assert str(e).startswith(f"{e.file}:6: ")


def test_yaml_errors_unknown_keys_and_bad_values_name_their_line(tmp_path):
    cases = {
        "nodes:\n  - name: a\n    cmd: [true\n  - name: b\n": (4, "YAML error"),
        "nodes:\n  - cmd: [true]\n    respawnn: true\n": (3, "unknown key 'respawnn'"),
        "nodez: []\n": (1, "unknown key 'nodez'"),
        "nodes:\n  - module: nodes.surely_not_a_module\n": (2, "no module named"),
        "nodes:\n  - cmd: [zt-surely-not-a-program]\n": (2, "program not found"),
        "nodes:\n  - name: a\n": (2, "exactly one program"),
        "nodes:\n  - cmd: [true]\n    respawn: maybe\n": (3, "expected true or false"),
        "nodes:\n  - cmd: [true]\n    respawn_delay: -1\n": (3, "must be >= 0"),
        "nodes:\n  - cmd: [true]\n    output: file\n": (3, "screen or log"),
        "nodes:\n  - cmd: [true]\n    name: a/b\n": (3, "bad node name"),
        "nodes:\n  - cmd: [true]\n    namespace: 'a b'\n": (3, "bad namespace"),
        "nodes:\n  - cmd: [true]\n    required: true\n    respawn: true\n": (2, "both required"),
        "nodes:\n  - cmd: [true]\n    name: x\n  - cmd: [true]\n    name: x\n": (4, "already used"),
        "nodes:\n  - cmd: [true]\n    a: 1\n    a: 2\n": (4, "duplicate key"),
        "clock: {rate: 0}\n": (1, "must be > 0"),
        "clock: {speed: 2}\n": (1, "unknown key 'speed'"),
        "nodes: {a: 1}\n": (1, "must be a list"),
        "- just a list\n": (1, "must be a mapping"),
        "": (1, "empty launch file"),
    }
    for i, (text, (line, message)) in enumerate(cases.items()):
        f = tmp_path / f"c{i}.yaml"
        f.write_text(text)
        e = refused(str(f))
        assert (e.line, message in e.message) == (line, True), f"{text!r} -> {e}"


def test_groups_namespaces_env_conditions_and_remappings(tmp_path):
    f = write(tmp_path, "a.yaml", """
        args: {second: false}
        env: {TOP: t}
        nodes:
          - {cmd: [true], name: root_node, remappings: {tf: /shared/tf}}
        groups:
          - namespace: r1
            env: {GROUP: g}
            nodes:
              - {cmd: [true], name: a, namespace: sub, remappings: ["scan:=base_scan"]}
              - {cmd: [true], name: abs, namespace: /elsewhere}
            groups:
              - namespace: inner
                nodes: [{cmd: [true], name: deep, env: {OWN: o}}]
          - namespace: r2
            if: $(arg second)
            nodes: [{cmd: [true], name: skipped}]
          - nodes:
              - {cmd: [true], name: kept, unless: $(arg second)}
              - {cmd: [true], name: dropped, if: "false"}
        """)
    nodes = by_name(load_launch(f))
    assert sorted(nodes) == ["elsewhere/abs", "kept", "r1/inner/deep", "r1/sub/a", "root_node"]
    assert nodes["root_node"].remappings == {"tf": "/shared/tf"}
    assert nodes["r1/sub/a"].remappings == {"scan": "base_scan"}
    assert nodes["r1/inner/deep"].env == {"TOP": "t", "GROUP": "g", "OWN": "o"}
    assert nodes["r1/inner/deep"].namespace == "r1/inner"
    env = nodes["r1/sub/a"].child_env()
    assert (env["ZENTF_NODE_NAME"], env["ZENTF_NAMESPACE"]) == ("a", "r1/sub")
    assert env["ZENTF_REMAP"] == '{"scan":"base_scan"}'
    nodes = by_name(load_launch(f, ["second:=true"]))
    assert "r2/skipped" in nodes and "kept" not in nodes
    ns = by_name(load_launch(f, namespace="t_1"))
    assert sorted(ns) == ["elsewhere/abs", "t_1/kept", "t_1/r1/inner/deep", "t_1/r1/sub/a", "t_1/root_node"]


def test_include_passes_args_and_namespace_and_refuses_unknown_args_and_cycles(tmp_path):
    write(tmp_path, "part.yaml", """
        args: {who: {description: required}, n: 1}
        nodes:
          - {cmd: [echo, $(arg who)], name: part_$(arg n)}
        """)
    f = write(tmp_path, "top.yaml", """
        args: {name: bob}
        include:
          - file: part.yaml
            args: {who: $(arg name)}
          - file: $(dirname)/part.yaml
            namespace: ns2
            args: {who: carol, n: 2}
        """)
    nodes = by_name(load_launch(f))
    assert nodes["part_1"].cmd == ["echo", "bob"]
    assert nodes["ns2/part_2"].cmd == ["echo", "carol"]
    bad = write(tmp_path, "bad.yaml", """
        include:
          - file: part.yaml
            args: {who: x, whom: y}
        """)
    e = refused(bad)
    assert e.file.endswith("bad.yaml") and e.line == 3 and "unknown argument 'whom'" in e.message
    e = refused(write(tmp_path, "miss.yaml", "include:\n  - file: nope.yaml\n"))
    assert e.line == 2 and "not found" in e.message
    write(tmp_path, "loop_a.yaml", "include:\n  - file: loop_b.yaml\n")
    write(tmp_path, "loop_b.yaml", "include:\n  - file: loop_a.yaml\n")
    e = refused(str(tmp_path / "loop_a.yaml"))
    assert "include cycle" in e.message and e.line == 2
    write(tmp_path, "with_clock.yaml", "clock: {rate: 2}\n")
    e = refused(write(tmp_path, "inc_clock.yaml", "include:\n  - file: with_clock.yaml\n"))
    assert "only allowed in the top-level" in e.message


def test_params_file_plain_and_ros2_style_inline_wins(tmp_path):
    write(tmp_path, "plain.yaml", "a: 1\nb: two\n")
    write(tmp_path, "ros.yaml", """
        /**:
          ros__parameters: {a: 10, c: 3}
        n2:
          ros__parameters: {b: own}
        other:
          ros__parameters: {b: not_mine}
        """)
    f = write(tmp_path, "a.yaml", """
        nodes:
          - {cmd: [true], name: n1, params_file: plain.yaml, parameters: {b: inline}}
          - {cmd: [true], name: n2, params_file: $(dirname)/ros.yaml}
          - {cmd: [true], name: n3, params_file: missing.yaml}
        """)
    e = refused(f)
    assert e.line == 4 and "params file not found" in e.message
    Path(f).write_text("\n".join(Path(f).read_text().splitlines()[:3]) + "\n")
    nodes = by_name(load_launch(f))
    assert nodes["n1"].parameters == {"a": 1, "b": "inline"}
    assert nodes["n2"].parameters == {"a": 10, "c": 3, "b": "own"}
    write(tmp_path, "broken.yaml", "a: [1\n")
    e = refused(write(tmp_path, "b.yaml", "nodes:\n  - {cmd: [true], params_file: broken.yaml}\n"))
    assert e.file.endswith("broken.yaml") and e.line == 2


def test_clock_section_sets_use_sim_time_unless_given(tmp_path):
    f = write(tmp_path, "a.yaml", """
        clock: {rate: 10, frequency: 50, paused: true, start: 100}
        nodes:
          - {cmd: [true], name: a}
          - {cmd: [true], name: b, parameters: {use_sim_time: false}}
        """)
    desc = load_launch(f)
    assert (desc.clock.rate, desc.clock.frequency, desc.clock.paused, desc.clock.start) == (10, 50, True, 100)
    nodes = by_name(desc)
    assert nodes["a"].parameters == {"use_sim_time": True}
    assert nodes["b"].parameters == {"use_sim_time": False}
    assert load_launch(write(tmp_path, "b.yaml", "clock:\nnodes: []\n")).clock.start is None


def test_module_programs_and_bare_names_resolve():
    assert resolve_launch_file("drones", cwd="/") == str(REPO / "configs" / "drones.yaml")
    with pytest.raises(LaunchError, match="no launch file named 'surely_not_there'"):
        resolve_launch_file("surely_not_there", cwd="/")
    desc = load_launch("drones", ["static:=true"])
    fp = by_name(desc)["frames_publisher"]
    assert fp.cmd == [sys.executable, "-m", "zentf.demos.frames_publisher"]
    assert fp.parameters["static"] is True


@pytest.mark.parametrize("name, expected", [
    ("drones", {"frames_publisher", "plots_publisher"}),
    ("laser", {"laser_static", "camera_static", "point_publisher", "frame_listener", "point_listener"}),
    ("turtles", {"turtlesim", "turtle1_tf_broadcaster", "turtle2_tf_broadcaster", "follower", "teleop"}),
    ("multi_robot", {f"{r}/{n}" for r in ("robot1", "robot2") for n in
                     ("base_static", "laser_static", "camera_static", "point_publisher", "frame_listener",
                      "point_listener")}),
])
def test_demo_launch_files_resolve(name, expected):
    desc = load_launch(name)
    assert {n.full_name for n in desc.nodes} == expected
    text = format_description(desc)
    assert all(f"name: /{n}\n" in text for n in expected)


def test_multi_robot_frames_are_prefixed_per_robot():
    nodes = by_name(load_launch("multi_robot"))
    assert nodes["robot2/base_static"].cmd[-4:] == ["--frame-id", "world", "--child-frame-id", "robot2/base_link"]
    assert nodes["robot1/point_listener"].parameters == {"target_frame": "robot1/base_link"}
    assert nodes["robot2/point_publisher"].parameters == {"frame_id": "robot2/laser"}


def test_cli_refuses_a_bad_file_in_one_line_before_starting_anything(tmp_path):
    marker = tmp_path / "started"
    f = write(tmp_path, "bad.yaml", f"""
        nodes:
          - cmd: [touch, {marker}]
            name: first
          - cmd: [true]
            name: second
            colour: red
        """)
    r = subprocess.run([sys.executable, "-m", "zentf.launch", f], capture_output=True, text=True, timeout=60,
                       cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr == "bad.yaml:6: unknown key 'colour' in node (allowed: " + \
        ", ".join(__import__("zentf.launch.description", fromlist=["x"]).NODE_KEYS) + ")\n"
    assert not marker.exists()
    r = subprocess.run([sys.executable, "-m", "zentf.launch", f, "nope:=1"], capture_output=True, text=True,
                       timeout=60, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("bad.yaml:1: unknown argument 'nope'")
    assert len(r.stderr.splitlines()) == 1


def test_cli_print_and_show_args(tmp_path):
    env = {**os.environ, "ZENTF_NAMESPACE": ""}
    r = subprocess.run([sys.executable, "-m", "zentf.launch", "--print", "drones", "static:=true",
                        "-n", "team"], capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stderr
    import yaml

    data = yaml.safe_load(r.stdout)
    names = [n["name"] for n in data["nodes"]]
    assert names == ["/team/frames_publisher", "/team/plots_publisher"]
    assert data["nodes"][0]["parameters"] == {"static": True, "rate": 50}
    r = subprocess.run([sys.executable, "-m", "zentf.launch", "drones", "--show-args"], capture_output=True,
                       text=True, timeout=60, env=env)
    assert r.returncode == 0 and "static  default: 'false'" in r.stdout
    r = subprocess.run([sys.executable, "-m", "zentf.launch", "robot", "--show-args"], capture_output=True,
                       text=True, timeout=60, env=env)  # a required arg does not stop --show-args
    assert r.returncode == 0 and "robot  (required)" in r.stdout, r.stderr


def test_zentf_cli_delegates_launch_and_refuses_bad_zenoh_options(tmp_path):
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "launch", "laser", "--print"], capture_output=True,
                       text=True, timeout=60, cwd=tmp_path)
    assert r.returncode == 0 and "name: /frame_listener" in r.stdout, r.stderr
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "launch", "laser", "--connect", "nonsense"],
                       capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert r.returncode == 2 and "bad endpoint 'nonsense'" in r.stderr and len(r.stderr.splitlines()) == 1
    (tmp_path / "bad.yaml").write_text("nodes:\n  - cmd: [true]\n    bad: 1\n")
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "launch", "bad.yaml"], capture_output=True, text=True,
                       timeout=60, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("bad.yaml:3: unknown key 'bad' in node")
    assert len(r.stderr.splitlines()) == 1


def test_mangled_launch_files_are_refused_in_one_line_never_crash(tmp_path):
    """Seeded mutations of the shipped files: every outcome is a result or a one-line LaunchError."""
    import random

    sources = [(REPO / "configs" / f"{n}.yaml").read_text() for n in ("drones", "laser", "turtles", "multi_robot")]
    for name in ("laser.yaml", "robot.yaml"):
        (tmp_path / name).symlink_to(REPO / "configs" / name)
    snippets = ["\n  - {cmd: [true], name: n$(arg x)}\n", "clock: {rate: nan}\n", "args: [1, 2]\n", "nodes: [[]]\n",
                "parameters: {a: .inf}\n", "$(", ")", ":", "- ", "{", "}", "[", "]", "\t", "&a ", "*a", "? ",
                "<<: *a", "!!python/object:os.system x", "\x00", "respawn_max: -3", "namespace: /", "if: maybe",
                "  env: {1: 2}\n", "remappings: ['a:=']\n", "arguments: [{a: 1}]\n", "frequency: 1e9\n"]
    rng = random.Random(4)
    path = tmp_path / "f.yaml"
    outcomes = {"ok": 0, "refused": 0}
    for _ in range(400):
        text = rng.choice(sources)
        for _ in range(rng.randint(1, 4)):
            pos = rng.randint(0, len(text))
            op = rng.random()
            if op < 0.4:
                text = text[:pos] + rng.choice(snippets) + text[pos:]
            elif op < 0.7:
                text = text[:pos] + text[pos + rng.randint(1, 20):]
            else:
                text = text[:pos] + chr(rng.randint(32, 126)) + text[pos:]
        path.write_text(text)
        try:
            load_launch(str(path), ["robot:=r"] if rng.random() < 0.5 else [])
            outcomes["ok"] += 1
        except LaunchError as e:
            assert "\n" not in str(e) and str(e).startswith(str(path)), repr(str(e))
            outcomes["refused"] += 1
    assert outcomes["ok"] > 20 and outcomes["refused"] > 100, outcomes


def test_a_yaml_alias_bomb_is_refused_in_one_line_quickly_in_bounded_memory(tmp_path):
    """The "billion laughs": nine levels of nine aliases (9^9 values once expanded, 265 MB after 15 s
    before the fix); the first alias is refused where it stands, before anything is expanded."""
    levels = ["l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    levels += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 9)}]" for i in range(1, 9)]
    f = write(tmp_path, "bomb.yaml", "\n".join(levels) + "\nnodes: [{cmd: [true], parameters: {x: *l8}}]\n")
    t0 = time.monotonic()
    # bounded memory: the child may not map more than 512 MB (a child's ru_maxrss would include the
    # test worker's own size at fork, inherited across exec, so it cannot tell)
    limit = lambda: resource.setrlimit(resource.RLIMIT_AS, (512 << 20, 512 << 20))  # noqa: E731
    p = subprocess.Popen([sys.executable, "-m", "zentf.launch", f, "--print"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=limit)
    killer = threading.Timer(60, p.kill)  # a regression must fail, not hang the suite
    killer.start()
    try:
        out, err = p.stdout.read(), p.stderr.read()  # type: ignore[union-attr]
        status = p.wait()
    finally:
        killer.cancel()
        p.stdout.close(), p.stderr.close()  # type: ignore[union-attr]
    assert status == 2 and out == "", err
    assert err == "bomb.yaml:2: YAML alias *l0 is not allowed in a launch file " \
                  "(aliases can expand without bound; write the value out)\n"
    assert time.monotonic() - t0 < 30
    params = write(tmp_path, "params.yaml", "base: &b {gain: 1}\nother: *b\n")  # params files too
    g = write(tmp_path, "g.yaml", f"nodes: [{{cmd: [true], params_file: {params}}}]\n")
    assert str(refused(g)) == f"{params}:2: YAML alias *b is not allowed " \
                              "(aliases can expand without bound; write the value out)"
