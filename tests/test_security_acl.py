"""Access control (configs/zenoh/router-acl.json5): only clients whose certificate CN is listed
(``robot-a``) may publish on tf / tf_static or clock, and a certificate declares only its own nodes'
graph tokens; another client with a valid certificate (``intruder``, in no role) is connected, but
nothing it publishes on tf or clock reaches a listener, it hears nothing and cannot squat a node name.
(Wildcard keys, the ROS 2 wire and the other roles: tests/test_net_acl_allowlist.py.)
"""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

from conftest import REPO
from netns_fixtures import next_state
from security_helpers import ROUTER_ACL, client_config, client_flags, machine_dir, make_certs, start_tls_router

pytestmark = pytest.mark.timeout(120)


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PYTHONUNBUFFERED="1", PYTHONPATH=os.pathsep.join(
        p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
    return env


def test_acl_config_lists_robot_a_as_the_only_tf_publisher() -> None:
    import zenoh

    cfg = zenoh.Config.from_file(str(ROUTER_ACL))
    acl = json.loads(cfg.get_json("access_control"))
    assert acl["enabled"] is True
    publishers = [s for s in acl["subjects"] if s["id"] == "tf_publishers"]
    assert publishers and publishers[0]["cert_common_names"] == ["robot-a"]
    owners = [s for s in acl["subjects"] if s["id"] == "clock_owners"]
    assert owners and owners[0]["cert_common_names"] == ["robot-a"]
    listed = {cn for s in acl["subjects"] for cn in s.get("cert_common_names") or []}
    assert "intruder" not in listed


def test_acl_denied_publisher_never_reaches_a_listener(tmp_path: Path, spawn, test_namespace: str) -> None:
    certs = make_certs(tmp_path / "certs")
    _, ep = start_tls_router(spawn, machine_dir(tmp_path, certs, "router"), ROUTER_ACL)
    flags = client_flags(ep, test_namespace)
    py = sys.executable
    intruder = machine_dir(tmp_path, certs, "intruder")
    robot_a = machine_dir(tmp_path, certs, "robot-a")
    # the intruder publishes both kinds of transforms: dynamic (tf) and latched (tf_static)
    bad_frames = spawn([py, "-m", "nodes.frames_publisher", *flags, "--name", "intruder_frames",
                        "-p", "frame_prefix:=intruder/"], env=_env(), cwd=intruder)
    bad_static = spawn([py, "-m", "nodes.static_transform_publisher", *flags, "--name", "intruder_static",
                        "--frame-id", "world", "--child-frame-id", "evil"], env=_env(), cwd=intruder)
    bad_frames.wait_for_line(r"publishing intruder/av1", 30)
    bad_static.wait_for_line(r"Spinning until stopped - publishing .* from 'world' to 'evil'", 30)
    # the authorized robot
    spawn([py, "-m", "nodes.frames_publisher", *flags], env=_env(), cwd=robot_a)
    spawn([py, "-m", "nodes.static_transform_publisher", *flags, "--frame-id", "world", "--child-frame-id",
           "tower"], env=_env(), cwd=robot_a)
    watcher = spawn([py, str(REPO / "tests/net_probe.py"), *flags, "--static", "world:tower"], env=_env(),
                    cwd=machine_dir(tmp_path, certs, "base-b"))
    state = next_state(watcher, lambda s: s["static"] and s["av1_ns"], 30)

    # the intruder is connected but in no role (an allow-list): its own probe sees nothing either
    spy = spawn([py, str(REPO / "tests/net_probe.py"), *flags, "--name", "intruder_probe"], env=_env(), cwd=intruder)
    next_state(spy, timeout=30)

    # a second of authorized traffic (50 Hz) later, nothing of the intruder's (also 50 Hz) has arrived
    state = next_state(watcher, lambda s: s["checked"] >= state["checked"] + 10, 10)
    assert state["count"].get("av1", 0) > 20
    assert not [f for f in state["frames"] if f.startswith("intruder/") or f == "evil"], state["frames"]
    assert not [c for c in state["count"] if c.startswith("intruder/")], state["count"]
    assert state["bad"] == 0
    spied = next_state(spy, timeout=10)  # after the watcher's second of robot-a's transforms
    assert not spied["frames"] and not spied["av1_ns"], spied


def _zentf(*args: str) -> list[str]:
    return [sys.executable, "-m", "zentf.cli", *args]


def test_unlisted_client_cannot_jump_the_clock(tmp_path: Path, spawn, test_namespace: str) -> None:
    """An allowed-nothing client publishes /clock going back (which would make every sim-time
    listener clear its buffer). Both publish at 20 Hz; the listener only ever hears the owner."""
    certs = make_certs(tmp_path / "certs")
    _, ep = start_tls_router(spawn, machine_dir(tmp_path, certs, "router"), ROUTER_ACL)
    flags = client_flags(ep, test_namespace)
    clock = ["topic", "pub", "/clock", "rosgraph_msgs/msg/Clock"]
    echo = spawn(_zentf("topic", "echo", "/clock", "--json", *flags), env=_env(),
                 cwd=machine_dir(tmp_path, certs, "base-b"))
    evil = spawn(_zentf(*clock, "{clock: {sec: 1}}", "--rate", "20", *flags), env=_env(),
                 cwd=machine_dir(tmp_path, certs, "intruder"))
    evil.wait_for_line(r"publishing #20: Clock on /clock", 30)  # it sends (a second of it, to a subscriber)
    spawn(_zentf(*clock, "{clock: {sec: 1000}}", "--rate", "20", *flags), env=_env(),
          cwd=machine_dir(tmp_path, certs, "robot-a"))
    for _ in range(20):
        echo.wait_for_line(r'^\{"clock":\{"sec":1000,', 30)
    heard = [json.loads(ln)["clock"]["sec"] for ln in echo.lines if ln.startswith("{")]
    assert heard and set(heard) == {1000}, heard
    assert evil.returncode is None and "publishing #" in evil.lines[-1]  # still sending all along


def test_unlisted_client_cannot_squat_a_node_name(tmp_path: Path, spawn, test_namespace: str) -> None:
    """A certified client declares robot-a's node name (which would keep robot-a from starting)."""
    certs = make_certs(tmp_path / "certs")
    _, ep = start_tls_router(spawn, machine_dir(tmp_path, certs, "router"), ROUTER_ACL)
    flags = client_flags(ep, test_namespace)
    py = sys.executable
    squatter = spawn([py, "-m", "nodes.static_transform_publisher", *flags, "--name", "frames_publisher",
                      "--frame-id", "x", "--child-frame-id", "y"], env=_env(),
                     cwd=machine_dir(tmp_path, certs, "intruder"))
    squatter.wait_for_line(r"Spinning until stopped", 30)

    import zenoh

    token = f"@zentf/node/%{test_namespace}/frames_publisher"
    session = zenoh.open(client_config(machine_dir(tmp_path, certs, "viewer", key_of="base-b"), ep))
    try:
        def names() -> list[str]:
            return [str(r.ok.key_expr) for r in session.liveliness().get(f"@zentf/node/%{test_namespace}/*",
                                                                         timeout=3.0) if r.ok is not None]

        assert token not in names()  # the squatter's token never left the router
        robot = spawn([py, "-m", "nodes.frames_publisher", *flags], env=_env(),
                      cwd=machine_dir(tmp_path, certs, "robot-a"))
        robot.wait_for_line(r"publishing av1", 30)  # starts: no NodeNameError
        assert names().count(token) == 1
    finally:
        session.close()
    assert squatter.returncode is None
