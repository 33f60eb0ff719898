"""Pytest fixtures for tests across network namespaces: ``net`` (a Topology), ``run_in`` (processes inside).

Import them into a test module: ``from netns_fixtures import net, run_in  # noqa: F401``.
"""
from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from typing import Any

import pytest

from conftest import REPO, Proc
from netns_topology import Topology, unavailable_reason

CLIENT_CONFIG = str(REPO / "configs/zenoh/client.json5")
ROUTER_CONFIG = str(REPO / "configs/zenoh/router.json5")


def net_env() -> dict[str, str]:
    """os.environ without ZENTF_* (each process gets explicit flags), unbuffered, repo importable."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PYTHONUNBUFFERED="1", PYTHONPATH=os.pathsep.join(
        p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
    return env


def topology(hosts: list[str], lan: bool = False) -> Iterator[Topology]:
    reason = unavailable_reason()
    if reason:
        pytest.skip(reason)
    with Topology(hosts, lan=lan) as topo:
        yield topo


@pytest.fixture
def net(request: pytest.FixtureRequest) -> Iterator[Topology]:
    """Hosts a and b around a router namespace; ``@pytest.mark.parametrize('net', [[hosts...]] or
    [{"hosts": [...], "lan": True}], indirect=True)`` for others."""
    param = getattr(request, "param", ["a", "b"])
    if isinstance(param, dict):
        yield from topology(param["hosts"], lan=param.get("lan", False))
    else:
        yield from topology(param)


@pytest.fixture
def run_in(net: Topology) -> Iterator:
    """``run_in(where, *argv) -> Proc`` inside a namespace; all stopped before the namespaces go."""
    procs: list[Proc] = []

    def _run(where: str, *argv: str, env: dict[str, str] | None = None, **kw: Any) -> Proc:
        p = Proc(net.cmd(where, *argv), env=env or net_env(), **kw)
        procs.append(p)
        return p

    try:
        yield _run
    finally:
        for p in reversed(procs):
            try:
                p.stop(timeout=3)
            except Exception:
                p.kill()


def start_router(run_in: Any, config: str = ROUTER_CONFIG, **kw: Any) -> Proc:
    """``zentf router --config configs/zenoh/router.json5`` in the router namespace (tcp/0.0.0.0:7447)."""
    router = run_in("r", sys.executable, "-m", "zentf.cli", "router", "--config", config, **kw)
    router.wait_for_line(r"listening on ", 30)
    return router


def client_args(net: Topology, host: str) -> list[str]:
    """Zenoh flags of a node on ``host``: the shipped client config, pointed at the router's address."""
    return ["--zenoh-config", CLIENT_CONFIG, "--connect", f"tcp/{net.router_ip(host)}:7447"]


def node(run_in: Any, net: Topology, host: str, module: str, *args: str) -> Proc:
    return run_in(host, sys.executable, "-m", module, *client_args(net, host), *args)


def probe(run_in: Any, net: Topology, host: str, *args: str) -> Proc:
    return run_in(host, sys.executable, str(REPO / "tests/net_probe.py"), *client_args(net, host), *args)


def next_state(p: Proc, cond: Any = lambda s: True, timeout: float = 15.0) -> dict[str, Any]:
    """The next probe line (JSON) for which ``cond(state)`` holds."""
    while True:
        m = p.wait_for_line(r"^\{.*\}$", timeout)
        state = json.loads(m.group(0))
        if cond(state):
            return state


def wait_stalled(p: Proc, timeout: float = 10.0) -> int:
    """Skip probe lines until av1's latest stamp stops moving (two ticks alike); returns that stamp.

    Lines printed before a fault was injected are still queued, so "the next line" is not enough."""
    prev = None
    while True:
        stamp = next_state(p, timeout=timeout)["av1_ns"]
        if prev is not None and stamp == prev:
            return stamp
        prev = stamp
