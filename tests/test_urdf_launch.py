"""`zentf launch urdf model:=... [gui:=true]`: the lecture's display.launch, started for real."""
from __future__ import annotations

import json
import math
import sys
import urllib.request

from conftest import REPO

PROBE = str(REPO / "tests" / "tf_lookup_probe.py")
LAUNCH = [sys.executable, "-m", "zentf.launch", "urdf", "--no-color"]


def _post(url: str, body: dict) -> dict:
    req = urllib.request.Request(url, data=json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.loads(r.read())


def test_launch_urdf_with_gui_publishes_the_model_and_follows_the_page(spawn, zenoh_env) -> None:
    env = {k: v for k, v in zenoh_env.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}  # no browser opened
    launch = spawn([*LAUNCH, "model:=configs/robots/my_robot.urdf", "gui:=true"], env=env)
    url = launch.wait_for_line(r"sliders: (http://127\.0\.0\.1:\d+/)", timeout=60).group(1)
    launch.wait_for_line(r"publishing robot 'my_robot'", timeout=60, from_start=True)
    probe = spawn.python(PROBE, "base_link:head", "base_link:right_tip")
    seen = set()
    while seen != {"base_link:head", "base_link:right_tip"}:
        seen.add(json.loads(probe.wait_for_line(r'^\{"pair"', timeout=30).string)["pair"])
    state = _post(url + "set", {"head_swivel": 1.0})
    assert {j["name"]: j["value"] for j in state["joints"]}["head_swivel"] == 1.0
    while True:
        line = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=30).string)
        x, y, z, w = line["q"]
        if line["pair"] == "base_link:head" and abs(math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)) - 1.0) < 1e-9:
            break


def test_launch_urdf_with_a_broken_model_stops_with_the_one_line(spawn, tmp_path) -> None:
    text = (REPO / "configs" / "robots" / "my_robot.urdf").read_text()
    broken = tmp_path / "broken.urdf"
    broken.write_text(text.replace('<parent link="base_link"/>\n    <child link="gripper_pole"/>',
                                   '<parent link="gripper_pole"/>\n    <child link="gripper_pole"/>'))
    launch = spawn([*LAUNCH, f"model:={broken}"])
    launch.wait_for_line(r"robot_state_publisher: error: .*broken\.urdf:\d+: <joint name='gripper_extension'>: "
                         r"parent and child are the same link 'gripper_pole'", timeout=60)
    assert launch.wait(30) == 2, launch.output()
