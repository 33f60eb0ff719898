"""Safe by default: with no configuration a zentf graph is reachable from its own
machine only; ``--lan`` is the one explicit choice that opens it to the LAN, and says so at start.

Host a runs a zero-configuration graph (static-transform-publisher + tf echo, separate processes);
host b, on the same Ethernet segment with multicast, runs tests/net_intruder.py: a plain
``zenoh.Config()`` session that subscribes to everything and forges ``base -> sensor`` with x = 666.
The LAN tests are skipped unless root with iproute2 (CI runs as root). The zero-configuration tests
at the end run on this machine's loopback, each with its own ZENTF_LOCAL_PORT.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest

from conftest import REPO
from netns_fixtures import net, run_in  # noqa: F401
from netns_topology import Topology

pytestmark = pytest.mark.timeout(120)

LAN = [{"hosts": ["a", "b"], "lan": True}]
ZENTF = [sys.executable, "-m", "zentf.cli"]
TRANSLATION = r"- Translation: \[(\S+), "


def _graph(run_in, *flags: str):
    """On host a, zero configuration: a static transform base -> sensor (x = 1), a tf echo of it and a
    topic published at 5 Hz."""
    pub = run_in("a", *ZENTF, "static-transform-publisher", "--x", "1", "--frame-id", "base",
                 "--child-frame-id", "sensor", *flags)
    pub.wait_for_line(r"Spinning until stopped", 30)
    run_in("a", *ZENTF, "topic", "pub", "chatter", "geometry_msgs/msg/Point", "{x: 1}", "--rate", "5", *flags)
    echo = run_in("a", *ZENTF, "tf", "echo", "base", "sensor", "--rate", "10", *flags)
    assert echo.wait_for_line(TRANSLATION, 30).group(1) == "1.000"
    return pub, echo


def _intruder(run_in):
    return run_in("b", sys.executable, str(REPO / "tests/net_intruder.py"), "base", "sensor", "666")


def _state(p) -> dict:
    return json.loads(p.wait_for_line(r"^\{.*\}$", 30).group(0))


@pytest.mark.parametrize("net", LAN, indirect=True)
def test_default_graph_is_invisible_and_untouchable_from_the_lan(net: Topology, run_in) -> None:
    pub, echo = _graph(run_in)
    intruder = _intruder(run_in)
    # The stranger tries for 5 s (the --lan test below shows it succeeds in well under that).
    deadline = time.monotonic() + 5.0
    state = _state(intruder)
    while time.monotonic() < deadline:
        state = _state(intruder)
    assert state["puts"] > 10
    assert (state["samples"], state["tokens"], state["peers"]) == (0, 0, 0), state
    echo.wait_for_line(TRANSLATION, 10)  # still printing...
    values = [ln for ln in echo.lines if ln.startswith("- Translation:")]
    assert values and all(v.startswith("- Translation: [1.000,") for v in values), values  # ...and never 666
    assert not any("beyond this machine" in ln for ln in pub.lines + echo.lines)  # nothing to warn about


@pytest.mark.parametrize("net", LAN, indirect=True)
def test_lan_is_the_explicit_choice_and_says_so(net: Topology, run_in) -> None:
    pub, echo = _graph(run_in, "--lan")
    for p in (pub, echo):  # one line at start, naming what is exposed
        warnings = [ln for ln in p.lines if "beyond this machine without authentication" in ln]
        assert len(warnings) == 1 and "multicast scouting on" in warnings[0], p.lines
    intruder = _intruder(run_in)
    state = _state(intruder)
    while not (state["samples"] and state["tokens"]):
        state = _state(intruder)
    echo.wait_for_line(r"- Translation: \[666\.000, ", 30)  # a LAN peer's forged frame, only with --lan



@pytest.mark.parametrize("net", LAN, indirect=True)
def test_launch_lan_passes_the_choice_to_every_node(net: Topology, run_in) -> None:
    launch = run_in("a", *ZENTF, "launch", "laser", "--lan")
    intruder = _intruder(run_in)
    state = _state(intruder)
    while state["tokens"] < 5:  # the five nodes of configs/laser.yaml, seen from host b
        state = _state(intruder)
    launch.wait_for_line(r"beyond this machine without authentication", 30)

# ------------------------------------------------------------------ zero configuration on one machine

@pytest.fixture
def local_env() -> dict[str, str]:
    """No ZENTF_* settings but a rendezvous port of this test's own (a separate local graph)."""
    from conftest import free_port

    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PYTHONUNBUFFERED="1", ZENTF_LOCAL_PORT=str(free_port()),
               PYTHONPATH=os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
    return env


