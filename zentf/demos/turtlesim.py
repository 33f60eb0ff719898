"""Headless turtlesim: turtles driven by `<turtle>/cmd_vel`, poses on `<turtle>/pose`, ROS's services.

Kinematics follow ROS turtlesim: an 11.09 m square world (500 px at 45 px/m), turtle1 born at its
centre facing +x, a velocity command lasts 1 s, theta stays in (-pi, pi], a turtle that hits a wall
is clamped to it. Services, as in ROS: `spawn` (`turtlesim/srv/Spawn`: x, y, theta, name -> name;
an empty name picks `turtleN`; an existing name is an error), `kill` (`turtlesim/srv/Kill`) and
`<turtle>/teleport_absolute` (`turtlesim/srv/TeleportAbsolute`).

Parameters: `rate` (Hz, default 62.5), `spawn_first` (default true: create turtle1 at start).
Prints `spawned <name> at (x, y, theta)` for every new turtle, `killed <name>` when one goes.
"""
from __future__ import annotations

import logging
import math
import re
import threading
from dataclasses import dataclass
from typing import Callable, Sequence

from ..transport import program
from ..core.messages import SpawnResponse, TurtlePose, Twist
from ..core.services import Kill, Spawn, TeleportAbsolute
from ..transport.options import NodeOptions

log = logging.getLogger("turtlesim")

PROG = "turtlesim"
WORLD_SIZE = (500 - 1) / 45.0  # metres: turtlesim's 500 px canvas at 45 px per metre, (width - 1) / meter
CENTRE = WORLD_SIZE / 2.0  # 5.5444...
COMMAND_TIMEOUT = 1.0      # seconds a cmd_vel stays in force
MAX_STEP = 0.016           # integration step (turtlesim's update interval)
_NAME_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def normalize_angle(a: float) -> float:
    """Wrap into (-pi, pi] like turtlesim's normalizeAngle."""
    a = math.fmod(a + math.pi, 2.0 * math.pi)
    if a <= 0.0:
        a += 2.0 * math.pi
    return a - math.pi


@dataclass
class Turtle:
    """One turtle's state: pose plus the command in force and when it arrived."""

    name: str
    x: float
    y: float
    theta: float
    lin_x: float = 0.0
    lin_y: float = 0.0
    ang_z: float = 0.0
    last_command: float = -math.inf

    def command(self, lin_x: float, lin_y: float, ang_z: float, now: float) -> None:
        self.lin_x, self.lin_y, self.ang_z, self.last_command = lin_x, lin_y, ang_z, now

    def step(self, now: float, dt: float) -> bool:
        """Integrate dt seconds in steps of at most MAX_STEP (a late timer keeps the path); True on a wall."""
        if now - self.last_command > COMMAND_TIMEOUT:
            self.lin_x = self.lin_y = self.ang_z = 0.0
        n = max(1, math.ceil(dt / MAX_STEP - 1e-9))
        h = dt / n
        hit = False
        for _ in range(n):
            self.theta = normalize_angle(self.theta + self.ang_z * h)
            c, s = math.cos(self.theta), math.sin(self.theta)
            x = self.x + (c * self.lin_x - s * self.lin_y) * h
            y = self.y + (s * self.lin_x + c * self.lin_y) * h
            self.x = min(max(x, 0.0), WORLD_SIZE)
            self.y = min(max(y, 0.0), WORLD_SIZE)
            hit = hit or self.x != x or self.y != y
        return hit

    def velocities(self) -> tuple[float, float]:
        """Linear and angular velocity as turtlesim's Pose reports them."""
        return math.hypot(self.lin_x, self.lin_y), self.ang_z


