"""The DDS bridge is safe by default: without --lan its DDS participant cannot be seen or fed from the LAN;
with --lan (and the interface named) the robot's network reaches it. Host a runs ``zentf bridge dds``,
host b (one Ethernet segment with multicast) runs tests/dds_intruder.py: a Cyclone DDS participant on that
segment that looks for the bridge and writes a forged transform on rt/tf. Skipped unless root with
iproute2 (CI runs as root).
"""
from __future__ import annotations

import json
import re
import sys

import pytest

from conftest import REPO
from netns_fixtures import net, net_env, run_in  # noqa: F401
from netns_topology import Topology

pytest.importorskip("cyclonedds")
pytestmark = pytest.mark.timeout(120)

LAN = [{"hosts": ["a", "b"], "lan": True}]
DOMAIN = "7"


def _bridge(run_in, *flags: str):
    env = {**net_env(), "ROS_DOMAIN_ID": DOMAIN}
    b = run_in("a", sys.executable, "-m", "zentf.cli", "bridge", "dds", *flags, env=env)
    b.wait_for_line("dds bridge: active", 30)
    return b


def _watch(run_in, writes: int) -> tuple[dict, object]:
    """The intruder's state once it saw the bridge, or after ``writes`` forged writes (as many periods of
    looking for it) without seeing it."""
    intruder = run_in("b", sys.executable, str(REPO / "tests/dds_intruder.py"), DOMAIN, "10.78.0.1")
    state: dict = {}
    while not state.get("bridge_seen") and state.get("writes", 0) < writes:
        state = json.loads(intruder.wait_for_line(r"^\{.*\}$", 30).group(0))
    return state, intruder


def _relayed(bridge) -> int:
    assert bridge.wait(30) == 0
    m = bridge.wait_for_line(r"to zentf: (\d+)", 5, from_start=True)
    return int(m.group(1))


@pytest.mark.parametrize("net", LAN, indirect=True)
def test_default_bridge_is_invisible_and_unfed_from_the_lan(net: Topology, run_in) -> None:
    bridge = _bridge(run_in, "--duration", "30")
    state, _ = _watch(run_in, 25)  # 5 s of looking: the --lan test below sees the bridge well within this
    assert not state["bridge_seen"], state
    bridge.signal(2)
    assert _relayed(bridge) == 0


@pytest.mark.parametrize("net", LAN, indirect=True)
def test_lan_bridge_reaches_the_robot_network(net: Topology, run_in) -> None:
    bridge = _bridge(run_in, "--duration", "30", "--lan", "--dds-interface", "lan0")
    state, intruder = _watch(run_in, 150)
    assert state["bridge_seen"], state
    for _ in range(10):  # ten more forged writes now that the two have met
        intruder.wait_for_line(r"^\{.*\}$", 30)
    bridge.signal(2)
    assert _relayed(bridge) > 0
    assert re.search(r"DDS domain 7 \(LAN\)", bridge.output())
