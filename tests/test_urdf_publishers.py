"""robot_state_publisher + joint_state_publisher as real processes, seen by real listener processes."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from cli_helpers import assert_one_line_error, zentf
from conftest import REPO
from zentf.urdf import Kinematics, load_urdf

DATA = REPO / "tests" / "data" / "urdf"
R2D2 = DATA / "urdf_tutorial" / "urdf" / "06-flexible.urdf"
BURGER = DATA / "turtlebot3_burger.urdf"
MY_ROBOT = REPO / "configs" / "robots" / "my_robot.urdf"
PROBE = str(REPO / "tests" / "tf_lookup_probe.py")


def _matrix(t: list[float], q: list[float]) -> np.ndarray:
    x, y, z, w = q
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = t
    return m


def _wait_pairs(probe, pairs: set[str], timeout: float = 30.0) -> dict[str, dict]:
    """The first line of each pair from a tf_lookup_probe process."""
    got: dict[str, dict] = {}
    while set(got) != pairs:
        line = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=timeout).string)
        got.setdefault(line["pair"], line)
    return got


def test_rsp_and_jsp_processes_give_a_listener_the_fk_frames(spawn, zenoh_args) -> None:
    values = {"right_front_wheel_joint": 0.7, "gripper_extension": -0.21, "left_gripper_joint": 0.33,
              "head_swivel": -0.82}
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(R2D2))
    rsp.wait_for_line(r"publishing robot 'visual' \(16 links\): 7 fixed joints on tf_static, 8 movable", timeout=30)
    jsp = spawn.python("-m", "nodes.joint_state_publisher", str(R2D2),
                       *[a for n, v in values.items() for a in ("--set", f"{n}={v}")])
    jsp.wait_for_line(r"publishing joint_states of robot 'visual': 8 movable joints at 10 Hz", timeout=30)
    pairs = {"base_link:right_front_wheel", "base_link:left_gripper", "base_link:left_tip", "base_link:box"}
    probe = spawn.python(PROBE, *sorted(pairs))
    got = _wait_pairs(probe, pairs)
    kin = Kinematics(load_urdf(R2D2))
    poses = kin.link_poses(values)
    for pair, line in got.items():
        link = pair.split(":")[1]
        assert np.abs(_matrix(line["t"], line["q"]) - poses[link]).max() < 1e-9, (pair, line)
    # a listener that joins late, listening to tf_static only, still gets every fixed joint
    late = spawn.python(PROBE, "--static-only", "base_link:right_base", "left_gripper:left_tip", "head:box")
    got = _wait_pairs(late, {"base_link:right_base", "left_gripper:left_tip", "head:box"})
    assert got["base_link:right_base"]["t"] == pytest.approx([0, -0.22, -0.35])
    assert got["head:box"]["t"] == pytest.approx([0.1814, 0, 0.1414])


def test_stamp_mimic_prefix_and_unknown_joints(spawn, node_options) -> None:
    from zentf.core.messages import Header, JointState
    from zentf.core.time import Time
    from zentf.transport.node import Node

    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(MY_ROBOT), "--frame-prefix", "r1/",
                       "-p", "publish_frequency:=1000")
    rsp.wait_for_line(r"publishing robot 'my_robot'", timeout=30)
    probe = spawn.python(PROBE, "r1/gripper_pole:r1/right_gripper", "r1/base_link:r1/gripper_pole")
    probe.wait_for_line("probe ready", timeout=30)
    with Node("js_sender", options=node_options) as node:
        pub = node.create_publisher("joint_states", JointState)
        assert pub.wait_for_subscribers(10.0)
        stamp = Time(1_700_000_000, 123_456_789)
        pub.publish(JointState(Header(stamp), ["left_gripper_joint", "gripper_extension", "bogus"],
                               [0.4, -0.1, 1.0], [], []))
        got = _wait_pairs(probe, {"r1/gripper_pole:r1/right_gripper", "r1/base_link:r1/gripper_pole"})
        right = got["r1/gripper_pole:r1/right_gripper"]
        assert right["stamp"] == stamp.nanoseconds            # the JointState's stamp, not now
        assert right["t"] == pytest.approx([0.2, -0.01, 0])
        # mimic: right_gripper_joint = left_gripper_joint, about -z
        assert right["q"] == pytest.approx([0, 0, -math.sin(0.2), math.cos(0.2)], abs=1e-12)
        assert got["r1/base_link:r1/gripper_pole"]["t"] == pytest.approx([0.09, 0, 0.2])
        for i in range(20):  # a flood of unknown names: one warning
            pub.publish(JointState(Header(Time(1_700_000_001, i)), ["bogus"], [0.0], [], []))
        pub.publish(JointState(Header(Time(1_700_000_002, 0)), ["left_gripper_joint"], [0.1], [], []))
        while True:
            line = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=30).string)
            if line["pair"] == "r1/gripper_pole:r1/right_gripper" and line["stamp"] == Time(1_700_000_002, 0).nanoseconds:
                break
    warnings = [ln for ln in rsp.lines if "unknown joint 'bogus'" in ln]
    assert len(warnings) == 1, rsp.output()


def test_missing_meshes_do_not_stop_the_publisher_and_robot_description_is_latched(spawn, node_options) -> None:
    from zentf.core.messages import String
    from zentf.transport.node import Node

    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(BURGER))
    rsp.wait_for_line(r"publishing robot 'turtlebot3_burger' \(7 links\): 4 fixed joints", timeout=30)
    probe = spawn.python(PROBE, "--static-only", "base_footprint:base_scan")
    got = _wait_pairs(probe, {"base_footprint:base_scan"})
    assert got["base_footprint:base_scan"]["t"] == pytest.approx([-0.032, 0, 0.182])
    received: list[str] = []
    done = threading.Event()
    with Node("description_reader", options=node_options) as node:
        node.create_subscription("robot_description", String,
                                 lambda m: (received.append(m.data), done.set()), latched=True)
        assert done.wait(20), "robot_description was not delivered to a late subscriber"
    assert received[0] == BURGER.read_text()
    assert rsp.returncode is None


def _broken_my_robot(tmp_path: Path) -> tuple[Path, int]:
    text = MY_ROBOT.read_text()
    broken = text.replace('<parent link="base_link"/>\n    <child link="gripper_pole"/>',
                          '<parent link="gripper_pole"/>\n    <child link="gripper_pole"/>')
    path = tmp_path / "my_robot_broken.urdf"
    path.write_text(broken)
    return path, 1 + broken[:broken.index('<joint name="gripper_extension"')].count("\n")


@pytest.mark.parametrize("program", ["robot_state_publisher", "joint_state_publisher"])
def test_malformed_urdf_refused_before_anything_starts(program, tmp_path, zenoh_env) -> None:
    path, line = _broken_my_robot(tmp_path)
    expected = f"{path}:{line}: <joint name='gripper_extension'>: parent and child are the same link 'gripper_pole'"
    proc = subprocess.run([sys.executable, "-m", f"nodes.{program}", str(path)], env=zenoh_env, cwd=str(REPO),
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.splitlines() == [f"{program}: error: {expected}"]
    cli = zentf([program.replace("_", "-"), str(path)], zenoh_env)
    assert_one_line_error(cli, expected, code=2)
    assert cli.stdout == ""


def test_joint_state_publisher_start_errors(zenoh_env) -> None:
    for args, needle in [
        (["--set", "head_swivel=abc"], "--set head_swivel=abc: 'abc' is not a number"),
        (["--set", "nope=1"], "'nope' is not a movable joint of robot 'visual'"),
        (["--set", "gripper_extension=0.5"], "outside the joint's range [-0.38, 0]"),
        (["--sweep", "--gui"], "--sweep and --gui exclude each other"),
        (["--bogus"], "unrecognized arguments: --bogus"),
    ]:
        proc = zentf(["joint-state-publisher", str(R2D2), *args], zenoh_env)
        assert_one_line_error(proc, needle, code=2)
    # no file, no parameter, and nobody publishes robot_description: one line after the wait
    proc = zentf(["joint-state-publisher", "--description-timeout", "0.5"], zenoh_env)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert proc.stderr.splitlines()[-1].startswith("joint_state_publisher: error: no robot model: nothing on /t_")


def test_joint_state_publisher_takes_the_model_from_robot_description(spawn) -> None:
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(R2D2))
    rsp.wait_for_line("publishing robot 'visual'", timeout=30)
    jsp = spawn.python("-m", "nodes.joint_state_publisher", "--set", "head_swivel=0.6")
    jsp.wait_for_line(r"waiting for the robot model on /t_\w+/robot_description", timeout=30)
    jsp.wait_for_line("publishing joint_states of robot 'visual': 8 movable joints", timeout=30)
    probe = spawn.python(PROBE, "base_link:head")
    while True:
        line = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=30).string)
        if line["q"][2] == pytest.approx(math.sin(0.3)):
            break


def test_urdf_check_and_graph(tmp_path) -> None:
    proc = zentf(["urdf", "check", str(R2D2)], None)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout.splitlines()
    assert out[0] == "robot name is: visual"
    assert out[2] == "root Link: base_link has 4 child(ren)"
    assert "        child(1):  right_base  (fixed joint 'right_base_joint')" in out
    assert "    child(3):  gripper_pole  (prismatic joint 'gripper_extension')" in out
    assert "16 links, 15 joints (5 continuous, 7 fixed, 1 prismatic, 2 revolute)" in out
    path, line = _broken_my_robot(tmp_path)
    assert_one_line_error(zentf(["urdf", "check", str(path)], None), f"{path}:{line}:", code=2)
    proc = zentf(["urdf", "graph", str(MY_ROBOT), "-o", str(tmp_path / "my_robot")], None)
    assert proc.returncode == 0, proc.stderr
    gv = (tmp_path / "my_robot.gv").read_text()
    assert '"base_link" -> "joint:gripper_extension" [label="xyz: 0.19 0 0.2 \\nrpy: 0 0 0"];' in gv
    assert '"joint:gripper_extension" -> "gripper_pole";' in gv
    if (tmp_path / "my_robot.pdf").exists():
        assert (tmp_path / "my_robot.pdf").read_bytes().startswith(b"%PDF")
    else:  # graphviz missing: the .gv alone, with the reason on stderr
        assert "dot" in proc.stderr


@pytest.mark.parametrize("wire_name", ["zentf", "ros2"])
def test_rsp_plans_mimics_throttle_and_bad_values(node_options, wire_name) -> None:
    """In process (the payloads captured before they leave): what one JointState turns into, through the
    compiled path of zentf's wire (zentf/tools/jointtf.pyx) and through numpy and the ros2 wire's CDR encoder."""
    from zentf.ros import codec as cdr_codec
    from zentf.transport.wire import codec as wire
    from zentf.transport.node import Node
    from zentf.tools.robot_state_publisher import RobotStatePublisher

    def read(payload: bytes) -> dict:
        if wire_name == "zentf":
            return wire.unpack(payload)
        return cdr_codec.decode(payload, "tf2_msgs/msg/TFMessage").to_dict()

    with Node("rsp_unit", options=node_options.with_(wire=wire_name)) as node:
        rsp = RobotStatePublisher(node, load_urdf(MY_ROBOT), publish_frequency=10.0)
        assert rsp._msgpack == (wire_name == "zentf")
        sent: list[dict] = []
        rsp._tf.publish_bytes = lambda p: sent.append(read(p))

        def children(i: int = -1) -> dict[str, dict]:
            return {t["child_frame_id"]: t for t in sent[i]["transforms"]}

        assert rsp.process(["left_gripper_joint"], [0.25], 100, 0)
        got = children()
        assert set(got) == {"left_gripper", "right_gripper"}        # the mimic follows its master
        assert got["right_gripper"]["header"]["stamp"] == {"sec": 100, "nanosec": 0}
        assert got["right_gripper"]["transform"]["rotation"]["z"] == pytest.approx(-math.sin(0.125))
        # a message that names the mimic joint itself: its own value, published once (no duplicate)
        assert rsp.process(["left_gripper_joint", "right_gripper_joint"], [0.25, 0.1], 101, 0)
        assert [t["child_frame_id"] for t in sent[-1]["transforms"]] == ["left_gripper", "right_gripper"]
        assert children()["right_gripper"]["transform"]["rotation"]["z"] == pytest.approx(-math.sin(0.05))
        # publish_frequency 10 Hz: a stamp 50 ms later is throttled, 100 ms later is not (by stamp)
        assert not rsp.process(["left_gripper_joint"], [0.3], 101, 50_000_000)
        assert rsp.process(["left_gripper_joint"], [0.3], 101, 100_000_000)
        # a name given twice: once, its first value
        assert rsp.process(["head_swivel", "head_swivel"], [0.5, 0.9], 102, 0)
        assert [t["child_frame_id"] for t in sent[-1]["transforms"]] == ["head"]
        assert children()["head"]["transform"]["rotation"]["z"] == pytest.approx(math.sin(0.25))
        # bad input: nothing published, counted
        n = len(sent)
        assert not rsp.process(["left_gripper_joint"], [float("nan")], 200, 0)
        assert not rsp.process(["left_gripper_joint", "head_swivel"], [0.1], 201, 0)
        assert not rsp.process(["bogus"], [1.0], 202, 0)
        assert len(sent) == n and rsp.ignored >= 3
        # frame ids and values equal FK for a full joint vector
        values = {"head_swivel": 0.4, "gripper_extension": -0.2, "left_front_wheel_joint": 2.0}
        assert rsp.process(list(values), list(values.values()), 300, 0)
        kin = Kinematics(rsp.robot)
        for child, t in children().items():
            j = rsp.robot.joints[rsp.robot.parent_joint[child]]
            tr = t["transform"]
            m = _matrix([tr["translation"][a] for a in "xyz"], [tr["rotation"][a] for a in "xyzw"])
            assert np.abs(m - kin.joint_transform(j.name, values[j.name])).max() < 1e-12
            assert t["header"]["frame_id"] == j.parent


def test_rsp_payload_equals_forward_kinematics(node_options) -> None:
    """The compiled filler's TFMessage equals the model's forward kinematics (frame ids, stamps, each
    joint's transform within 1e-12) for random joint subsets with unknown names and mimics, on a 30-joint
    chain and on my_robot."""
    from zentf.transport.wire import codec as wire
    from zentf.transport.node import Node
    from zentf.tools.robot_state_publisher import RobotStatePublisher
    from zentf.urdf import parse_urdf

    chain = ['<robot name="chain"><link name="l0"/>']
    for i in range(1, 31):
        kind = ("revolute", "continuous", "prismatic")[i % 3]
        chain.append(f'<link name="l{i}"/><joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0.1 0.02 0.01" rpy="0.01 0.2 0.02"/>'
                     f'<axis xyz="{("0 0 1", "0 1 0", "0.6 0 0.8")[i % 3]}"/>'
                     f'<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>')
    rng = np.random.default_rng(12)
    with Node("rsp_eq", options=node_options) as node:
        for robot in (parse_urdf("".join(chain) + "</robot>"), load_urdf(MY_ROBOT)):
            rsp = RobotStatePublisher(node, robot, ignore_timestamp=True)
            sent: list[dict] = []
            rsp._tf.publish_bytes = lambda p: sent.append(wire.unpack(p))
            kin = Kinematics(robot)
            names = list(rsp._index)
            for trial in range(40):
                subset = [str(n) for n in rng.permutation(names)[: rng.integers(1, len(names) + 1)]] + ["bogus"]
                position = [float(v) for v in rng.uniform(-3, 3, len(subset))]
                assert rsp.process(subset, position, 7, trial)
                given = dict(zip(subset, position))
                for j in robot.joints.values():  # a mimic not named follows its master
                    if j.mimic is not None and j.name not in given and j.mimic.joint in given:
                        given[j.name] = given[j.mimic.joint] * j.mimic.multiplier + j.mimic.offset
                published = sent[-1]["transforms"]
                assert {t["child_frame_id"] for t in published} == {
                    robot.joints[n].child for n in given if n in robot.joints and robot.joints[n].movable}
                for t in published:
                    j = robot.joints[robot.parent_joint[t["child_frame_id"]]]
                    assert t["header"] == {"stamp": {"sec": 7, "nanosec": trial}, "frame_id": j.parent}
                    tr = t["transform"]
                    m = _matrix([tr["translation"][a] for a in "xyz"], [tr["rotation"][a] for a in "xyzw"])
                    assert np.abs(m - kin.joint_transform(j.name, given[j.name])).max() < 1e-12


@pytest.mark.parametrize("case", ["unknown parent", "parent is child", "loop", "two parents", "missing attribute",
                                  "bad number"])
def test_each_kind_of_malformed_urdf_is_one_line_from_the_cli(case, tmp_path) -> None:
    from test_urdf_model import MALFORMED, _write

    body, line, needle = MALFORMED[case]
    path = _write(tmp_path, body)
    for command in (["urdf", "check"], ["robot-state-publisher"], ["joint-state-publisher"]):
        proc = zentf([*command, str(path)], None)
        err = assert_one_line_error(proc, f"{path}:{line}: ", needle, code=2)
        assert err == f"zentf: error: {path}:{line}: " + err.split(f"{path}:{line}: ", 1)[1]
        assert proc.stdout == ""


def test_robot_description_parameter_instead_of_a_file(spawn, zenoh_env) -> None:
    env = {**zenoh_env, "ZENTF_PARAMS": json.dumps({"robot_description": MY_ROBOT.read_text(),
                                                    "frame_prefix": "p/"})}
    rsp = spawn.python("-m", "nodes.robot_state_publisher", env=env)
    rsp.wait_for_line(r"publishing robot 'my_robot' \(16 links\)", timeout=30)
    probe = spawn.python(PROBE, "--static-only", "p/head:p/box")
    assert _wait_pairs(probe, {"p/head:p/box"})["p/head:p/box"]["t"] == pytest.approx([0.1814, 0, 0.1414])


def test_time_moving_backwards_republishes(isolated_router, test_namespace) -> None:
    """A bag played in a loop (sim time jumps back): the per-joint throttle starts over (ROS 2)."""
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions, ZenohOptions
    from zentf.tools.robot_state_publisher import RobotStatePublisher

    opts = NodeOptions(namespace=test_namespace, zenoh=ZenohOptions(connect=[isolated_router], no_multicast=True,
                                                                    mode="client"))
    with Node("rsp_sim", params={"use_sim_time": True}, options=opts) as node:
        clock = node.get_clock()
        rsp = RobotStatePublisher(node, load_urdf(R2D2), publish_frequency=1.0)
        rsp._tf.publish_bytes = lambda p: None
        clock.set_sim_time(100 * 10**9)
        assert rsp.process(["head_swivel"], [0.1], 100, 0)
        assert not rsp.process(["head_swivel"], [0.2], 50, 0)      # older than the last publish + 1 s
        clock.set_sim_time(50 * 10**9)                             # the bag starts over
        assert rsp.process(["head_swivel"], [0.2], 50, 0)


def test_joint_state_publisher_sweep_covers_each_range_and_publishes_mimics(spawn, node_options) -> None:
    from zentf.core.messages import JointState
    from zentf.transport.node import Node

    seen: dict[str, list[float]] = {}
    mimic_ok: list[bool] = []
    done = threading.Event()

    def on_state(msg: JointState) -> None:
        pos = dict(zip(msg.name, msg.position))
        mimic_ok.append(pos["right_gripper_joint"] == pos["left_gripper_joint"])
        for n, v in pos.items():
            seen.setdefault(n, []).append(v)
        ext = seen["gripper_extension"]
        if min(ext) < -0.37 and max(ext) > -0.01 and max(seen["head_swivel"]) > 3.1:
            done.set()

    with Node("sweep_watcher", options=node_options) as node:
        node.create_subscription("joint_states", JointState, on_state)
        jsp = spawn.python("-m", "nodes.joint_state_publisher", str(MY_ROBOT), "--sweep", "--sweep-period", "1",
                           "--rate", "100")
        jsp.wait_for_line("publishing joint_states of robot 'my_robot': 8 movable joints at 100 Hz \\(sweeping\\)", 30)
        assert done.wait(30), {n: (min(v), max(v)) for n, v in seen.items()}
    assert all(mimic_ok)
    assert all(-0.38 <= v <= 0.0 for v in seen["gripper_extension"])
    assert all(0.0 <= v <= 0.548 for v in seen["left_gripper_joint"])
    assert all(-math.pi <= v <= math.pi for v in seen["head_swivel"])


def test_rsp_reads_repeated_joint_states_in_c_as_the_general_path_would(node_options) -> None:
    """JointStates over real Zenoh: once a name list was seen, the next messages with the same list are read
    in C (positions and stamp, no name decoded) and publish what the general decoder's path publishes; any
    message unlike that (other names, key order, ints, float32, sizes, NaN, stamps out of range, extra
    keys, cut short) gives the general path's outcome."""
    import msgpack

    from zentf.transport.wire import codec as wire
    from zentf.core.messages import JointState
    from zentf.transport.node import Node
    from zentf.tools.robot_state_publisher import RobotStatePublisher
    from zentf.urdf import parse_urdf

    chain = ['<robot name="chain"><link name="l0"/>']
    for i in range(1, 13):
        kind = ("revolute", "continuous", "prismatic")[i % 3]
        chain.append(f'<link name="l{i}"/><joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0.1 0.02 0.01" rpy="0.01 0.2 0.02"/>'
                     f'<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>')
    chain.append('<link name="m"/><joint name="jm" type="revolute"><parent link="l0"/><child link="m"/>'
                 '<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/>'
                 '<mimic joint="j1" multiplier="2" offset="0.1"/></joint>')
    robot = parse_urdf("".join(chain) + "</robot>")
    names = [f"j{i}" for i in range(1, 13)]

    class Probe(RobotStatePublisher):
        """Records, per message its subscriber handled: (payload, ignored, fast reads, messages sent on tf)."""

        def __init__(self, *args, **kwargs) -> None:
            self.handled: list[tuple[bytes, int, int, int]] = []
            self.cond = threading.Condition()
            self.out: list[bytes] = []
            super().__init__(*args, **kwargs)
            self._tf.publish_bytes = self.out.append

        def _on_sample(self, sample) -> None:
            super()._on_sample(sample)
            with self.cond:
                self.handled.append((sample.payload, self.ignored, self.fast_reads, len(self.out)))
                self.cond.notify_all()

        def outcome(self, payload: bytes) -> tuple[int, int, bytes | None]:
            """(ignored, fast reads) added by that message, and what it sent on tf (None: nothing)."""
            with self.cond:
                assert self.cond.wait_for(lambda: any(h[0] == payload for h in self.handled), 30)
                k = next(k for k, h in enumerate(self.handled) if h[0] == payload)
                before = self.handled[k - 1] if k else (b"", 0, 0, 0)
                now = self.handled[k]
                return now[1] - before[1], now[2] - before[2], self.out[now[3] - 1] if now[3] > before[3] else None

    class General(Probe):
        def _on_sample(self, sample) -> None:  # never a plan to read with: the general decoder every time
            self._last_plan = None
            super()._on_sample(sample)

    def js(ns: list[str], pos: list, sec: int = 5, nsec: int = 0, **extra) -> dict:
        return {"header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": ""}, "name": ns,
                "position": pos, "velocity": [], "effort": [], **extra}

    rng = np.random.default_rng(3)
    pos = [float(v) for v in rng.uniform(-2, 2, 12)]
    payloads = [("plain", msgpack.packb(js(names, [float(v) for v in rng.uniform(-2, 2, 12)], 5, k)))
                for k in range(20)]
    odd = [
        ("other names", js(names[:6], pos[:6])),
        ("names permuted", js(names[::-1], pos, 5, 1)),
        ("names again", js(names, pos, 6)),
        ("keys reordered", {"position": pos, "effort": [], "name": names, "velocity": [1.0] * 12,
                            "header": {"frame_id": "x", "stamp": {"sec": 7, "nanosec": 1}}}),
        ("integral positions", js(names, list(range(12)), 8)),
        ("float32", None),
        ("fewer positions", js(names, pos[:11], 9)),
        ("NaN", js(names, [float("nan")] + pos[1:], 10)),
        ("sec out of range", js(names, pos, 2**32)),
        ("negative sec", js(names, pos, -1)),
        ("nanosec out of range", js(names, pos, 11, 10**9)),
        ("an extra key", js(names, pos, 12, extra_field=[1, 2])),
        ("cut short", None),
        ("a string for a position", js(names, ["x"] + pos[1:], 13)),
        ("a string for a velocity", js(names, pos, 16) | {"velocity": ["x"] * 12}),
        ("negative integral positions", js(names, [-k for k in range(12)], 17)),
    ]
    for label, m in odd:
        if label == "float32":
            b = msgpack.packb(js(names, pos, 14), use_single_float=True)
        elif label == "cut short":
            b = msgpack.packb(js(names, pos, 15))[:-9]
        else:
            b = msgpack.packb(m)
        payloads += [(label, b), (label + ", then plain", msgpack.packb(js(names, pos, 20 + len(payloads))))]
    with_unknown = names + ["bogus"]  # a joint the model does not have: logged, the others published
    payloads += [("an unknown joint", msgpack.packb(js(with_unknown, pos + [0.5], 40))),
                 ("an unknown joint again", msgpack.packb(js(with_unknown, pos[::-1] + [0.5], 41)))]
    assert len({p for _, p in payloads}) == len(payloads)
    # read in C: the same names as the message before, however the rest is sent
    must_read = {"keys reordered", "integral positions", "negative integral positions", "float32",
                 "an unknown joint again", "NaN, then plain", "an extra key, then plain"}
    with Node("rsp_fast", options=node_options) as node, Node("rsp_ref", options=node_options) as ref_node, \
            Node("rsp_js", options=node_options) as sender:
        rsp = Probe(node, robot, ignore_timestamp=True)
        ref = General(ref_node, robot, ignore_timestamp=True)
        pub = sender.create_publisher("joint_states", JointState)
        for probe in (rsp, ref):  # both subscribers reached: a message that is not a JointState until each has one
            with probe.cond:
                while not probe.cond.wait_for(lambda: probe.handled, 0.2):
                    pub.publish_bytes(b"not a JointState")
        for label, payload in payloads:
            pub.publish_bytes(payload)
        for k, (label, payload) in enumerate(payloads):
            ignored, fast, sent = rsp.outcome(payload)
            ref_ignored, ref_fast, ref_sent = ref.outcome(payload)
            assert ref_fast == 0
            assert ignored == ref_ignored, label
            assert (sent is None) == (ref_sent is None), label
            if sent is not None:
                assert wire.unpack(sent) == wire.unpack(ref_sent), label
            if label in must_read or (label == "plain" and k > 0):
                assert fast == 1, label
        assert rsp.fast_reads >= 25