def test_readme_first_command_and_the_cli_work_with_zero_configuration(spawn, local_env) -> None:
    launch = spawn([*ZENTF, "launch", "laser"], env=local_env)
    launch.wait_for_line(r"launching .*laser\.yaml", 30)
    echo = spawn([*ZENTF, "tf", "echo", "camera", "laser", "--count", "1", "--timeout", "30"], env=local_env)
    assert echo.wait(60) == 0, echo.output()
    assert "- Translation:" in echo.output()
    nodes = subprocess.run([*ZENTF, "node", "list"], env=local_env, capture_output=True, text=True, timeout=60)
    assert {"/laser_static", "/camera_static", "/point_publisher"} <= set(nodes.stdout.split()), nodes
    topics = subprocess.run([*ZENTF, "topic", "list"], env=local_env, capture_output=True, text=True, timeout=60)
    assert "/tf_static" in topics.stdout.split(), topics
    ports = subprocess.run(["ss", "-ltnuHp"], capture_output=True, text=True).stdout
    pids = {launch.pid, *_children(launch.pid)}
    mine = [ln for ln in ports.splitlines() if any(f"pid={p}," in ln for p in pids)]
    assert mine and all(" 127.0.0.1:" in ln for ln in mine), mine  # TCP on loopback only, no UDP at all


def test_an_immediate_node_list_names_every_local_node(spawn, local_env) -> None:
    """A short-lived listing is complete at once: it asks the rendezvous, which every local
    peer links to, rather than only the peers gossip has linked it to by then. --wait 0 leaves no
    time to settle, so the answer must come whole from the first query; repeated, as a race would show
    only sometimes."""
    names = [f"/mesh{i}" for i in range(5)]
    for i, name in enumerate(names):
        p = spawn([*ZENTF, "static-transform-publisher", "--frame-id", f"f{i}", "--child-frame-id", f"g{i}",
                   "--name", name[1:]], env=local_env)
        p.wait_for_line(r"Spinning until stopped", 30)
    for wait in ("0", "0", "0", "0", "0", "2"):
        out = subprocess.run([*ZENTF, "node", "list", "--wait", wait], env=local_env, capture_output=True,
                             text=True, timeout=60)
        assert out.returncode == 0 and sorted(out.stdout.split()) == names, (wait, out)


def test_node_list_with_nothing_running_prints_nothing(local_env) -> None:
    """No holder: the listing falls back to a peer session, prints nothing and exits 0."""
    out = subprocess.run([*ZENTF, "node", "list"], env=local_env, capture_output=True, text=True, timeout=60)
    assert (out.returncode, out.stdout) == (0, ""), out


def _children(pid: int) -> list[int]:
    """Every descendant (the launcher's nodes run under a reaper each: grandchildren)."""
    from zentf.launch import proctree

    table = proctree.snapshot()
    return list(proctree.descendants(pid, table))


def test_the_rendezvous_is_taken_over_when_its_holder_exits(spawn, local_env) -> None:
    first = spawn([*ZENTF, "static-transform-publisher", "--frame-id", "a", "--child-frame-id", "b"], env=local_env)
    first.wait_for_line(r"Spinning until stopped", 30)
    second = spawn([*ZENTF, "static-transform-publisher", "--x", "2", "--frame-id", "c", "--child-frame-id", "d"],
                   env=local_env)
    second.wait_for_line(r"Spinning until stopped", 30)
    assert first.stop() == 0  # the holder of tcp/127.0.0.1:PORT goes away
    echo = spawn([*ZENTF, "tf", "echo", "c", "d", "--count", "1", "--timeout", "30"], env=local_env)
    assert echo.wait(60) == 0, echo.output()
    assert "- Translation: [2.000, 0.000, 0.000]" in echo.output()


@pytest.mark.parametrize("kwargs,exposed", [
    ({}, []),                                                                      # local profile
    ({"connect": ["tcp/127.0.0.1:7447"], "mode": "client"}, []),
    ({"lan": True}, ["tcp/[::]:0", "multicast scouting on"]),
    ({"connect": ["tcp/10.0.0.2:7447"], "mode": "client"}, ["tcp/10.0.0.2:7447"]),
    ({"config_file": str(REPO / "configs/zenoh/router.json5")}, ["tcp/0.0.0.0:7447"]),
    ({"config_file": str(REPO / "configs/zenoh/peer-lan.json5")}, ["tcp/0.0.0.0:0", "multicast scouting on"]),
    ({"config_file": str(REPO / "configs/zenoh/client.json5"), "connect": ["tcp/10.0.0.2:7447"]},
     ["tcp/10.0.0.2:7447"]),
])
def test_what_the_start_up_warning_names(kwargs, exposed) -> None:
    """The one-line warning's content for each profile and shipped config (mutual TLS: none, below)."""
    from zentf.transport.options import ZenohOptions, exposure

    assert exposure(ZenohOptions(**kwargs).config()) == exposed


def test_mutual_tls_is_not_warned_about(tmp_path, monkeypatch) -> None:
    from zentf.transport.options import ZenohOptions, exposure

    (tmp_path / "certs").mkdir()
    for name in ("ca.pem", "client.pem", "client.key"):  # client-tls.json5 names certs/... from the cwd
        (tmp_path / "certs" / name).write_text("x")
    monkeypatch.chdir(tmp_path)
    opts = ZenohOptions(config_file=str(REPO / "configs/zenoh/client-tls.json5"), connect=["tls/10.0.0.2:7447"])
    assert exposure(opts.config()) == []
