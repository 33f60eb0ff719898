"""configs/zenoh/router-acl.json5 is an allow-list, tested across network namespaces with real certificates.

One router (mutual TLS + the shipped ACL) in its own namespace serves three hosts, set up once for the
module: host a holds robot-a's certificate (tf publisher, clock owner) and runs a launch with a sim clock
and a static transform world -> tower (zentf wire) plus world -> tower2 on the ROS 2 wire; host b holds
base-b's (tf and clock listener) and runs listeners of both wires and of /clock, and an operator's
certificate (graph, parameters, clock control); host i holds ``intruder``, a valid certificate in no role,
and runs tests/acl_intruder.py (forged transforms and clocks on wildcard keys, wildcard clock-control and
parameter queries, ``**`` subscriptions and liveliness) plus the stock ROS 2 wire static publisher.
Skipped unless root with iproute2 and openssl (CI runs as root).
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from conftest import REPO, Proc
from netns_fixtures import net_env, topology
from netns_topology import Topology
from security_helpers import CLIENT_TLS, ROUTER_ACL, machine_dir, make_certs

pytestmark = pytest.mark.timeout(180)

NS = "acl"
ZENTF = [sys.executable, "-m", "zentf.cli"]
TRANSLATION = r"- Translation: \[(\S+),"
LAUNCH = textwrap.dedent("""\
    description: robot-a's graph for the ACL tests - a sim clock and a static transform.
    clock: {start: 1000, rate: 1.0, frequency: 20}
    nodes:
      - run: static_transform_publisher
        name: static_transform_publisher_tower
        arguments: [--x, "1", --frame-id, world, --child-frame-id, tower]
    """)


class Graph:
    """The module's hosts, their machine directories and the processes started in them."""

    def __init__(self, net: Topology, base: Path) -> None:
        self.net, self.base = net, base
        self.certs = make_certs(base / "ca", sans=[net.router_ip(h) for h in ("a", "b", "i")])
        self.procs: list[Proc] = []

    def flags(self, host: str) -> list[str]:
        return ["--zenoh-config", str(CLIENT_TLS), "--connect", f"tls/{self.net.router_ip(host)}:7447",
                "--namespace", NS]

    def machine(self, name: str, key_of: str | None = None) -> Path:
        return machine_dir(self.base, self.certs, name, key_of=key_of)

    def start(self, host: str, who: str, *argv: str) -> Proc:
        p = Proc(self.net.cmd(host, *argv), env=net_env(), cwd=self.machine(who))
        self.procs.append(p)
        return p

    def run(self, host: str, who: str, *argv: str, timeout: float = 60) -> subprocess.CompletedProcess:
        return subprocess.run(self.net.cmd(host, *argv), env=net_env(), cwd=self.machine(who), capture_output=True,
                              text=True, timeout=timeout)

    def stop(self) -> None:
        for p in reversed(self.procs):
            try:
                p.stop(timeout=3)
            except Exception:
                p.kill()


@pytest.fixture(scope="module")
def graph(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Graph]:
    for net in topology(["a", "b", "i"]):
        g = Graph(net, tmp_path_factory.mktemp("acl"))
        try:
            router = g.start("r", "router", *ZENTF, "router", "--config", str(ROUTER_ACL))
            router.wait_for_line(r"listening on tls/", 30)
            launch_file = g.base / "robot_a.yaml"
            launch_file.write_text(LAUNCH)
            g.launch = g.start("a", "robot-a", *ZENTF, "launch", str(launch_file), *g.flags("a"))
            g.ros2_static = g.start("a", "robot-a", *ZENTF, "static-transform-publisher", "--x", "1", "--frame-id",
                                    "world", "--child-frame-id", "tower2", "--wire", "ros2", *g.flags("a"))
            g.launch.wait_for_line(r"Spinning until stopped", 60)
            g.ros2_static.wait_for_line(r"Spinning until stopped", 60)
            g.echo = g.start("b", "base-b", *ZENTF, "tf", "echo", "world", "tower", "--rate", "5", *g.flags("b"))
            g.echo2 = g.start("b", "base-b", *ZENTF, "tf", "echo", "world", "tower2", "--rate", "5", "--wire", "ros2",
                              *g.flags("b"))
            g.clock = g.start("b", "base-b", *ZENTF, "topic", "echo", "/clock", "--json", *g.flags("b"))
            for p in (g.echo, g.echo2):  # the listed listeners get the listed publishers' frames (both wires)...
                assert p.wait_for_line(TRANSLATION, 60).group(1) == "1.000"
            g.clock.wait_for_line(r'^\{"clock":\{"sec":10\d\d,', 60)
            g.watch = g.start("b", "base-b", sys.executable, str(REPO / "tests/acl_intruder.py"),
                              f"tls/{net.router_ip('b')}:7447", NS, "--watch")
            _state(g.watch, lambda s: s["samples"] > 0)
            # ...then the intruder starts, and the stock ROS 2 wire static publisher with its certificate
            g.intruder = g.start("i", "intruder", sys.executable, str(REPO / "tests/acl_intruder.py"),
                                 f"tls/{net.router_ip('i')}:7447", NS)
            g.intruder_static = g.start("i", "intruder", *ZENTF, "static-transform-publisher", "--x", "666",
                                        "--frame-id", "world", "--child-frame-id", "tower2", "--wire", "ros2",
                                        *g.flags("i"))
            g.intruder_static.wait_for_line(r"Spinning until stopped", 60)
            g.state = _state(g.intruder, lambda s: s["puts"] >= 15 * 30)  # 15 rounds of every forgery
            yield g
        finally:
            g.stop()


