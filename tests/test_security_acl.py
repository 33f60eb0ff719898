"""Access control (configs/zenoh/router-acl.json5): only clients whose certificate CN is listed
(``robot-a``) may publish on tf / tf_static; another client with a valid certificate (``intruder``)
is connected and may listen, but nothing it publishes on tf reaches a listener.
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

    # the intruder is connected (its nodes are alive in the graph): only its tf puts are dropped
    import zenoh

    session = zenoh.open(client_config(machine_dir(tmp_path, certs, "viewer", key_of="base-b"), ep))
    try:
        names = {str(r.ok.key_expr) for r in session.liveliness().get(f"@zentf/node/%{test_namespace}/*",
                                                                       timeout=5.0) if r.ok is not None}
    finally:
        session.close()
    assert {f"@zentf/node/%{test_namespace}/intruder_frames",
            f"@zentf/node/%{test_namespace}/intruder_static"} <= names, names

    # a second of authorized traffic (50 Hz) later, nothing of the intruder's (also 50 Hz) has arrived
    state = next_state(watcher, lambda s: s["checked"] >= state["checked"] + 10, 10)
    assert state["count"].get("av1", 0) > 20
    assert not [f for f in state["frames"] if f.startswith("intruder/") or f == "evil"], state["frames"]
    assert not [c for c in state["count"] if c.startswith("intruder/")], state["count"]
    assert state["bad"] == 0
