"""Robot models built to break things: control characters in names, overflowing axes and mimics, a
100,000-link chain, names that try to choose where `urdf graph` writes. Each runs through the real
programs (`zentf urdf`, robot_state_publisher with a real router and a real listener process)."""
from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cli_helpers import ZENTF, assert_one_line_error, zentf
from conftest import REPO
from zentf.urdf import Kinematics, URDFError, load_urdf, parse_urdf

PROBE = str(REPO / "tests" / "tf_lookup_probe.py")
# what a hostile name carries: CR/LF with a forged log line, C1 controls (NEL, CSI), a bidi override
EVIL = "a&#13;&#10;[ERROR] forged&#x85;&#x9b;2J&#x202e;"


def _robot(tmp_path: Path, body: str, name: str = "r", file: str = "robot.urdf") -> Path:
    path = tmp_path / file
    path.write_text(f'<robot name="{name}">\n{body}\n</robot>\n')
    return path


# ----------------------------------------------------------------------------- names from the file
def test_check_prints_names_from_the_file_escaped(tmp_path: Path) -> None:
    path = _robot(tmp_path, f'<link name="{EVIL}"/><link name="b&#x9b;2J"/>'
                            f'<joint name="j&#13;x" type="revolute"><parent link="{EVIL}"/><child link="b&#x9b;2J"/>'
                            '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
                            f'<mimic joint="k&#10;[ERROR] y"/></joint>'
                            '<link name="c"/><joint name="k&#10;[ERROR] y" type="continuous"><parent link="b&#x9b;2J"/>'
                            '<child link="c"/></joint>', name=f"r{EVIL}")
    proc = zentf(["urdf", "check", str(path)], None)
    assert proc.returncode == 0, proc.stderr
    assert not any(raw in proc.stdout for raw in ("\r", "\x85", "\x9b", "\u202e")), repr(proc.stdout)
    assert not any(line.startswith("[ERROR]") for line in proc.stdout.splitlines()), proc.stdout
    assert "root Link: a\\r\\n[ERROR] forged\\x85\\x9b2J\\u202e has 1 child(ren)" in proc.stdout
    assert "mimic: j\\rx = 1 * k\\n[ERROR] y + 0" in proc.stdout


def test_a_duplicate_name_error_is_one_escaped_line(tmp_path: Path) -> None:
    path = _robot(tmp_path, f'<link name="{EVIL}"/>\n<link name="{EVIL}"/>')
    proc = zentf(["urdf", "check", str(path)], None)
    line = assert_one_line_error(proc, code=2)
    assert line.endswith("<link name='a\\r\\n[ERROR] forged\\x85\\x9b2J\\u202e'>: duplicate link name (first at "
                         "line 2)"), line
    assert not any(raw in proc.stderr for raw in ("\r", "\x85", "\x9b", "\u202e"))
    with pytest.raises(URDFError) as exc:
        load_urdf(path)
    assert "\n" not in str(exc.value) and "\r" not in str(exc.value)


# ----------------------------------------------------------------------------- axes
def test_axes_are_normalized_without_overflow_and_a_zero_axis_is_refused(tmp_path: Path) -> None:
    def axis(xyz: str) -> tuple:
        body = ('<link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
                f'<axis xyz="{xyz}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
        return parse_urdf(f'<robot name="r">{body}</robot>').joints["j"].axis

    h = math.sqrt(0.5)
    assert axis("1e200 1e200 0") == pytest.approx((h, h, 0.0))
    assert axis("1.7e308 -1.7e308 1.7e308") == pytest.approx((1 / math.sqrt(3), -1 / math.sqrt(3), 1 / math.sqrt(3)))
    assert axis("1e-320 0 0") == (1.0, 0.0, 0.0)
    assert axis("0 0 3") == (0.0, 0.0, 1.0)
    path = _robot(tmp_path, '<link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/>'
                            '<child link="b"/><axis xyz="0 0 -0"/><limit lower="-1" upper="1" effort="1" '
                            'velocity="1"/></joint>')
    assert_one_line_error(zentf(["urdf", "check", str(path)], None), 'the axis xyz="0 0 -0" is zero', code=2)


def test_an_overflowing_axis_gives_listeners_a_unit_rotation(spawn, node_options, tmp_path: Path) -> None:
    from zentf.core.messages import Header, JointState
    from zentf.core.time import Time
    from zentf import Node

    path = _robot(tmp_path, '<link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/>'
                            '<child link="b"/><axis xyz="1e200 1e200 0"/>'
                            '<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>')
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(path))
    rsp.wait_for_line(r"publishing robot 'r'", timeout=30)
    probe = spawn.python(PROBE, "a:b")
    probe.wait_for_line("probe ready", timeout=30)
    with Node("js_sender", options=node_options) as node:
        pub = node.create_publisher("joint_states", JointState)
        assert pub.wait_for_subscribers(10.0)
        pub.publish(JointState(Header(Time(1_700_000_000, 0)), ["j"], [1.0], [], []))
        line = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=30).string)
    h = math.sqrt(0.5) * math.sin(0.5)
    assert line["q"] == pytest.approx([h, h, 0.0, math.cos(0.5)], abs=1e-12)


