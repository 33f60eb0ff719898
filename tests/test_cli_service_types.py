"""`zentf service call` takes every service type zentf has a definition for (a class is made from the .srv text
when there is no hand-written one), and `zentf service list -t` shows their types; under zentf's wire and
--wire ros2."""
from __future__ import annotations

import sys

import pytest

from cli_helpers import assert_one_line_error, zentf
from conftest import REPO


@pytest.mark.parametrize("wire", ["zentf", "ros2"])
def test_service_call_takes_every_defined_type(spawn, request, wire):
    env = request.getfixturevalue("zenoh_env" if wire == "zentf" else "ros2_env")
    ns = env.get("ZENTF_NAMESPACE", "")
    prefix = f"/{ns}" if ns else ""
    spawn([sys.executable, str(REPO / "tests" / "service_server.py")], env=env).wait_for_line(r"^serving$", 60)

    listed = zentf(["service", "list", "-t"], env)
    assert listed.returncode == 0, listed.stderr
    lines = listed.stdout.splitlines()
    for want in (f"{prefix}/frames [tf2_msgs/srv/FrameGraph]", f"{prefix}/echo [std_srvs/srv/SetBool]",
                 f"{prefix}/service_server/get_parameters [rcl_interfaces/srv/GetParameters]",
                 f"{prefix}/service_server/list_parameters [rcl_interfaces/srv/ListParameters]"):
        assert want in lines, (want, lines)

    frames = zentf(["service", "call", "frames", "tf2_msgs/srv/FrameGraph"], env)
    assert frames.returncode == 0, frames.stderr
    assert frames.stdout.endswith("response:\nframe_yaml: 'av1: {parent: world}'\n"), frames.stdout
    got = zentf(["service", "call", f"{prefix}/service_server/get_parameters", "rcl_interfaces/srv/GetParameters",
                 "{names: [use_sim_time]}"], env)
    assert got.returncode == 0, got.stderr
    response = got.stdout.split("response:\n", 1)[1]
    assert response.startswith("values:\n- type: 1\n  bool_value: false\n"), got.stdout
    listed = zentf(["service", "call", f"{prefix}/service_server/list_parameters", "rcl_interfaces/ListParameters"],
                   env)  # pkg/Name, as ros2 takes it
    assert listed.returncode == 0 and "- use_sim_time" in listed.stdout, (listed.stdout, listed.stderr)
    bad = zentf(["service", "call", "frames", "tf2_msgs/srv/FrameGraph", "{frame_yaml: x}"], env)
    assert_one_line_error(bad, "bad DATA for tf2_msgs/srv/FrameGraph_Request", "unknown field 'frame_yaml'", code=2)
    unknown = zentf(["service", "call", "frames", "tf2_msgs/srv/NoSuch"], env)
    assert_one_line_error(unknown, "unknown service type 'tf2_msgs/srv/NoSuch'", "tf2_msgs/srv/FrameGraph",
                          "rcl_interfaces/srv/DescribeParameters", code=2)
