"""Clocks: wall time, or sim time fed from ``/clock``; Rate and sleep follow whichever is active."""
from __future__ import annotations

import enum
import logging
import threading
import time as _time
from collections.abc import Callable

from ..core.time import Duration, Time, to_duration

__all__ = ["ClockType", "Clock", "Rate", "sleep", "JumpHandle", "MIN_RATE", "MAX_RATE", "MIN_PERIOD", "MAX_PERIOD",
           "rate_problem", "MAX_TIMER_PERIOD_NS"]

log = logging.getLogger("zentf.transport.clock")

JumpCallback = Callable[[Time, Time], None]

#: The rates (Hz) and periods (s) a program's option or parameter may ask of a timer: a tick per 11.6
#: days to a million a second. Beyond them the period is no number a wait can take (``1e-300`` Hz is
#: 1e300 s) or the timer only spins.
MIN_RATE, MAX_RATE = 1e-6, 1e6
MIN_PERIOD, MAX_PERIOD = 1.0 / MAX_RATE, 1.0 / MIN_RATE
#: Longest period ``Node.create_timer`` takes: what a thread can wait for at once.
MAX_TIMER_PERIOD_NS = int(threading.TIMEOUT_MAX) * 1_000_000_000


def rate_problem(what: str, value: object, *, period: bool = False) -> str | None:
    """Why ``value`` cannot be the rate in Hz (a period in s with ``period``) called ``what``; None if it can."""
    lo, hi, unit = (MIN_PERIOD, MAX_PERIOD, "s") if period else (MIN_RATE, MAX_RATE, "Hz")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
        shown = repr(value) if not isinstance(value, str) else repr(value[:40])
        return f"{what} must be between {lo:g} and {hi:g} {unit}, got {shown}"
    return None


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

    def _set_ros_time_is_active(self, active: bool) -> None:
        """Switch between sim and wall time (``use_sim_time`` set at run time, rclpy's name); the jump
        callbacks run with the times before and after, as tf2_ros clears its buffer on such a change."""
        with self._cond:
            if self._sim == bool(active):
                return
            old = self.now()
            self._sim = bool(active)
            if active:
                self.clock_type = ClockType.ROS_TIME
            new = self.now()
            self._cond.notify_all()
            callbacks = list(self._jump_callbacks)
        for h in callbacks:
            try:
                h.callback(old, new)
            except Exception:
                log.exception("time jump callback failed")

    def add_jump_callback(self, callback: JumpCallback) -> JumpHandle:
        """Call ``callback(old, new)`` whenever sim time goes backwards or sim time is switched on/off."""
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
        """Block until this clock reaches ``until``; False on timeout (wall seconds) or shutdown.

        Follows a switch between wall and sim time made while sleeping (``use_sim_time`` set at run time).
        """
        target = until.nanoseconds if isinstance(until, Time) else int(until)
        deadline = None if timeout is None else _time.monotonic() + timeout
        with self._cond:
            while True:
                if self._sim:
                    if self._sim_ns >= target:
                        return True
                    wait = None
                else:
                    wait = (target - _time.time_ns()) / 1e9
                    if wait <= 0:
                        return True
                if deadline is not None:
                    left = deadline - _time.monotonic()
                    if left <= 0:
                        return False
                    wait = left if wait is None else min(wait, left)
                if self._closed:
                    return False
                self._cond.wait(wait)

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
        problem = rate_problem("Rate frequency", frequency)
        if problem is not None:
            raise ValueError(problem)
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
