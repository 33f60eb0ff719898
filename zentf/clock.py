"""Clocks: wall time, or sim time fed from ``/clock``; Rate and sleep follow whichever is active."""
from __future__ import annotations

import enum
import logging
import threading
import time as _time
from collections.abc import Callable

from .core.time import Duration, Time, to_duration

__all__ = ["ClockType", "Clock", "Rate", "sleep", "JumpHandle"]

log = logging.getLogger("zentf.clock")

JumpCallback = Callable[[Time, Time], None]


class ClockType(enum.Enum):
    SYSTEM_TIME = "system"
    ROS_TIME = "ros"  # sim time from /clock when active


class JumpHandle:
    """Returned by add_jump_callback; pass to remove_jump_callback."""

    __slots__ = ("callback",)

    def __init__(self, callback: JumpCallback) -> None:
        self.callback = callback


class Clock:
    """Time source: wall clock, or (ROS_TIME + sim active) the last ``/clock`` value; 0 until the first."""

    def __init__(self, clock_type: ClockType = ClockType.SYSTEM_TIME, *, sim: bool = False) -> None:
        self.clock_type = clock_type
        self._sim = bool(sim)
        self._sim_ns = 0
        self._cond = threading.Condition()
        self._jump_callbacks: list[JumpHandle] = []
        self._closed = False

    @property
    def ros_time_is_active(self) -> bool:
        return self._sim

    is_sim = ros_time_is_active

    def now(self) -> Time:
        if self._sim:
            return Time(nanoseconds=self._sim_ns)
        return Time(nanoseconds=_time.time_ns())

    def now_ns(self) -> int:
        return self._sim_ns if self._sim else _time.time_ns()

    def set_sim_time(self, t: Time | int) -> None:
        """Feed a /clock value (Time or ns); a backwards step runs the jump callbacks (old, new)."""
        ns = t.nanoseconds if isinstance(t, Time) else int(t)
        with self._cond:
            old = self._sim_ns
            self._sim_ns = ns
            self._cond.notify_all()
            callbacks = list(self._jump_callbacks) if ns < old else []
        for h in callbacks:
            try:
                h.callback(Time(nanoseconds=old), Time(nanoseconds=ns))
            except Exception:
                log.exception("time jump callback failed")

    def add_jump_callback(self, callback: JumpCallback) -> JumpHandle:
        """Call ``callback(old, new)`` whenever sim time goes backwards."""
        h = JumpHandle(callback)
        with self._cond:
            self._jump_callbacks.append(h)
        return h

    def remove_jump_callback(self, handle: JumpHandle) -> None:
        with self._cond:
            if handle in self._jump_callbacks:
                self._jump_callbacks.remove(handle)

    def wake(self) -> None:
        """Wake every sleeper (used on shutdown)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def sleep_until(self, until: Time | int, timeout: float | None = None) -> bool:
        """Block until this clock reaches ``until``; False on timeout (wall seconds) or shutdown."""
        target = until.nanoseconds if isinstance(until, Time) else int(until)
        deadline = None if timeout is None else _time.monotonic() + timeout
        if not self._sim:
            while True:
                remaining = (target - _time.time_ns()) / 1e9
                if remaining <= 0:
                    return True
                if deadline is not None:
                    left = deadline - _time.monotonic()
                    if left <= 0:
                        return False
                    remaining = min(remaining, left)
                with self._cond:
                    if self._closed:
                        return False
                    self._cond.wait(remaining)
        with self._cond:
            while self._sim_ns < target:
                if self._closed:
                    return False
                left = None if deadline is None else deadline - _time.monotonic()
                if left is not None and left <= 0:
                    return False
                self._cond.wait(left)
            return True

    def sleep_for(self, duration: Duration | float, timeout: float | None = None) -> bool:
        return self.sleep_until(self.now_ns() + to_duration(duration).nanoseconds, timeout)

    def wait_for_change(self, timeout: float | None = None) -> bool:
        """Sim time: block until the next /clock update; wall time: sleep ``timeout``."""
        with self._cond:
            before = self._sim_ns
            return self._cond.wait_for(lambda: self._sim_ns != before or self._closed, timeout)

    def __repr__(self) -> str:
        return f"Clock({'sim' if self._sim else 'wall'}, now={self.now()})"


_WALL = Clock()


class Rate:
    """Loop at a fixed frequency on a clock without drift (``while ...: work(); rate.sleep()``)."""

    def __init__(self, frequency: float, clock: Clock | None = None) -> None:
        if not frequency > 0:
            raise ValueError(f"Rate frequency must be > 0, got {frequency!r}")
        self._clock = clock or _WALL
        self._period = round(1e9 / frequency)
        self._next = self._clock.now_ns() + self._period

    @property
    def period(self) -> Duration:
        return Duration(nanoseconds=self._period)

    def sleep(self) -> bool:
        now = self._clock.now_ns()
        if now > self._next + self._period or now < self._next - 2 * self._period:
            self._next = now + self._period  # fell behind, or time jumped back: restart the grid
        ok = self._clock.sleep_until(self._next)
        self._next += self._period
        return ok


def sleep(seconds: Duration | float, clock: Clock | None = None) -> bool:
    """Sleep on a clock (sim-aware); plain wall sleep without one."""
    return (clock or _WALL).sleep_for(seconds)
