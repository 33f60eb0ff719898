"""joint_state_publisher: ``joint_states`` for every movable joint of a URDF model.

Values start at joint_state_publisher's defaults (0, or the middle of the range when 0 is outside
it), may be set per joint, swept between the limits, or moved from the web page of
``zentf.tools.joint_state_gui``. Mimic joints are published too, computed from their master
(``use_mimic_tags``). Each change is published at once; the timer re-publishes at ``rate`` Hz.

The program (``zentf run joint_state_publisher``):

    zentf run joint_state_publisher configs/robots/my_robot.urdf              # start values
    zentf run joint_state_publisher robot.urdf --set head_swivel=0.8 --set gripper_extension=-0.2
    zentf run joint_state_publisher robot.urdf --sweep                        # each joint between its limits
    zentf run joint_state_publisher robot.urdf --gui                          # sliders in the browser

Start values are joint_state_publisher's: 0, or the middle of the range when 0 is outside it.
Parameters: ``rate`` (Hz, default 10), ``robot_description`` (URDF text when no file is given).
With neither a file nor the parameter, the model is read from the latched ``robot_description``
topic that robot_state_publisher publishes (as ROS 2's joint_state_publisher does).
"""
from __future__ import annotations

import logging
import math
import random
import threading
import time
from collections.abc import Mapping

from ..core.messages import Header, JointState
from ..core.text import printable
from ..transport.node import Node
from ..transport.clock import rate_problem
from ..urdf import Kinematics, Robot
import argparse
import os
import sys
from typing import Sequence
from .robot_model import START_ERRORS, ArgError, Prepared, own_arguments, prepare
from ..transport import program

__all__ = ["JointStatePublisher"]

log = logging.getLogger("zentf.joint_state_publisher")


class JointStatePublisher:
    """Holds one value per actuated joint and publishes them (plus mimics) as a JointState."""

    def __init__(self, node: Node, robot: Robot, *, rate: float = 10.0, topic: str = "joint_states",
                 initial: Mapping[str, float] | None = None, sweep_period: float | None = None) -> None:
        problem = rate_problem("rate", rate) or (rate_problem("sweep_period", sweep_period, period=True)
                                                 if sweep_period is not None else None)
        if problem is not None:
            raise ValueError(problem)
        self.node = node
        self.robot = robot
        self.kin = Kinematics(robot)
        self.joints = robot.actuated_joints()                   # the ones with a value (and a slider)
        self.published_names = [j.name for j in robot.movable_joints()]  # + mimics, document order
        self.bounds = {j.name: j.bounds() for j in self.joints}
        self._values = {j.name: j.center() for j in self.joints}
        self._lock = threading.Lock()
        self.sweep_period = sweep_period
        self._t0 = time.monotonic()
        self.version = 0  # bumps on every change (the web page polls it)
        if initial:
            self.set_values(initial, publish=False)
        self._pub = node.create_publisher(topic, JointState)
        self._timer = node.create_timer(1.0 / rate, self.publish)
        self.publish()

    # ------------------------------------------------------------------ values
    def values(self) -> dict[str, float]:
        with self._lock:
            return dict(self._values)

    def set_values(self, values: Mapping[str, float], *, publish: bool = True) -> dict[str, float]:
        """Set some joints (clamped to their range); KeyError/ValueError name a bad joint or value."""
        clean = {}
        for name, v in values.items():
            if name not in self.bounds:  # (names and values may come from the slider page: shown escaped, cut)
                raise KeyError(f"'{printable(name, 64)}' is not a movable, non-mimic joint of robot "
                               f"'{printable(self.robot.name, 64)}' (joints: {printable(', '.join(self.bounds), 512)})")
            try:  # an int too big for a float (a 400-digit JSON number) is as out of range as inf
                finite = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
            except OverflowError:
                finite = False
            if not finite:
                raise ValueError(f"joint '{printable(name, 64)}': expected a finite number, got "
                                 f"{_brief(v)}")
            lo, hi = self.bounds[name]
            clean[name] = min(max(float(v), lo), hi)
        with self._lock:
            self._values.update(clean)
            self.version += 1
        if publish:
            self.publish()
        return clean

    def center(self) -> None:
        """joint_state_publisher_gui's Center: every joint back to its start value."""
        self.set_values({j.name: j.center() for j in self.joints})

    def randomize(self, rng: random.Random | None = None) -> None:
        """joint_state_publisher_gui's Randomize: every joint uniformly within its range."""
        r = rng or random
        self.set_values({n: r.uniform(lo, hi) for n, (lo, hi) in self.bounds.items()})

    def _sweep(self) -> None:
        t = time.monotonic() - self._t0
        phase = (1.0 - math.cos(2.0 * math.pi * t / float(self.sweep_period))) / 2.0  # 0 -> 1 -> 0
        with self._lock:
            for name, (lo, hi) in self.bounds.items():
                self._values[name] = lo + (hi - lo) * phase
            self.version += 1

    # ------------------------------------------------------------------ publishing
    def message(self) -> JointState:
        if self.sweep_period:
            self._sweep()
        positions = self.kin.joint_positions(self.values())
        return JointState(Header(self.node.get_clock().now()), list(self.published_names),
                          [float(positions[n]) for n in self.published_names], [], [])

    def publish(self) -> None:
        self._pub.publish(self.message())

    def close(self) -> None:
        self._timer.cancel()