# ----------------------------------------------------------------------------- mimics
def _mimic_robot(tmp_path: Path, multiplier: str, offset: str = "0", master: str = "continuous",
                 chain: str = "", file: str = "mimic.urdf") -> Path:
    limit = '<limit lower="-1e308" upper="1e308" effort="1" velocity="1"/>' if master == "revolute" else ""
    chain = chain or 'multiplier="1"'
    return _robot(tmp_path, '<link name="base"/><link name="m"/><link name="s"/><link name="t"/>'
                            f'<joint name="master" type="{master}"><parent link="base"/><child link="m"/>{limit}</joint>'
                            '<joint name="mim" type="continuous"><parent link="base"/><child link="s"/><axis xyz="0 0 1"/>'
                            f'<mimic joint="master" multiplier="{multiplier}" offset="{offset}"/></joint>'
                            '<joint name="mim2" type="continuous"><parent link="base"/><child link="t"/>'
                            f'<mimic joint="mim" {chain}/></joint>', file=file)


@pytest.mark.parametrize("case", ["multiplier", "offset_at_the_limit", "composed_chain"])
def test_a_mimic_that_can_leave_the_finite_range_is_refused_at_load(case: str, tmp_path: Path, zenoh_env) -> None:
    path = {"multiplier": lambda: _mimic_robot(tmp_path, "1e308"),
            "offset_at_the_limit": lambda: _mimic_robot(tmp_path, "1", "1.7e308", master="revolute"),
            "composed_chain": lambda: _mimic_robot(tmp_path, "1e200", chain='multiplier="1e200"')}[case]()
    joint = "mim2" if case == "composed_chain" else "mim"
    assert_one_line_error(zentf(["urdf", "check", str(path)], None), f"<joint name='{joint}'>: mimic multiplier",
                          "out of the finite range", code=2)
    for program in ("robot-state-publisher", "joint-state-publisher"):
        assert_one_line_error(zentf([program, str(path)], zenoh_env), "out of the finite range", code=2)


def test_a_mimic_overflowing_at_run_time_drops_that_joint_only(spawn, node_options, tmp_path: Path) -> None:
    from zentf.core.messages import Header, JointState
    from zentf.core.time import Time
    from zentf import Node

    path = _mimic_robot(tmp_path, "1e300")  # fine within the master's -pi..pi, not at 1e10 rad
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(path), "--ignore-timestamp")
    rsp.wait_for_line(r"publishing robot 'r'", timeout=30)
    probe = spawn.python(PROBE, "base:m", "base:s")
    probe.wait_for_line("probe ready", timeout=30)
    with Node("js_sender", options=node_options) as node:
        pub = node.create_publisher("joint_states", JointState)
        assert pub.wait_for_subscribers(10.0)
        pub.publish(JointState(Header(Time(1_700_000_000, 0)), ["master"], [1e10], [], []))
        first = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=30).string)
        # the master's frame came, at its huge (finite) value; the mimic's did not
        assert first["pair"] == "base:m" and first["q"] == pytest.approx([math.sin(5e9), 0, 0, math.cos(5e9)],
                                                                         abs=1e-9)
        for i in range(1, 30):
            pub.publish(JointState(Header(Time(1_700_000_000, i)), ["master"], [1e10 + i], [], []))
        pub.publish(JointState(Header(Time(1_700_000_001, 0)), ["master"], [0.5], [], []))
        while True:
            line = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=30).string)
            assert all(map(math.isfinite, line["q"])), line
            if line["pair"] == "base:s":
                break
    assert line["q"] == pytest.approx([0, 0, math.sin(0.5e300 / 2), math.cos(0.5e300 / 2)], abs=1e-9)
    drops = [ln for ln in rsp.lines if "left joint 'mim' out of a JointState" in ln]
    assert len(drops) == 1, rsp.output()  # 30 bad messages, one line (rate-limited)
    assert "as a mimic (1e+300 * 1" in drops[0] and "RuntimeWarning" not in rsp.output()


# ----------------------------------------------------------------------------- depth
N_CHAIN = 100_000


