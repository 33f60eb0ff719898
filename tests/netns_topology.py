"""Throw-away "machines": Linux network namespaces joined to a router namespace by veth pairs.

    with Topology(["a", "b"]) as net:        # namespaces <prefix>-r, <prefix>-a, <prefix>-b
        net.router_ip("a")                   # 10.77.1.1: the router as seen from host a
        net.cmd("a", sys.executable, "-m", "nodes.frames_publisher", ...)   # argv to run inside a

With ``lan=True`` the first two hosts also share one Ethernet segment (10.78.0.0/24) with a
multicast route, for peers that find each other by scouting.
Host number i (1-based) gets 10.77.i.2/24 on its veth and the router namespace 10.77.i.1/24 on the
peer end; hosts reach each other only through a process in the router namespace (no IP forwarding).
The addresses exist only inside these namespaces. Names carry the creating pid, so a namespace left
behind by a killed run is found and deleted by the next ``Topology`` (``remove_stale``).
Needs root and iproute2 (``ip netns``); ``unavailable_reason()`` says why not, for a skip.
"""
from __future__ import annotations

import itertools
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Sequence

PREFIX = "ztn"
SUBNET = "10.77"
_counter = itertools.count()
_NAME = re.compile(rf"{PREFIX}(\d+)x\d+-\w+\Z")


class NetnsError(RuntimeError):
    """An ``ip`` command failed; the message holds its stderr."""


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    proc = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20)
    if check and proc.returncode != 0:
        raise NetnsError(f"ip {' '.join(args)}: {proc.stderr.strip() or proc.returncode}")
    return proc


def unavailable_reason() -> str | None:
    """None when namespaces can be made here, else why not (for ``pytest.skip``)."""
    if os.name != "posix" or not hasattr(os, "geteuid"):
        return "network namespaces need Linux"
    if os.geteuid() != 0:
        return "network namespace tests need root (ip netns add); run as root or in CI"
    if shutil.which("ip") is None:
        return "iproute2 'ip' command not found (apt-get install iproute2)"
    probe = f"{PREFIX}{os.getpid()}x{next(_counter)}-probe"
    proc = _ip("netns", "add", probe, check=False)
    if proc.returncode != 0:
        return f"'ip netns add' failed here: {proc.stderr.strip()}"
    _ip("netns", "del", probe, check=False)
    return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def existing() -> list[str]:
    out = _ip("netns", "list", check=False).stdout
    return [line.split()[0] for line in out.splitlines() if line.strip()]


def remove_stale() -> list[str]:
    """Delete namespaces of ours whose creating process is gone; returns their names."""
    removed = []
    for name in existing():
        m = _NAME.match(name)
        if m and not _alive(int(m.group(1))):
            _ip("netns", "del", name, check=False)
            removed.append(name)
    return removed


class Topology:
    """A router namespace plus one namespace per host, each host on its own veth link to the router."""

    def __init__(self, hosts: Sequence[str] = ("a", "b"), *, router: str = "r", lan: bool = False) -> None:
        """``lan=True``: also one Ethernet segment between the first two hosts (10.78.0.1/.2, multicast on)."""
        if len(hosts) > 9 or not all(re.fullmatch(r"[a-z]\w{0,3}", h) for h in hosts):
            raise ValueError("hosts: up to 9 short names like 'a', 'b', 'c1'")
        self.tag = f"{PREFIX}{os.getpid()}x{next(_counter)}"
        self.hosts = list(hosts)
        self.router = router
        self.lan = lan
        self.namespaces: dict[str, str] = {h: f"{self.tag}-{h}" for h in [router, *hosts]}
        self._created: list[str] = []

    # ---- lifecycle
    def __enter__(self) -> "Topology":
        self.create()
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()

    def create(self) -> None:
        remove_stale()
        try:
            for ns in self.namespaces.values():
                _ip("netns", "add", ns)
                self._created.append(ns)
                _ip("-n", ns, "link", "set", "lo", "up")
            r = self.namespaces[self.router]
            for i, host in enumerate(self.hosts, start=1):
                h = self.namespaces[host]
                # Both ends are created directly inside our namespaces: nothing touches the root stack.
                _ip("-n", h, "link", "add", "eth0", "type", "veth", "peer", "name", f"to_{host}", "netns", r)
                _ip("-n", h, "addr", "add", f"{SUBNET}.{i}.2/24", "dev", "eth0")
                _ip("-n", r, "addr", "add", f"{SUBNET}.{i}.1/24", "dev", f"to_{host}")
                _ip("-n", h, "link", "set", "eth0", "up")
                _ip("-n", r, "link", "set", f"to_{host}", "up")
            if self.lan:
                h1, h2 = (self.namespaces[h] for h in self.hosts[:2])
                _ip("-n", h1, "link", "add", "lan0", "type", "veth", "peer", "name", "lan0", "netns", h2)
                for i, ns in enumerate((h1, h2), start=1):
                    _ip("-n", ns, "addr", "add", f"10.78.0.{i}/24", "dev", "lan0")
                    _ip("-n", ns, "link", "set", "lan0", "multicast", "on", "up")
                    _ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", "lan0")
        except Exception:
            self.destroy()
            raise

    def destroy(self) -> None:
        """Delete the namespaces (their veth pairs go with them). Processes inside must be stopped first."""
        for ns in reversed(self._created):
            _ip("netns", "del", ns, check=False)
        self._created.clear()

    # ---- addresses and commands
    def index(self, host: str) -> int:
        return self.hosts.index(host) + 1

    def host_ip(self, host: str) -> str:
        return f"{SUBNET}.{self.index(host)}.2"

    def router_ip(self, host: str) -> str:
        """The router namespace's address on ``host``'s link."""
        return f"{SUBNET}.{self.index(host)}.1"

    def cmd(self, where: str, *argv: str) -> list[str]:
        """argv that runs ``argv`` inside host (or router) ``where``."""
        return ["ip", "netns", "exec", self.namespaces[where], *argv]

    def link(self, host: str, up: bool) -> None:
        """Take host's only link down (cable pulled) or up again."""
        _ip("-n", self.namespaces[host], "link", "set", "eth0", "up" if up else "down")

    def reaches(self, host: str, target: str | None = None, timeout: float = 1.0) -> bool:
        """Does ``host`` reach ``target`` (default: the router over its link)? A TCP connect to port 9:
        refused or accepted = reachable; unreachable network or timeout = not."""
        code = ("import socket,sys\ntry: socket.create_connection((sys.argv[1], 9), %r)\n"
                "except ConnectionRefusedError: sys.exit(0)\nexcept OSError: sys.exit(1)" % timeout)
        argv = self.cmd(host, sys.executable, "-c", code, target or self.router_ip(host))
        return subprocess.run(argv, capture_output=True, timeout=timeout + 10).returncode == 0
