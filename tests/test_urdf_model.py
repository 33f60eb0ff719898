"""URDF model: parsing real files, forward kinematics against yourdfpy, and every refusal's one line."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from zentf.urdf import Kinematics, URDFError, load_urdf, parse_urdf
from zentf.urdf.model import Box, Cylinder, Mesh, Sphere

DATA = Path(__file__).parent / "data" / "urdf"
R2D2 = DATA / "urdf_tutorial" / "urdf" / "06-flexible.urdf"
BURGER = DATA / "turtlebot3_burger.urdf"
MY_ROBOT = Path(__file__).parents[1] / "configs" / "robots" / "my_robot.urdf"

MIMIC_URDF = """<robot name="m">
  <link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="e"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 1.0"/>
    <axis xyz="1 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0 0 0.5" rpy="1 0 0"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="0.4" effort="1" velocity="1"/><mimic joint="j1" multiplier="0.1" offset="0.05"/></joint>
  <joint name="j3" type="continuous"><parent link="c"/><child link="d"/><origin xyz="0.3 0 0" rpy="0 0.5 0"/>
    <axis xyz="0 1 0"/><mimic joint="j1" multiplier="-3" offset="0.2"/></joint>
  <joint name="j4" type="continuous"><parent link="a"/><child link="e"/><origin xyz="0 1 0"/><axis xyz="0 0 1"/></joint>
