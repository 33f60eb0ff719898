"""turtle_teleop_key through a pseudo-terminal: arrow keys -> cmd_vel, raw mode on while it runs and
restored on q, Ctrl-C and SIGTERM, a clear error without a terminal, and `zentf launch turtles teleop:=key`."""
from __future__ import annotations

import ctypes
import fcntl
import os
import signal
import subprocess
import sys
import termios
import threading
from collections.abc import Iterator

import pytest

from conftest import REPO, Proc
from zentf.demos.turtle_teleop_key import parse_keys
from zentf.core.messages import TurtlePose, Twist
from zentf.transport.node import Node

UP, DOWN, RIGHT, LEFT = b"\x1b[A", b"\x1b[B", b"\x1b[C", b"\x1b[D"


def test_parse_keys():
    assert parse_keys(UP + DOWN + b"x" + RIGHT + LEFT) == (["up", "down", "right", "left"], b"")
    assert parse_keys(b"\x1bOA") == (["up"], b"")  # application cursor mode
    assert parse_keys(UP + b"\x1b[") == (["up"], b"\x1b[")  # the rest comes with the next read
    assert parse_keys(b"\x1b") == ([], b"\x1b")
    assert parse_keys(b"\x1b[Zq") == (["quit"], b"")


def test_without_a_terminal_it_says_so(spawn):
    p = spawn.python("-m", "nodes.turtle_teleop_key")  # stdin is /dev/null
    assert p.wait(30) == 1
    assert "turtle_teleop_key: error: stdin is not a terminal" in p.output()
    assert "Traceback" not in p.output()


class PtyProc(Proc):
    """A child whose stdin (and controlling terminal) is a fresh pseudo-terminal; stdout stays a pipe."""

    def __init__(self, args: list[str], env: dict[str, str]) -> None:
        self.master, self.slave = os.openpty()
        slave = self.slave

        def setup() -> None:  # pragma: no cover - runs in the child
            os.setsid()
            fcntl.ioctl(slave, termios.TIOCSCTTY, 0)
            ctypes.CDLL("libc.so.6").prctl(1, signal.SIGTERM)

        self.args = list(args)
        self.popen = subprocess.Popen(self.args, env=env, cwd=str(REPO), stdin=slave, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True, bufsize=1, preexec_fn=setup)
        self.lines = []
        import queue
        self._new = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self._cursor = 0
        self.original = termios.tcgetattr(self.slave)

    def keys(self, data: bytes) -> None:
        os.write(self.master, data)

    def lflags(self) -> int:
        return termios.tcgetattr(self.slave)[3]

    def close(self) -> None:
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


@pytest.fixture
def pty_spawn(zenoh_env) -> Iterator:
    procs: list[PtyProc] = []

    def _spawn(*args: str) -> PtyProc:
        p = PtyProc([sys.executable, *args], zenoh_env)
        procs.append(p)
        return p

    yield _spawn
    for p in procs:
        p.stop(5)
        p.close()


@pytest.fixture
def twists(node_options) -> Iterator[tuple[list[Twist], threading.Condition]]:
    got: list[Twist] = []
    cond = threading.Condition()

    def on(msg: Twist) -> None:
        with cond:
            got.append(msg)
            cond.notify_all()

    with Node("cmd_probe", options=node_options) as node:
        node.create_subscription("turtle1/cmd_vel", Twist, on)
        yield got, cond


def press(p: PtyProc, key: bytes, got: list[Twist], cond: threading.Condition) -> Twist:
    """Press until a Twist arrives (the first presses may beat the route to this subscriber)."""
    for _ in range(20):
        with cond:
            n = len(got)
        p.keys(key)
        with cond:
            if cond.wait_for(lambda: len(got) > n, 1.5):
                return got[n]
    raise AssertionError(f"no cmd_vel after pressing {key!r}; output:\n{p.output()}")


def test_arrow_keys_publish_cmd_vel_and_ctrl_c_restores_the_terminal(pty_spawn, twists):
    got, cond = twists
    p = pty_spawn("-m", "nodes.turtle_teleop_key")
    p.wait_for_line(r"Use arrow keys to move the turtle", 30)
    flags = p.lflags()
    assert not flags & termios.ICANON and not flags & termios.ECHO and flags & termios.ISIG  # raw while running
    t = press(p, UP, got, cond)
    assert (t.linear.x, t.angular.z) == (2.0, 0.0)
    for key, expected in ((LEFT, (0.0, 2.0)), (DOWN, (-2.0, 0.0)), (RIGHT, (0.0, -2.0))):
        t = press(p, key, got, cond)
        assert (t.linear.x, t.angular.z) == expected
    p.keys(b"\x03")  # Ctrl-C typed on the terminal: SIGINT to its foreground group
    assert p.wait(20) == 0
    assert termios.tcgetattr(p.slave) == p.original


@pytest.mark.parametrize("how", ["q", "SIGTERM"])
def test_q_and_sigterm_restore_the_terminal(pty_spawn, how):
    p = pty_spawn("-m", "nodes.turtle_teleop_key", "-p", "turtlename:=t9")
    p.wait_for_line(r"'q' to quit", 30)
    assert not p.lflags() & termios.ICANON
    if how == "q":
        p.keys(b"q")
    else:
        p.signal(signal.SIGTERM)
    assert p.wait(20) == 0
    assert termios.tcgetattr(p.slave) == p.original
    assert "Traceback" not in p.output()


def test_launch_turtles_with_teleop_key_drives_turtle1(pty_spawn, node_options):
    poses: list[TurtlePose] = []
    cond = threading.Condition()

    def on(msg: TurtlePose) -> None:
        with cond:
            poses.append(msg)
            cond.notify_all()

    with Node("pose_probe", options=node_options) as node:
        node.create_subscription("turtle1/pose", TurtlePose, on)
        p = pty_spawn("-m", "zentf.launch", "turtles", "teleop:=key", "--no-color")
        p.wait_for_line(r"\[(?:[\w/]+/)?teleop\].*Use arrow keys to move the turtle", 60)
        with cond:
            assert cond.wait_for(lambda: bool(poses), 30)
            x0 = poses[-1].x
        assert not p.lflags() & termios.ICANON  # the launched teleop has the terminal in raw mode
        moved = False
        for _ in range(40):
            p.keys(UP)
            with cond:
                if cond.wait_for(lambda: poses[-1].x > x0 + 0.5, 1.0):
                    moved = True
                    break
        assert moved, f"turtle1 did not move forward from x={x0}; output:\n{p.output()[-2000:]}"
        p.keys(b"q")  # quitting the (required) teleop ends the demo
        assert p.wait(60) == 0
        assert termios.tcgetattr(p.slave) == p.original
        assert "Traceback" not in p.output()
