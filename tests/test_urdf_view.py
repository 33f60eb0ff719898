"""`zentf view` draws the robot from robot_description: checked in the Rerun recording it saves."""
from __future__ import annotations

import sys

import pytest

from conftest import REPO

pytest.importorskip("rerun.chunk", reason="rerun-sdk (zentf[view]) not installed")
from test_view_rerun import read_rrd  # noqa: E402

ZENTF = [sys.executable, "-m", "zentf.cli"]
DATA = REPO / "tests" / "data" / "urdf"
R2D2 = DATA / "urdf_tutorial" / "urdf" / "06-flexible.urdf"
BURGER = DATA / "turtlebot3_burger.urdf"


def _components(rows: list[dict]) -> set[str]:
    return {k.split(":")[0] for r in rows for k, v in r.items() if v is not None}


def test_view_draws_r2d2_with_its_collada_meshes(spawn, tmp_path, zenoh_env) -> None:
    pytest.importorskip("trimesh", reason="trimesh reads the .dae meshes")
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(R2D2))
    rsp.wait_for_line("publishing robot", 30)
    spawn.python("-m", "nodes.joint_state_publisher", str(R2D2), "--set", "head_swivel=-0.82").wait_for_line(
        "publishing joint_states", 30)
    rrd = tmp_path / "r2d2.rrd"
    view = spawn([*ZENTF, "view", "-f", "base_link", "--save", str(rrd), "--duration", "3", "--rate", "10"],
                 env={**zenoh_env, "ZENTF_PACKAGE_PATH": str(DATA)})
    assert view.wait(60) == 0, view.output()
    assert "Traceback" not in view.output() and "placeholder" not in view.output(), view.output()
    data = read_rrd(rrd)
    assert "Cylinders3D" in _components(data["/tf/base_link/robot/0"])
    assert "Ellipsoids3D" in _components(data["/tf/head/robot/0"])
    assert "Boxes3D" in _components(data["/tf/box/robot/0"])
    assert "Mesh3D" in _components(data["/tf/left_gripper/robot/0"])
    # colours from the named materials: base_link is "blue" (0 0 0.8 1)
    colors = [c for r in data["/tf/base_link/robot/0"] for c in (r.get("Cylinders3D:colors") or [])]
    assert colors and colors[0] == 0x0000CCFF
    # the visual origin of right_leg (rpy 0 1.57075 0, xyz 0 0 -0.3) is the entity's own transform
    leg = [r for r in data["/tf/right_leg/robot/0"] if r.get("Transform3D:translation")]
    assert leg[0]["Transform3D:translation"][0] == pytest.approx([0, 0, -0.3])


def test_view_draws_a_robot_whose_meshes_are_missing_and_says_so_once(spawn, tmp_path) -> None:
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(BURGER))
    rsp.wait_for_line("publishing robot", 30)
    spawn.python("-m", "nodes.joint_state_publisher", str(BURGER)).wait_for_line("publishing joint_states", 30)
    rrd = tmp_path / "burger.rrd"
    view = spawn([*ZENTF, "view", "-f", "base_footprint", "--save", str(rrd), "--duration", "3", "--rate", "20"])
    assert view.wait(60) == 0, view.output()
    out = view.output()
    lines = [ln for ln in out.splitlines() if "burger_base.stl not found" in ln]
    assert len(lines) == 1, out  # once, although the view refreshed ~60 times
    assert "link 'base_link': mesh package://turtlebot3_description/meshes/bases/burger_base.stl" in lines[0]
    data = read_rrd(rrd)
    assert "Boxes3D" in _components(data["/tf/base_link/robot/0"])       # the placeholder
    assert "Cylinders3D" not in _components(data["/tf/base_link/robot/0"])
    assert rsp.returncode is None  # the publisher never needed the meshes