@pytest.fixture(scope="module")
def chain(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("chain") / "chain.urdf"
    parts = ['<robot name="chain">', '<link name="l0"/>']
    for i in range(1, N_CHAIN + 1):
        parts.append(f'<link name="l{i}"/><joint name="j{i}" type="revolute"><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0.001 0 0"/><axis xyz="0 0 1"/>'
                     '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    parts.append("</robot>")
    path.write_text("\n".join(parts))
    return path


@pytest.mark.slow
def test_a_100000_link_chain_checks_and_graphs(chain: Path, tmp_path: Path) -> None:
    proc = zentf(["urdf", "check", str(chain)], None, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    assert lines[-1] == f"{N_CHAIN + 1} links, {N_CHAIN} joints ({N_CHAIN} revolute)"
    assert lines[-2].endswith(f"[{N_CHAIN}] child(1):  l{N_CHAIN}  (revolute joint 'j{N_CHAIN}')")
    assert len(proc.stdout) < 80 * N_CHAIN * 4  # the indent stops growing: linear output
    env = {**os.environ, "PATH": ""}  # no dot: rendering 100,000 nodes is graphviz's business, not this test's
    proc = subprocess.run([*ZENTF, "urdf", "graph", str(chain), "-o", str(tmp_path / "chain")], env=env,
                          capture_output=True, text=True, timeout=300, cwd=str(REPO))
    assert proc.returncode == 0, proc.stderr[-2000:]
    gv = (tmp_path / "chain.gv").read_text()
    assert f'"joint:j{N_CHAIN}" -> "l{N_CHAIN}";' in gv


@pytest.mark.slow
def test_a_100000_link_chain_has_kinematics_a_publisher_and_a_view(chain: Path, node_options) -> None:
    robot = load_urdf(chain)
    kin = Kinematics(robot)
    poses = kin.link_poses()
    assert poses[f"l{N_CHAIN}"][:3, 3] == pytest.approx([N_CHAIN * 0.001, 0, 0])
    q = np.full((2, N_CHAIN), 1e-5)
    batch = kin.link_poses_batch(q[:, :N_CHAIN])
    assert batch.shape == (2, N_CHAIN + 1, 4, 4)
    assert np.abs(batch[0, -1] - kin.link_pose(f"l{N_CHAIN}", q[0])).max() < 1e-9
    # robot_state_publisher, in process: one JointState naming 70,000 joints (more than msgpack's 16-bit array)
    from zentf.transport.wire import codec as wire
    from zentf import Node
    from zentf.tools.robot_state_publisher import RobotStatePublisher

    with Node("rsp_chain", options=node_options) as node:
        rsp = RobotStatePublisher(node, robot)
        sent: list[dict] = []
        rsp._tf.publish_bytes = lambda p: sent.append(wire.unpack(p))
        names = [f"j{i}" for i in range(1, 70_001)]
        assert rsp.process(names, [0.1] * len(names), 100, 0)
        assert len(sent[-1]["transforms"]) == 70_000
        assert sent[-1]["transforms"][-1]["child_frame_id"] == "l70000"
    # the view: the model drawn on every frame, without recursion
    rr = pytest.importorskip("rerun")
    from zentf.tools.robot_view import RobotModelDisplay
    from zentf.tools.view import frame_path

    rec = rr.RecordingStream("zentf_chain_test")
    rec.memory_recording()
    display = RobotModelDisplay(rr, rec)
    display.set_description(chain.read_text())
    display.draw({f"l{i}" for i in range(N_CHAIN + 1)}, frame_path)
    assert display.robot is not None and len(display._drawn) == N_CHAIN + 1


@pytest.mark.slow
def test_a_100000_deep_mimic_chain_loads_in_linear_time(tmp_path: Path) -> None:
    parts = ['<robot name="mimics">', '<link name="l0"/>']
    for i in range(1, N_CHAIN + 1):
        mimic = f'<mimic joint="j{i - 1}" multiplier="1" offset="0.0"/>' if i > 1 else ""
        parts.append(f'<link name="l{i}"/><joint name="j{i}" type="continuous"><parent link="l0"/>'
                     f'<child link="l{i}"/>{mimic}</joint>')
    path = tmp_path / "mimics.urdf"
    path.write_text("\n".join(parts + ["</robot>"]))
    proc = zentf(["urdf", "check", str(path)], None, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    kin = Kinematics(load_urdf(path))
    assert kin.joint_names == ["j1"]
    assert kin.joint_positions({"j1": 0.25})[f"j{N_CHAIN}"] == 0.25


# ----------------------------------------------------------------------------- where graph writes
@pytest.mark.parametrize("name, stem", [("../../up", "_.._up"), ("{tmp}/abs_target", None),
                                        ("-O", "O"), ("-Tsvg -o/tmp/zentf_x", "Tsvg_-o_tmp_zentf_x"),
                                        ("..", "robot"), ("a&#10;b&#x85;c", "a_b_c")])
def test_graph_writes_a_plain_file_name_in_the_current_folder(name: str, stem: str, tmp_path: Path) -> None:
    cwd = tmp_path / "a" / "b"
    cwd.mkdir(parents=True)
    name = name.replace("{tmp}", str(tmp_path))
    model = _robot(tmp_path, '<link name="base"/>', name=name)
    proc = subprocess.run([*ZENTF, "urdf", "graph", str(model)], capture_output=True, text=True, timeout=120,
                          cwd=str(cwd), env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == 0, proc.stderr
    made = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert all(p.startswith("a/b/") or p == "robot.urdf" for p in made), made
    gv = [p for p in made if p.endswith(".gv")]
    assert len(gv) == 1 and "/" not in gv[0][len("a/b/"):], made
    stem = stem or gv[0][len("a/b/"):-len(".gv")]
    assert gv == [f"a/b/{stem}.gv"], made
    assert not Path("/tmp/zentf_x").exists()
    if shutil.which("dot") is None:
        if os.environ.get("CI"):
            pytest.fail("graphviz 'dot' is not installed")
        return
    assert (cwd / f"{stem}.pdf").read_bytes().startswith(b"%PDF"), proc.stderr