def _state(p: Proc, cond=lambda s: True) -> dict:
    while True:
        s = json.loads(p.wait_for_line(r"^\{.*\}$", 60).group(0))
        if cond(s):
            return s


def _values(p: Proc) -> list[str]:
    p.wait_for_line(TRANSLATION, 30)  # one more after the forgeries
    return [m.group(1) for ln in p.lines if (m := re.match(TRANSLATION, ln))]


def test_wildcard_tf_puts_by_an_unlisted_certificate_reach_no_listener(graph: Graph) -> None:
    """Not forwarded by the router (a listed listener's raw subscriptions get none of them), and not
    inserted by a listener either way."""
    values = _values(graph.echo)
    assert len(values) > 10 and set(values) == {"1.000"}, values
    watched = _state(graph.watch, lambda s: s["samples"] >= 100 or s["wildcard"])  # 5 s of clock, intruder on
    assert watched["wildcard"] == 0, watched


def test_wildcard_clock_puts_by_an_unlisted_certificate_reach_no_listener(graph: Graph) -> None:
    graph.clock.wait_for_line(r'^\{"clock"', 30)
    secs = [json.loads(ln)["clock"]["sec"] for ln in graph.clock.lines if ln.startswith('{"clock"')]
    assert len(secs) > 20 and min(secs) >= 1000 and secs == sorted(secs), secs[:50]


def test_wildcard_clock_control_queries_by_an_unlisted_certificate_are_not_obeyed(graph: Graph) -> None:
    out = graph.run("b", "operator", *ZENTF, "clock", "--json", *graph.flags("b"))
    assert out.returncode == 0, out.stderr
    state = json.loads(out.stdout)
    assert (state["rate"], state["paused"]) == (1.0, False), state  # never paused, never at rate 100
    assert graph.state["replies"] == 0, graph.state


def test_the_stock_ros2_wire_publisher_of_an_unlisted_certificate_reaches_no_listener(graph: Graph) -> None:
    values = _values(graph.echo2)
    assert len(values) > 10 and set(values) == {"1.000"}, values
    assert graph.intruder_static.returncode is None  # it ran all along


def test_parameters_are_a_role(graph: Graph) -> None:
    node = f"/{NS}/static_transform_publisher_tower"
    operator = graph.run("b", "operator", *ZENTF, "param", "list", node, *graph.flags("b"))
    assert operator.returncode == 0 and "use_sim_time" in operator.stdout, operator
    intruder = graph.run("i", "intruder", *ZENTF, "param", "set", node, "use_sim_time", "false", *graph.flags("i"),
                         timeout=90)
    assert intruder.returncode != 0 and "Traceback" not in intruder.stderr, intruder
    after = graph.run("b", "operator", *ZENTF, "param", "get", node, "use_sim_time", *graph.flags("b"))
    assert after.returncode == 0 and "Boolean value is: true" in after.stdout, after  # unchanged


def test_an_unlisted_certificate_reads_nothing(graph: Graph) -> None:
    """Its ``**`` subscription, liveliness subscribers and queries got nothing; the operator's listing (role
    graph) sees robot-a's nodes."""
    state = _state(graph.intruder)
    assert (state["samples"], state["tokens"], state["replies"]) == (0, 0, 0), state
    nodes = graph.run("b", "operator", *ZENTF, "node", "list", *graph.flags("b"))
    assert f"/{NS}/static_transform_publisher_tower" in nodes.stdout.split(), nodes
