"""joint_state_publisher: joint_states for every movable joint of a URDF (and its slider web page).

    python -m nodes.joint_state_publisher configs/robots/my_robot.urdf              # start values
    python -m nodes.joint_state_publisher robot.urdf --set head_swivel=0.8 --set gripper_extension=-0.2
    python -m nodes.joint_state_publisher robot.urdf --sweep                        # each joint between its limits
    python -m nodes.joint_state_publisher robot.urdf --gui                          # sliders in the browser

Start values are joint_state_publisher's: 0, or the middle of the range when 0 is outside it.
Parameters: ``rate`` (Hz, default 10), ``robot_description`` (URDF text when no file is given).
With neither a file nor the parameter, the model is read from the latched ``robot_description``
topic that robot_state_publisher publishes (as ROS 2's joint_state_publisher does).
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Sequence

from nodes import _common
from nodes._robot_model import START_ERRORS, ArgError, Prepared, own_arguments, prepare

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
    if a.rate is not None and not (a.rate > 0 and math.isfinite(a.rate)):
        raise ArgError(f"--rate must be a positive number, got {a.rate}")
    if not (a.sweep_period > 0 and math.isfinite(a.sweep_period)):
        raise ArgError(f"--sweep-period must be a positive number, got {a.sweep_period}")
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
        print(f"{PROG}: error: {e}", file=sys.stderr, flush=True)
        return 2
    return run(p, initial)


def run(p: Prepared, initial: dict[str, float]) -> int:
    return _common.run(lambda: _run(p, initial), PROG, p.debug)


def _run(p: Prepared, initial: dict[str, float]) -> None:
    from zentf.tools.joint_state_publisher import JointStatePublisher

    a = p.args
    with _common.make_node(p.opts, PROG) as node:
        if p.robot is None:
            p.robot = _model_from_topic(node, p)
            initial = parse_values(a.values, p)
        rate = a.rate if a.rate is not None else _common.param_positive(node, "rate", 10.0)
        jsp = JointStatePublisher(node, p.robot, rate=rate, initial=initial,
                                  sweep_period=a.sweep_period if a.sweep else None)
        _common.say(f"publishing joint_states of robot '{p.robot.name}': {len(jsp.published_names)} movable joints"
                    f" at {rate:g} Hz" + (" (sweeping)" if a.sweep else ""))
        gui = None
        if a.gui:
            from zentf.tools.joint_state_gui import JointStateGui

            try:
                gui = JointStateGui(jsp, "127.0.0.1", a.gui_port)
            except OSError as e:
                raise _common.OptionsError(f"cannot serve the slider page on port {a.gui_port}: {e.strerror}") from None
            _common.say(f"sliders: {gui.url}")
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

    from zentf.core.messages import String
    from zentf.urdf import parse_urdf

    texts: list[str] = []
    got = threading.Event()
    sub = node.create_subscription("robot_description", String, lambda m: (texts.append(m.data), got.set()),
                                   latched=True)
    _common.say(f"waiting for the robot model on {node.resolve_topic_name('robot_description')}")
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
    _common.finish(main())
