"""ROS 2 CLI habits against a live graph: node info (services, clients, parameters), topic type, topic find,
each under zentf's wire and --wire ros2."""
from __future__ import annotations

import sys

import pytest

from cli_helpers import zentf


@pytest.mark.parametrize("wire", ["zentf", "ros2"])
def test_node_info_topic_type_and_find(spawn, request, wire):
    env = request.getfixturevalue("zenoh_env" if wire == "zentf" else "ros2_env")
    ns = env.get("ZENTF_NAMESPACE", "")
    prefix = f"/{ns}" if ns else ""
    sim = spawn([sys.executable, "-m", "zentf.cli", "run", "turtlesim"], env=env)
    sim.wait_for_line(r"spawned turtle1", 60)
    info = zentf(["node", "info", f"{prefix}/turtlesim"], env, timeout=60)
    assert info.returncode == 0, info.stderr
    out = info.stdout
    assert f"{prefix}/turtle1/pose: turtlesim/msg/Pose" in out.split("Publishers:")[1].split("Service Servers:")[0]
    servers = out.split("Service Servers:")[1].split("Service Clients:")[0]
    assert f"{prefix}/spawn: turtlesim/srv/Spawn" in servers and "/turtlesim/list_parameters" in servers, out
    assert "Parameters:" in out and "use_sim_time: false" in out.split("Parameters:")[1], out
    typ = zentf(["topic", "type", "turtle1/pose"], env, timeout=60)
    assert typ.returncode == 0 and typ.stdout.split() == ["turtlesim/msg/Pose"], (typ.stdout, typ.stderr)
    found = zentf(["topic", "find", "turtlesim/Pose"], env, timeout=60)
    assert found.stdout.split() == [f"{prefix}/turtle1/pose"], (found.stdout, found.stderr)
    missing = zentf(["topic", "type", "no_such_topic", "--wait", "0.5"], env, timeout=60)
    assert missing.returncode == 1 and "unknown topic" in missing.stderr
