"""turtle_teleop_key: the arrow keys of this terminal drive a turtle, as in the ROS turtlesim tutorial.

Each arrow key publishes one Twist on `<turtlename>/cmd_vel` (default turtle1): up/down move
forward/backward at `scale_linear` (default 2.0 m/s), left/right turn at `scale_angular` (default
2.0 rad/s); turtlesim applies a command for 1 s. `q` quits. The terminal is put in raw mode (no line
buffering, no echo; Ctrl-C still stops the node) and restored on every exit: `q`, Ctrl-C, SIGTERM,
an error.

Reads stdin, which must be a terminal (a clear error otherwise; use `turtle_teleop` for a scripted
drive). Parameter `terminal` (e.g. `/dev/tty`) reads that terminal instead: `zentf launch turtles
teleop:=key` uses it, since launched nodes get no stdin; the node then takes the terminal's
foreground while it runs and gives it back when it ends.
"""
from __future__ import annotations

import contextlib
import logging
import os
import select
import signal
import sys
import termios
from typing import Iterator, Sequence

from ..transport import program
from ..core.messages import Twist, Vector3
from ..transport.options import NodeOptions

log = logging.getLogger("turtle_teleop_key")

PROG = "turtle_teleop_key"
#: arrow key -> (linear, angular) before scaling, as ROS 2's turtle_teleop_key
KEYS = {"up": (1.0, 0.0), "down": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}
_ARROWS = {ord("A"): "up", ord("B"): "down", ord("C"): "right", ord("D"): "left"}
BANNER = ("Reading from keyboard\n---------------------------\n"
          "Use arrow keys to move the turtle.\n'q' to quit.")


class NotATerminal(program.OptionsError):
    """The input is not a terminal: nothing to read keys from."""


def parse_keys(buf: bytes) -> tuple[list[str], bytes]:
    """Bytes typed so far -> (key names: up/down/left/right/quit, bytes of an unfinished sequence).

    Arrows are ``ESC [ A..D`` (or ``ESC O A..D`` in application cursor mode); other bytes are ignored.
    """
    keys: list[str] = []
    i = 0
    n = len(buf)
    while i < n:
        b = buf[i]
        if b == 0x1B:
            if i + 1 >= n or (buf[i + 1] in b"[O" and i + 2 >= n):
                return keys, buf[i:]  # wait for the rest of the sequence
            if buf[i + 1] in b"[O":
                name = _ARROWS.get(buf[i + 2])
                if name:
                    keys.append(name)
                i += 3
                continue
            i += 1
            continue
        if b in b"qQ\x03\x04":  # q, and Ctrl-C / Ctrl-D should the terminal pass them as bytes
            keys.append("quit")
        i += 1
    return keys, b""


@contextlib.contextmanager
def raw_terminal(fd: int) -> Iterator[None]:
    """No line buffering and no echo on ``fd`` (Ctrl-C still signals), restored whatever happens.

    If this process is not in the terminal's foreground (a launched node), it takes the foreground
    for as long as it runs, then gives it back.
    """
    old_fg = os.tcgetpgrp(fd)
    me = os.getpgrp()
    took = old_fg != me
    if took:
        _quiet_tcsetpgrp(fd, me)
    old = termios.tcgetattr(fd)
    new = termios.tcgetattr(fd)
    new[3] &= ~(termios.ICANON | termios.ECHO)  # lflags (ISIG stays: Ctrl-C is SIGINT)
    new[6][termios.VMIN] = 1
    new[6][termios.VTIME] = 0
    termios.tcsetattr(fd, termios.TCSANOW, new)
    try:
        yield
    finally:
        with contextlib.suppress(termios.error, OSError):
            _quiet_tcsetattr(fd, old)
        if took:
            with contextlib.suppress(OSError):
                _quiet_tcsetpgrp(fd, old_fg)


def _quiet_tcsetpgrp(fd: int, pgrp: int) -> None:
    prev = signal.signal(signal.SIGTTOU, signal.SIG_IGN)  # a background group may change it this way
    try:
        os.tcsetpgrp(fd, pgrp)
    finally:
        signal.signal(signal.SIGTTOU, prev)


def _quiet_tcsetattr(fd: int, attrs: list) -> None:
    prev = signal.signal(signal.SIGTTOU, signal.SIG_IGN)
    try:
        termios.tcsetattr(fd, termios.TCSADRAIN, attrs)
    finally:
        signal.signal(signal.SIGTTOU, prev)


def open_terminal(path: str) -> tuple[int, bool]:
    """(fd of the keyboard, whether we opened it); NotATerminal says why there is none."""
    if not path:
        fd = sys.stdin.fileno() if sys.stdin is not None else -1
        if fd < 0 or not os.isatty(fd):
            raise NotATerminal("stdin is not a terminal: run turtle_teleop_key in a terminal "
                               "(or use turtle_teleop for a scripted drive)")
        return fd, False
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    except OSError as e:
        raise NotATerminal(f"cannot open terminal {path}: {e.strerror} (no terminal to read keys from; "
                           "use turtle_teleop for a scripted drive)") from None
    if not os.isatty(fd):
        os.close(fd)
        raise NotATerminal(f"{path} is not a terminal")
    return fd, True


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, "teleop_turtle") as node:
        name = str(program.param(node, "turtlename", "turtle1"))
        linear = program.param_float(node, "scale_linear", 2.0)
        angular = program.param_float(node, "scale_angular", 2.0)
        fd, opened = open_terminal(str(program.param(node, "terminal", "") or ""))
        pub = node.create_publisher(f"{name}/cmd_vel", Twist)
        try:
            with raw_terminal(fd):
                _say_raw(fd, BANNER, opened)
                _loop(node, fd, pub, linear, angular)
        finally:
            if opened:
                os.close(fd)


def _say_raw(fd: int, text: str, opened: bool) -> None:
    if opened:  # a launched node: its stdout is the launcher's pipe, the user looks at the terminal
        os.write(fd, (text.replace("\n", "\r\n") + "\r\n").encode())
    for line in text.split("\n"):
        program.say(line)


def _loop(node: object, fd: int, pub: object, linear: float, angular: float) -> None:
    pending = b""
    while node.ok():  # type: ignore[attr-defined]
        ready, _, _ = select.select([fd], [], [], 0.1)
        if not ready:
            if pending:  # a lone ESC: not the start of an arrow after all
                pending = b""
            continue
        try:
            data = os.read(fd, 64)
        except InterruptedError:
            continue
        except OSError as e:  # the terminal went away (hang-up)
            log.info("terminal closed (%s)", e.strerror)
            return
        if not data:
            return
        keys, pending = parse_keys(pending + data)
        for key in keys:
            if key == "quit":
                program.say("quit")
                return
            v, w = KEYS[key]
            pub.publish(Twist(linear=Vector3(linear * v, 0.0, 0.0), angular=Vector3(0.0, 0.0, angular * w)))  # type: ignore[attr-defined]
            log.debug("%s: linear %g angular %g", key, linear * v, angular * w)


if __name__ == "__main__":
    program.finish(main())