class World:
    """All turtles; thread-safe, since commands arrive on transport threads."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.turtles: dict[str, Turtle] = {}

    def spawn(self, name: str, x: float, y: float, theta: float) -> Turtle:
        """Create a turtle; ValueError names what is wrong with the request."""
        with self._lock:
            if not name:
                n = 1
                while f"turtle{n}" in self.turtles:
                    n += 1
                name = f"turtle{n}"
            if not _NAME_RE.fullmatch(name):
                raise ValueError(f"invalid turtle name {name!r} (letters, digits and _, letter first)")
            if name in self.turtles:
                raise ValueError(f"a turtle named {name!r} already exists")
            for what, v in (("x", x), ("y", y), ("theta", theta)):
                if not math.isfinite(v):
                    raise ValueError(f"spawn {what} must be finite, got {v!r}")
            t = Turtle(name, min(max(x, 0.0), WORLD_SIZE), min(max(y, 0.0), WORLD_SIZE),
                       normalize_angle(theta))
            self.turtles[name] = t
            return t

    def kill(self, name: str) -> None:
        """Remove a turtle; ValueError (turtlesim's words) if there is none of that name."""
        with self._lock:
            if self.turtles.pop(name, None) is None:
                raise ValueError(f"Tried to kill turtle [{name}], which does not exist")

    def teleport(self, name: str, x: float, y: float, theta: float) -> None:
        """Put a turtle at (x, y, theta) (clamped to the world), keeping its command."""
        if not all(map(math.isfinite, (x, y, theta))):
            raise ValueError("teleport_absolute needs finite x, y and theta")
        with self._lock:
            t = self.turtles.get(name)
            if t is None:
                raise ValueError(f"no turtle named {name!r}")
            t.x, t.y = min(max(x, 0.0), WORLD_SIZE), min(max(y, 0.0), WORLD_SIZE)
            t.theta = normalize_angle(theta)

    def command(self, name: str, lin_x: float, lin_y: float, ang_z: float, now: float) -> None:
        if not all(map(math.isfinite, (lin_x, lin_y, ang_z))):
            raise ValueError(f"cmd_vel for {name} has a non-finite value")
        with self._lock:
            t = self.turtles.get(name)
            if t is not None:
                t.command(lin_x, lin_y, ang_z, now)

    def step(self, now: float, dt: float) -> list[tuple[str, float, float, float, float, float, bool]]:
        """Advance every turtle; returns (name, x, y, theta, v, w, hit_wall) for each."""
        out = []
        with self._lock:
            for t in self.turtles.values():
                hit = t.step(now, dt)
                v, w = t.velocities()
                out.append((t.name, t.x, t.y, t.theta, v, w, hit))
        return out


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    world = World()
    with program.make_node(opts, PROG) as node:
        clock = node.get_clock()
        rate = program.param_rate(node, "rate", 62.5)
        pose_pubs: dict[str, object] = {}
        per_turtle: dict[str, list] = {}  # name -> its subscription and service, destroyed on kill
        walls: set[str] = set()
        lock = threading.Lock()

        def now_s() -> float:
            return clock.now().nanoseconds / 1e9

        def on_cmd(name: str) -> Callable[[Twist], None]:
            def cb(msg: Twist) -> None:
                try:
                    world.command(name, msg.linear.x, msg.linear.y, msg.angular.z, now_s())
                except ValueError as e:
                    log.warning("ignoring %s", e)
            return cb

        def on_teleport(name: str) -> Callable[[TeleportAbsolute.Request], TeleportAbsolute.Response]:
            def cb(req: TeleportAbsolute.Request) -> TeleportAbsolute.Response:
                world.teleport(name, req.x, req.y, req.theta)
                return TeleportAbsolute.Response()
            return cb

        def add(name: str, x: float, y: float, theta: float) -> str:
            with lock:
                t = world.spawn(name, x, y, theta)
                pose_pubs[t.name] = node.create_publisher(f"{t.name}/pose", TurtlePose)
                per_turtle[t.name] = [node.create_subscription(f"{t.name}/cmd_vel", Twist, on_cmd(t.name)),
                                      node.create_service(f"{t.name}/teleport_absolute", TeleportAbsolute,
                                                          on_teleport(t.name))]
            program.say(f"spawned {t.name} at ({t.x:.3f}, {t.y:.3f}, {t.theta:.3f})")
            return t.name

        def on_spawn(req: Spawn.Request) -> SpawnResponse:
            # a bad or duplicate request raises: the caller gets the reason (turtlesim's ROS_ERROR)
            return SpawnResponse(name=add(req.name, req.x, req.y, req.theta))

        def on_kill(req: Kill.Request) -> Kill.Response:
            with lock:
                world.kill(req.name)
                pub = pose_pubs.pop(req.name, None)
                if pub is not None:
                    pub.destroy()
                for obj in per_turtle.pop(req.name, []):
                    obj.destroy()
            program.say(f"killed {req.name}")
            return Kill.Response()

        node.create_service("spawn", Spawn, on_spawn)
        node.create_service("kill", Kill, on_kill)
        if program.param_bool(node, "spawn_first", True):
            add("turtle1", CENTRE, CENTRE, 0.0)

        last = [now_s()]

        def tick() -> None:
            now = now_s()
            dt = min(max(now - last[0], 0.0), 0.5)
            last[0] = now
            for name, x, y, theta, v, w, hit in world.step(now, dt):
                if hit and name not in walls:
                    log.warning("Oh no! %s hit the wall! (clamped to x=%.3f, y=%.3f)", name, x, y)
                if hit:
                    walls.add(name)
                else:
                    walls.discard(name)
                pub = pose_pubs.get(name)
                if pub is not None:
                    pub.publish(TurtlePose(x=x, y=y, theta=theta, linear_velocity=v, angular_velocity=w))

        node.create_timer(1.0 / rate, tick)
        node.spin()


if __name__ == "__main__":
    program.finish(main())
