"""The split drones demo across separate network stacks: host a, router, host b (network namespaces).

Machine A runs ``zentf launch configs/split/machine_a.yaml``, machine B runs
``zentf launch configs/split/machine_b.yaml``, the router namespace runs ``zentf router --config
configs/zenoh/router.json5``; the only path between a and b is the router process. Skipped unless
root with iproute2 (CI runs as root).
"""
from __future__ import annotations

import sys

import pytest

from conftest import REPO
from netns_fixtures import net, run_in, start_router  # noqa: F401
from netns_topology import Topology

pytestmark = pytest.mark.timeout(120)


def on_ellipse(x: float, y: float, z: float, tol: float = 1e-3) -> bool:
    """av2 seen from av1: (x+1)^2 + (y+1/2)^2 = 1/4 and z = 2 (y + 1/2) (frames_publisher.av2_in_av1)."""
    return abs((x + 1) ** 2 + (y + 0.5) ** 2 - 0.25) < tol and abs(z - 2 * (y + 0.5)) < tol


def test_on_ellipse_rejects_points_off_it() -> None:
    from zentf.demos.frames_publisher import av2_in_av1

    assert all(on_ellipse(*av2_in_av1(t / 7)) for t in range(50))
    assert not on_ellipse(0.0, 0.0, 0.0) and not on_ellipse(-1.0, -0.5, 0.5)


def test_split_drones_demo_across_three_hosts(net: Topology, run_in) -> None:
    assert net.reaches("a") and net.reaches("b"), "veth wiring broken"
    assert not net.reaches("a", net.host_ip("b")), "hosts a and b must only meet through the router process"
    start_router(run_in)
    launch = [sys.executable, "-m", "zentf.cli", "launch"]
    b = run_in("b", *launch, str(REPO / "configs/split/machine_b.yaml"), f"router:=tcp/{net.router_ip('b')}:7447",
               "period:=0.2")
    a = run_in("a", *launch, str(REPO / "configs/split/machine_a.yaml"), f"router:=tcp/{net.router_ip('a')}:7447")
    a.wait_for_line(r"publishing av1 and av2 in world", 30)
    points = []
    for _ in range(5):
        m = b.wait_for_line(r"\[av2_in_av1\] av2 in av1: translation \((\S+), (\S+), (\S+)\)", 30)
        points.append(tuple(float(v) for v in m.groups()))
    assert all(on_ellipse(*p, tol=0.02) for p in points), points  # 3 decimals printed
    assert len(set(points)) > 1, f"av2 does not move in av1: {points}"
    # plots_publisher on b drew the same trail (4 decimals)
    m = b.wait_for_line(r"\[plots_publisher\] av2 in av1: \((\S+), (\S+), (\S+)\)", 20, from_start=True)
    assert on_ellipse(*(float(v) for v in m.groups()), tol=2e-3)


def test_split_demo_over_mutual_tls_with_access_control(net: Topology, run_in, tmp_path) -> None:
    """The same demo through configs/zenoh/router-acl.json5: machine A holds robot-a's certificate
    (the one allowed to publish tf), machine B base-b's; each runs from a directory with its certs/."""
    from security_helpers import machine_dir, make_certs

    certs = make_certs(tmp_path / "ca", sans=[net.router_ip("a"), net.router_ip("b")])
    start_router(run_in, str(REPO / "configs/zenoh/router-acl.json5"), cwd=machine_dir(tmp_path, certs, "router"))
    launch = [sys.executable, "-m", "zentf.cli", "launch"]
    tls = f"zenoh_config:={REPO / 'configs/zenoh/client-tls.json5'}"
    b = run_in("b", *launch, str(REPO / "configs/split/machine_b.yaml"), f"router:=tls/{net.router_ip('b')}:7447",
               tls, "period:=0.2", cwd=machine_dir(tmp_path, certs, "base-b"))
    run_in("a", *launch, str(REPO / "configs/split/machine_a.yaml"), f"router:=tls/{net.router_ip('a')}:7447", tls,
           cwd=machine_dir(tmp_path, certs, "robot-a"))
    for _ in range(3):
        m = b.wait_for_line(r"\[av2_in_av1\] av2 in av1: translation \((\S+), (\S+), (\S+)\)", 30)
        assert on_ellipse(*(float(v) for v in m.groups()), tol=0.02)


@pytest.mark.parametrize("net", [{"hosts": ["a", "b"], "lan": True}], indirect=True)
def test_split_demo_between_peers_on_a_lan_by_multicast_scouting(net: Topology, run_in) -> None:
    """No router: configs/zenoh/peer-lan.json5 on both hosts, which share one Ethernet segment."""
    launch = [sys.executable, "-m", "zentf.cli", "launch"]
    peer = f"zenoh_config:={REPO / 'configs/zenoh/peer-lan.json5'}"
    b = run_in("b", *launch, str(REPO / "configs/split/machine_b.yaml"), peer, "period:=0.2")
    run_in("a", *launch, str(REPO / "configs/split/machine_a.yaml"), peer)
    for _ in range(3):
        m = b.wait_for_line(r"\[av2_in_av1\] av2 in av1: translation \((\S+), (\S+), (\S+)\)", 30)
        assert on_ellipse(*(float(v) for v in m.groups()), tol=0.02)