</robot>"""


def _yourdfpy(path: Path):
    yourdfpy = pytest.importorskip("yourdfpy")
    return yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)


def _random_vectors(robot, kin: Kinematics, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    bounds = np.array([robot.joints[name].bounds() for name in kin.joint_names])
    return rng.uniform(bounds[:, 0], bounds[:, 1], size=(n, len(bounds)))


@pytest.mark.parametrize("path", [R2D2, BURGER, "mimic"], ids=["r2d2", "burger", "mimic"])
def test_fk_of_every_link_equals_yourdfpy(path, tmp_path: Path) -> None:
    if path == "mimic":
        path = tmp_path / "mimic.urdf"
        path.write_text(MIMIC_URDF)
    robot = load_urdf(path)
    kin = Kinematics(robot)
    ref = _yourdfpy(path)
    assert sorted(kin.joint_names) == sorted(ref.actuated_joint_names)
    assert set(kin.link_names) == set(robot.links) == set(ref.link_map)
    qs = _random_vectors(robot, kin, 100, seed=12)
    batch = kin.link_poses_batch(qs)
    worst = 0.0
    for i, q in enumerate(qs):
        cfg = dict(zip(kin.joint_names, q))
        ref.update_cfg(cfg)
        poses = kin.link_poses(cfg)
        for k, link in enumerate(kin.link_names):
            expected = ref.get_transform(link, robot.root)
            worst = max(worst, float(np.abs(poses[link] - expected).max()),
                        float(np.abs(batch[i, k] - expected).max()))
    assert worst < 1e-9, worst


def test_r2d2_model_contents() -> None:
    robot = load_urdf(R2D2)
    assert robot.name == "visual" and robot.root == "base_link"
    assert len(robot.links) == 16 and len(robot.joints) == 15
    types = {j.name: j.type for j in robot.joints.values()}
    assert types["gripper_extension"] == "prismatic" and types["head_swivel"] == "continuous"
    assert types["left_gripper_joint"] == "revolute" and types["tobox"] == "fixed"
    assert [j.name for j in robot.actuated_joints()] == [
        "right_front_wheel_joint", "right_back_wheel_joint", "left_front_wheel_joint", "left_back_wheel_joint",
        "gripper_extension", "left_gripper_joint", "right_gripper_joint", "head_swivel"]
    ext = robot.joints["gripper_extension"]
    assert ext.limit.lower == -0.38 and ext.limit.upper == 0 and ext.bounds() == (-0.38, 0.0)
    assert ext.center() == 0.0 and robot.joints["head_swivel"].bounds() == (-math.pi, math.pi)
    assert robot.joints["right_gripper_joint"].axis == (0.0, 0.0, -1.0)
    base = robot.links["base_link"].visual
    assert isinstance(base.geometry, Cylinder) and base.geometry.radius == 0.2 and base.geometry.length == 0.6
    assert base.material.name == "blue" and base.material.color == (0.0, 0.0, 0.8, 1.0)
    assert isinstance(robot.links["head"].visual.geometry, Sphere)
    leg = robot.links["right_leg"].visual
    assert isinstance(leg.geometry, Box) and leg.geometry.size == (0.6, 0.1, 0.2)
    assert leg.origin.rpy == (0.0, 1.57075, 0.0) and leg.origin.xyz == (0.0, 0.0, -0.3)
    # package://urdf_tutorial/... resolves through the package.xml above the file
    mesh = robot.links["left_gripper"].visual.geometry
    assert isinstance(mesh, Mesh) and mesh.filename == "package://urdf_tutorial/meshes/l_finger.dae"
    assert mesh.path == str(DATA / "urdf_tutorial" / "meshes" / "l_finger.dae")
    assert robot.missing_meshes() == []


def test_burger_loads_with_its_meshes_missing_and_finds_them_on_the_search_path(tmp_path: Path, monkeypatch) -> None:
    robot = load_urdf(BURGER)
    assert robot.root == "base_footprint"
    assert sorted(j.name for j in robot.actuated_joints()) == ["wheel_left_joint", "wheel_right_joint"]
    missing = robot.missing_meshes()
    assert ("base_link", "package://turtlebot3_description/meshes/bases/burger_base.stl") in missing
    mesh = robot.links["base_link"].visual.geometry
    assert mesh.scale == (0.001, 0.001, 0.001)
    stl = tmp_path / "share" / "turtlebot3_description" / "meshes" / "bases" / "burger_base.stl"
    stl.parent.mkdir(parents=True)
    stl.write_bytes(b"solid x\nendsolid x\n")
    # the option ...
    found = load_urdf(BURGER, package_path=[str(tmp_path / "share")]).links["base_link"].visual.geometry
    assert found.path == str(stl)
    # ... and the environment variable
    monkeypatch.setenv("ZENTF_PACKAGE_PATH", str(tmp_path / "share"))
    assert load_urdf(BURGER).links["base_link"].visual.geometry.path == str(stl)
    # file:// URIs
    text = BURGER.read_text().replace("package://turtlebot3_description/meshes/bases/burger_base.stl",
                                      f"file://{stl}")
    assert parse_urdf(text).links["base_link"].visual.geometry.path == str(stl)


def test_xacro_file_expands_to_the_same_tree_as_the_urdf() -> None:
    robot = load_urdf(DATA / "urdf_tutorial" / "urdf" / "08-macroed.urdf.xacro")
    plain = load_urdf(DATA / "urdf_tutorial" / "urdf" / "07-physics.urdf")
    assert set(robot.links) == set(plain.links)
    assert {(j.name, j.type, j.parent, j.child) for j in robot.joints.values()} == \
        {(j.name, j.type, j.parent, j.child) for j in plain.joints.values()}


def test_my_robot_is_a_tree_with_a_mimic_gripper() -> None:
    robot = load_urdf(MY_ROBOT)
    kin = Kinematics(robot)
    assert "right_gripper_joint" not in kin.joint_names  # a mimic: no slider, no joint_states entry
    pos = kin.joint_positions({"left_gripper_joint": 0.3})
    assert pos["right_gripper_joint"] == pytest.approx(0.3)
    left = kin.link_pose("left_gripper", {"left_gripper_joint": 0.3}, base="gripper_pole")
    right = kin.link_pose("right_gripper", {"left_gripper_joint": 0.3}, base="gripper_pole")
    assert math.atan2(left[1, 0], left[0, 0]) == pytest.approx(0.3)
    assert math.atan2(right[1, 0], right[0, 0]) == pytest.approx(-0.3)


def test_the_lectures_broken_gripper_extension_is_refused(tmp_path: Path) -> None:
    text = MY_ROBOT.read_text()
    broken = text.replace('<parent link="base_link"/>\n    <child link="gripper_pole"/>',
                          '<parent link="gripper_pole"/>\n    <child link="gripper_pole"/>')
    assert broken != text
    path = tmp_path / "my_robot.urdf"
    path.write_text(broken)
    line = 1 + broken[:broken.index('<joint name="gripper_extension"')].count("\n")
    with pytest.raises(URDFError) as exc:
        load_urdf(path)
    assert str(exc.value) == (f"{path}:{line}: <joint name='gripper_extension'>: "
                              "parent and child are the same link 'gripper_pole'")


def _write(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "bad.urdf"
    path.write_text('<?xml version="1.0"?>\n<robot name="bad">\n' + body + "\n</robot>\n")
    return path


J = '<joint name="{n}" type="fixed"><parent link="{p}"/><child link="{c}"/></joint>'

MALFORMED = {
    "unknown parent": ('<link name="a"/><link name="b"/>\n' + J.format(n="j", p="x", c="b"),
                       4, "<joint name='j'>: unknown parent link 'x'"),
    "unknown child": ('<link name="a"/><link name="b"/>\n' + J.format(n="j", p="a", c="y"),
                      4, "<joint name='j'>: unknown child link 'y'"),
    "parent is child": ('<link name="a"/><link name="b"/>\n' + J.format(n="j", p="a", c="b") + "\n"
                        + J.format(n="k", p="b", c="b"), 5, "<joint name='k'>: parent and child are the same link 'b'"),
    "loop": ('<link name="a"/><link name="b"/>\n' + J.format(n="j1", p="a", c="b") + "\n" + J.format(n="j2", p="b", c="a"),
             4, "<joint name='j1'>: the joints form a loop"),
    "two parents": ('<link name="a"/><link name="b"/><link name="c"/>\n' + J.format(n="j1", p="a", c="c") + "\n"
                    + J.format(n="j2", p="b", c="c"), 5, "<joint name='j2'>: link 'c' has two parents: 'a'"),
    "missing attribute": ('<link name="a"/><link name="b"/>\n<joint name="j"><parent link="a"/><child link="b"/></joint>',
                          4, "<joint name='j'>: missing required attribute 'type'"),
    "missing link attribute": ('<link name="a"/><link name="b"/>\n<joint name="j" type="fixed"><parent/><child link="b"/></joint>',
                               4, "<joint name='j'> <parent>: missing required attribute 'link'"),
    "bad number": ('<link name="a"/><link name="b"/>\n<joint name="j" type="fixed"><parent link="a"/><child link="b"/>\n'
                   '<origin xyz="0 0.5 1,5"/></joint>', 5, "<joint name='j'> <origin>: bad number in xyz=\"0 0.5 1,5\""),
    "wrong count": ('<link name="a"/>\n<link name="b"><visual><geometry><box size="1 2"/></geometry></visual></link>',
                    4, "<link name='b'> <box>: size=\"1 2\" needs 3 numbers, got 2"),
    "revolute without limit": ('<link name="a"/><link name="b"/>\n<joint name="j" type="revolute"><parent link="a"/>'
                               '<child link="b"/></joint>', 4, "<joint name='j'>: a revolute joint needs <limit>"),
    "unknown type": ('<link name="a"/><link name="b"/>\n<joint name="j" type="hinge"><parent link="a"/>'
                     '<child link="b"/></joint>', 4, "<joint name='j'>: unknown joint type 'hinge'"),
    "not xml": ('<link name="a">\n<link name="b"/>', 5, "not well-formed XML"),
    "undefined material": ('<link name="a"><visual><geometry><sphere radius="1"/></geometry>\n'
                           '<material name="nope"/></visual></link>', 4, "<link name='a'> <material>: material 'nope' is not defined"),
    "mimic unknown": ('<link name="a"/><link name="b"/>\n<joint name="j" type="continuous"><parent link="a"/>'
                      '<child link="b"/><mimic joint="zz"/></joint>', 4, "<joint name='j'>: mimics unknown joint 'zz'"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_urdf_is_refused_with_one_line_naming_element_and_line(tmp_path: Path, case: str) -> None:
    body, line, needle = MALFORMED[case]
    path = _write(tmp_path, body)
    with pytest.raises(URDFError) as exc:
        load_urdf(path)
    text = str(exc.value)
    assert "\n" not in text
    assert text.startswith(f"{path}:{line}: "), text
    assert needle in text, text


def test_a_pure_cycle_without_root_is_a_loop(tmp_path: Path) -> None:
    # every link has exactly one parent: a ring with no root
    body = ('<link name="a"/><link name="b"/><link name="c"/>\n' + J.format(n="j1", p="a", c="b") + "\n"
            + J.format(n="j2", p="b", c="c") + "\n" + J.format(n="j3", p="c", c="a"))
    with pytest.raises(URDFError, match=r"bad\.urdf:4: <joint name='j1'>: the joints form a loop"):
        load_urdf(_write(tmp_path, body))
    # a ring beside a proper tree
    body = ('<link name="r"/><link name="a"/><link name="b"/>\n' + J.format(n="j1", p="a", c="b") + "\n"
            + J.format(n="j2", p="b", c="a"))
    with pytest.raises(URDFError, match=r"bad\.urdf:4: <joint name='j1'>: the joints form a loop through link 'b'"):
        load_urdf(_write(tmp_path, body))


def test_a_mimic_of_a_mimic_follows_the_chain() -> None:
    # yourdfpy stops at the first mimic (it uses 0 + offset); the chain is what the equations say
    chained = MIMIC_URDF.replace('<mimic joint="j1" multiplier="-3"', '<mimic joint="j2" multiplier="-3"')
    robot = parse_urdf(chained)
    pos = Kinematics(robot).joint_positions({"j1": 0.7})
    assert pos["j2"] == pytest.approx(0.1 * 0.7 + 0.05)
    assert pos["j3"] == pytest.approx(-3 * (0.1 * 0.7 + 0.05) + 0.2)
    with pytest.raises(URDFError, match="mimic joints form a cycle"):
        parse_urdf(chained.replace('<mimic joint="j1" multiplier="0.1"', '<mimic joint="j3" multiplier="0.1"'))


def test_floating_and_planar_joints_parse_and_stay_at_their_origin() -> None:
    robot = parse_urdf("""<robot name="f"><link name="world"/><link name="body"/><link name="table"/>
      <joint name="free" type="floating"><parent link="world"/><child link="body"/><origin xyz="1 2 3"/></joint>
      <joint name="slide" type="planar"><parent link="world"/><child link="table"/><axis xyz="0 0 1"/></joint>
    </robot>""")
    kin = Kinematics(robot)
    assert kin.joint_names == [] and robot.movable_joints() == []
    assert np.allclose(kin.link_poses()["body"][:3, 3], [1, 2, 3])


def test_missing_file_and_xacro_errors_are_one_line(tmp_path: Path) -> None:
    with pytest.raises(URDFError, match=r"nope\.urdf: no such file"):
        load_urdf(tmp_path / "nope.urdf")
    bad = tmp_path / "bad.urdf.xacro"
    bad.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="x">\n  <xacro:nosuchmacro/></robot>')
    with pytest.raises(URDFError) as exc:
        load_urdf(bad)
    assert str(exc.value) == f"{bad}:2: xacro: unknown macro name: xacro:nosuchmacro"


def test_batch_fk_shape_checks() -> None:
    kin = Kinematics(load_urdf(R2D2))
    with pytest.raises(ValueError, match=r"\(N, 8\)"):
        kin.link_poses_batch(np.zeros((3, 2)))
    out = kin.link_poses_batch(np.zeros((5, 8)))
    assert out.shape == (5, 16, 4, 4)
    assert re.match(r"^\w+$", kin.link_names[0])


def test_joint_transforms_equal_the_kinematics_joint_matrices() -> None:
    from zentf.core.math3d import matrix_from_transform
    from zentf.urdf.kinematics import JointTransforms

    robot = parse_urdf(MIMIC_URDF)
    kin = Kinematics(robot)
    movable = robot.movable_joints()
    jt = JointTransforms(robot, movable)
    values = np.array([0.7, -0.3, 1.9, -2.5])
    t, q = jt.compute(np.arange(len(movable)), values)
    for k, j in enumerate(movable):
        m = np.asarray(matrix_from_transform(t[k], q[k]))
        assert np.abs(m - kin.joint_transform(j.name, values[k])).max() < 1e-12, j.name


def test_xacro_arguments_reach_the_model(tmp_path: Path) -> None:
    path = tmp_path / "arm.urdf.xacro"
    path.write_text("""<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="arm">
  <xacro:arg name="reach" default="0.5"/>
  <xacro:macro name="seg" params="n parent"><link name="l${n}"/>
    <joint name="j${n}" type="continuous"><parent link="${parent}"/><child link="l${n}"/>
      <origin xyz="$(arg reach) 0 0"/><axis xyz="0 0 1"/></joint></xacro:macro>
  <link name="base"/>
  <xacro:seg n="1" parent="base"/><xacro:seg n="2" parent="l1"/>
