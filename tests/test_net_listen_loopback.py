"""Safe by default, socket by socket: every long-running zentf program started with no network option
listens on loopback only - its Zenoh session, the slider page, the view's web viewer and data server, the
router, the bridges, and every process a launch starts.

All programs run at once in one private local graph (their own ZENTF_LOCAL_PORT); the sockets are read
from the kernel (psutil) for each program's whole process tree once it said it is ready.
"""
from __future__ import annotations

import ipaddress
import os
import socket
import sys

import psutil
import pytest

from conftest import REPO, free_port

pytestmark = pytest.mark.timeout(150)

ZENTF = [sys.executable, "-m", "zentf.cli"]
R2D2 = REPO / "tests/data/urdf/urdf_tutorial/urdf/06-flexible.urdf"
BAG = REPO / "tests/data/nav2_turtlebot.mcap"


def _port_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def _listening(pid: int) -> list[tuple[str, str, int, str]]:
    """(kind, address, port, process) of every listening TCP socket and every unconnected UDP socket of the
    tree rooted at ``pid``."""
    found = []
    root = psutil.Process(pid)
    for proc in (root, *root.children(recursive=True)):
        try:
            conns = proc.net_connections(kind="inet")
            name = " ".join(proc.cmdline()[:4])
        except psutil.Error:  # exited meanwhile
            continue
        for c in conns:
            if c.type == socket.SOCK_STREAM and c.status == psutil.CONN_LISTEN:
                found.append(("tcp", c.laddr.ip, c.laddr.port, name))
            elif c.type == socket.SOCK_DGRAM and not c.raddr:
                found.append(("udp", c.laddr.ip, c.laddr.port, name))
    return found


def test_every_long_running_program_listens_on_loopback_only(spawn, tmp_path) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PYTHONUNBUFFERED="1", ZENTF_LOCAL_PORT=str(free_port()),
               PYTHONPATH=os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
    programs: dict[str, tuple[list[str], str]] = {  # name: (argv, the line that says it is up)
        "view --web": (["view", "--web", "--web-port", str(free_port()), "--grpc-port", str(free_port())],
                       r"^viewing "),
        "joint-state-publisher --gui": (["joint-state-publisher", str(R2D2), "--gui", "--no-browser"],
                                        r"sliders: http://"),
        "robot-state-publisher": (["robot-state-publisher", str(R2D2)], r"publishing robot"),
        "static-transform-publisher": (["static-transform-publisher", "--frame-id", "a", "--child-frame-id", "b"],
                                       r"Spinning until stopped"),
        "tf echo": (["tf", "echo", "a", "b"], r"Translation|Waiting for transform"),
        "topic pub": (["topic", "pub", "chatter", "geometry_msgs/msg/Point", "{x: 1}"], r"publishing #2"),
        "bag play": (["bag", "play", str(BAG), "--loop"], r"playing .* \(Ctrl-C to stop\)"),
        "bag record": (["bag", "record", "--all", "-o", str(tmp_path / "rec.mcap")], r"[Rr]ecording"),
        "buffer_server": (["run", "buffer_server"], r"serving /tf2_buffer_server"),
        "turtlesim": (["run", "turtlesim"], r"spawned turtle1"),
        "bridge ros2": (["bridge", "ros2"], r"bridging tf"),
        "launch laser": (["launch", "laser"], r"\[frame_listener\]"),
    }
    if _port_free(7447):  # the router's default port (another run may hold it: that run checks the router)
        programs["router"] = (["router"], r"listening on")
    try:
        import cyclonedds  # noqa: F401
        programs["bridge dds"] = (["bridge", "dds"], r"dds bridge: active")
    except ImportError:
        pass
    procs = {name: spawn([*ZENTF, *argv], env=env, cwd=tmp_path) for name, (argv, _) in programs.items()}
    wide = {}
    for name, (_, ready) in programs.items():
        procs[name].wait_for_line(ready, 90)
        sockets = _listening(procs[name].pid)
        assert sockets, f"{name}: no socket at all (its Zenoh session listens on loopback)"
        if name == "bridge dds":  # see below
            sockets = [s for s in sockets if s[0] == "tcp" or s[1] != "0.0.0.0"]
        bad = [s for s in sockets if not ipaddress.ip_address(s[1]).is_loopback]
        if bad:
            wide[name] = bad
    assert not wide, f"listening beyond loopback under defaults: {wide}"
    # Cyclone DDS (11) binds its UDP receive sockets to 0.0.0.0 whatever the interface; the bridge's
    # participant uses the 127.0.0.1 interface only, no multicast, and tests/test_net_dds_local_default.py
    # proves a participant on the LAN neither sees nor feeds it. Every other socket is loopback.
