"""joint_state_publisher: ``joint_states`` for every movable joint of a URDF model.

Values start at joint_state_publisher's defaults (0, or the middle of the range when 0 is outside
it), may be set per joint, swept between the limits, or moved from the web page of
``zentf.tools.joint_state_gui``. Mimic joints are published too, computed from their master
(``use_mimic_tags``). Each change is published at once; the timer re-publishes at ``rate`` Hz.
"""
from __future__ import annotations

import logging
import math
import random
import threading
import time
from collections.abc import Mapping

from ..core.messages import Header, JointState
from ..node import Node
from ..urdf import Kinematics, Robot

__all__ = ["JointStatePublisher"]

log = logging.getLogger("zentf.joint_state_publisher")


class JointStatePublisher:
    """Holds one value per actuated joint and publishes them (plus mimics) as a JointState."""

    def __init__(self, node: Node, robot: Robot, *, rate: float = 10.0, topic: str = "joint_states",
                 initial: Mapping[str, float] | None = None, sweep_period: float | None = None) -> None:
        if not rate > 0:
            raise ValueError(f"rate must be > 0, got {rate!r}")
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
            if name not in self.bounds:
                raise KeyError(f"'{name}' is not a movable, non-mimic joint of robot '{self.robot.name}' "
                               f"(joints: {', '.join(self.bounds)})")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"joint '{name}': expected a finite number, got {v!r}")
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