</robot>""")
    assert load_urdf(path).joints["j2"].origin.xyz == (0.5, 0.0, 0.0)
    robot = load_urdf(path, xacro_args={"reach": "0.25"})
    assert robot.joints["j2"].origin.xyz == (0.25, 0.0, 0.0)
    assert Kinematics(robot).link_poses()["l2"][0, 3] == pytest.approx(0.5)


def test_joint_state_message_round_trip() -> None:
    from zentf.transport.wire import codec as wire
    from zentf.core.messages import Header, JointState, Message
    from zentf.core.time import Time

    js = JointState(Header(Time(5, 6), "base"), ["a", "b"], [0.5, -1.0], [0.1, 0.2], [])
    assert js.to_dict() == Message.to_dict(js)  # the fast form is the generic one
    assert wire.decode(wire.encode(js), JointState) == js
    with pytest.raises(ValueError, match=r"JointState\.position\[1\]: expected a number"):
        JointState.from_dict({**js.to_dict(), "position": [0.5, "x"]})


def test_parsing_leaves_nothing_for_the_cyclic_collector() -> None:
    """The element tree and the model are freed by reference counting: a tree kept in a cycle (expat's
    handlers refer to their parser) waited for the collector, which doubled the time of a big model."""
    import gc

    text = R2D2.read_text()
    gc.collect()
    gc.disable()
    try:
        robot = parse_urdf(text)
        del robot
        assert gc.collect() == 0
    finally:
        gc.enable()
    parse_urdf(text)
    assert gc.isenabled()  # the pause while parsing is undone
    gc.disable()
    try:
        parse_urdf(text)
        assert not gc.isenabled()  # and a caller's own pause is kept
    finally:
        gc.enable()


def test_a_number_text_read_once_is_checked_again_where_it_is_reused() -> None:
    """Number texts are read once per model; each use still checks its count, finiteness and its line."""
    ok = parse_urdf('<robot name="r"><link name="a"/><link name="b"/><link name="c"/>'
                    '<joint name="j" type="fixed"><parent link="a"/><child link="b"/><origin xyz="1 2 3" rpy="1 2 3"/></joint>'
                    '<joint name="k" type="fixed"><parent link="b"/><child link="c"/><origin xyz="1 2 3"/></joint></robot>')
    assert ok.joints["j"].origin.xyz == ok.joints["k"].origin.xyz == (1.0, 2.0, 3.0)
    with pytest.raises(URDFError) as exc:
        parse_urdf('<robot name="r">\n<link name="a"/><link name="b"/>\n<joint name="j" type="revolute"><parent link="a"/>'
                   '<child link="b"/><origin xyz="1 2 3"/>\n<limit lower="1 2 3" upper="1" effort="1" velocity="1"/>'
                   '</joint></robot>')
    assert str(exc.value) == "<string>:4: <joint name='j'> <limit>: lower=\"1 2 3\" needs 1 number, got 3"


def test_kinematics_origins_are_the_poses_matrices_bit_for_bit() -> None:
    robot = parse_urdf(R2D2.read_text())
    kin = Kinematics(robot)
    for jd in kin._joints:
        j = robot.joints[jd.name]
        assert np.array_equal(jd.origin, j.origin.matrix()), jd.name
        assert np.array_equal(jd.axis, np.array(j.axis)), jd.name