def _brief(value: object) -> str:
    """A refused value as one short line (a 400-digit integer is named by its size, not printed)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
        return f"an integer of {value.bit_length()} bits"
    return printable(repr(value), 64)


# ---- the program (zentf run joint_state_publisher)

PROG = "joint_state_publisher"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, allow_abbrev=False,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    own_arguments(p)
    p.add_argument("--set", dest="values", action="append", default=[], metavar="NAME=VALUE",
                   help="start value of a joint (repeat)")
    p.add_argument("--sweep", action="store_true", help="move every joint between its limits")
    p.add_argument("--sweep-period", type=float, default=4.0, metavar="S", help="seconds per sweep (default 4)")
    p.add_argument("--rate", type=float, default=None, metavar="HZ", help="messages per second (default 10)")
    p.add_argument("--gui", action="store_true", help="serve a web page with one slider per joint")
    p.add_argument("--gui-port", type=int, default=0, metavar="PORT", help="its port on 127.0.0.1 (default: any free)")
    p.add_argument("--no-browser", action="store_true", help="print the page's URL without opening a browser")
    p.add_argument("--description-timeout", type=float, default=30.0, metavar="S",
                   help="without a model: how long to wait for the robot_description topic (default 30)")
    return p


def parse_values(items: Sequence[str], prepared: Prepared) -> dict[str, float]:
    """--set NAME=VALUE items -> {joint: value}; ArgError names the bad item."""
    joints = {j.name: j for j in prepared.robot.actuated_joints()}
    out: dict[str, float] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise ArgError(f"--set expects NAME=VALUE, got {item!r}")
        if name not in joints:
            mimic = prepared.robot.joints.get(name)
            why = "a mimic joint (it follows its master)" if mimic is not None and mimic.mimic else "not a movable joint"
            raise ArgError(f"--set {item}: '{name}' is {why} of robot '{prepared.robot.name}'")
        try:
            value = float(text)
        except ValueError:
            raise ArgError(f"--set {item}: '{text}' is not a number") from None
        if not math.isfinite(value):
            raise ArgError(f"--set {item}: the value must be finite")
        lo, hi = joints[name].bounds()
        if not lo - 1e-12 <= value <= hi + 1e-12:
            raise ArgError(f"--set {item}: outside the joint's range [{lo:g}, {hi:g}]")
        out[name] = value
    return out


def check(p: Prepared) -> dict[str, float]:
    """The start-up checks (those of --set need the model: later when it comes from the topic)."""
    a = p.args
    problem = ((rate_problem("--rate", a.rate) if a.rate is not None else None)
               or rate_problem("--sweep-period", a.sweep_period, period=True))
    if problem is not None:
        raise ArgError(problem)
    if not 0 <= a.gui_port <= 65535:
        raise ArgError(f"--gui-port must be 0..65535, got {a.gui_port}")
    if a.sweep and a.gui:
        raise ArgError("--sweep and --gui exclude each other")
    if not (a.description_timeout > 0 and math.isfinite(a.description_timeout)):
        raise ArgError(f"--description-timeout must be a positive number, got {a.description_timeout}")
    return parse_values(a.values, p) if p.robot is not None else {}


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        p = prepare(PROG, _parser(), argv, model_optional=True)
        if p is None:
            return 0
        initial = check(p)
    except START_ERRORS as e:
        program.error_line(PROG, str(e))
        return 2
    return run(p, initial)


def run(p: Prepared, initial: dict[str, float]) -> int:
    return program.run(lambda: _run(p, initial), PROG, p.debug)


def _run(p: Prepared, initial: dict[str, float]) -> None:
    a = p.args
    with program.make_node(p.opts, PROG) as node:
        if p.robot is None:
            p.robot = _model_from_topic(node, p)
            initial = parse_values(a.values, p)
        rate = a.rate if a.rate is not None else program.param_rate(node, "rate", 10.0)
        jsp = JointStatePublisher(node, p.robot, rate=rate, initial=initial,
                                  sweep_period=a.sweep_period if a.sweep else None)
        program.say(f"publishing joint_states of robot '{p.robot.name}': {len(jsp.published_names)} movable joints"
                    f" at {rate:g} Hz" + (" (sweeping)" if a.sweep else ""))
        gui = None
        if a.gui:
            from ..tools.joint_state_gui import JointStateGui

            try:
                gui = JointStateGui(jsp, "127.0.0.1", a.gui_port)
            except OSError as e:
                raise program.OptionsError(f"cannot serve the slider page on port {a.gui_port}: {e.strerror}") from None
            program.say(f"sliders: {gui.url}")
            if not a.no_browser and (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
                import webbrowser

                webbrowser.open(gui.url)
        try:
            node.spin()
        finally:
            if gui is not None:
                gui.close()
            jsp.close()


def _model_from_topic(node, p: Prepared):
    """The URDF latched on robot_description (robot_state_publisher's); URDFError/ArgError end the program."""
    import threading

    from ..core.messages import String
    from ..urdf import parse_urdf

    texts: list[str] = []
    got = threading.Event()
    sub = node.create_subscription("robot_description", String, lambda m: (texts.append(m.data), got.set()),
                                   latched=True)
    program.say(f"waiting for the robot model on {node.resolve_topic_name('robot_description')}")
    deadline = p.args.description_timeout
    while not got.wait(min(0.2, deadline)) and node.ok():
        deadline -= 0.2
        if deadline <= 0:
            raise ArgError(f"no robot model: nothing on {node.resolve_topic_name('robot_description')} within "
                           f"{p.args.description_timeout:g} s (give a URDF file, or start robot_state_publisher)")
    node.destroy_subscription(sub)
    if not texts:
        raise KeyboardInterrupt  # stopped while waiting
    return parse_urdf(texts[0], source="robot_description", package_path=p.package_path)


if __name__ == "__main__":
    program.finish(main())
