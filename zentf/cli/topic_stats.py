"""The figures of `zentf topic bw` and `zentf topic delay`, printed in ros2 topic bw / delay's shape.

bw: bytes per second over the last N messages (from the oldest one's arrival to now), with the mean, min
and max message size, in B, KB or MB (1000-based, as ROS 2). delay: now minus each message's
``header.stamp`` in the tool's clock (wall, or /clock under sim time), mean, min, max and std dev.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Optional

__all__ = ["BandwidthWindow", "DelayWindow", "header_stamp_ns"]


def _unit(rate: float) -> tuple[float, str]:
    if rate < 1000:
        return 1.0, "B"
    if rate < 1_000_000:
        return 1000.0, "KB"
    return 1_000_000.0, "MB"


class BandwidthWindow:
    """Sizes and arrival times (monotonic seconds) of the last ``window`` messages."""

    def __init__(self, window: int = 100) -> None:
        self.times: deque[float] = deque(maxlen=window)
        self.sizes: deque[int] = deque(maxlen=window)

    def add(self, t: float, size: int) -> None:
        self.times.append(t)
        self.sizes.append(size)

    def report(self, now: float) -> Optional[str]:
        """ros2 topic bw's two lines, or None with fewer than two messages."""
        n = len(self.times)
        if n < 2 or now <= self.times[0]:
            return None
        total = sum(self.sizes)
        rate = total / (now - self.times[0])
        div, unit = _unit(rate)
        fmt = "{:.0f} B" if unit == "B" else "{:.2f} " + unit

        def f(x: float) -> str:
            return fmt.format(x / div)

        return (f"{f(rate)}/s from {n} messages\n"
                f"\tMessage size mean: {f(total / n)} min: {f(min(self.sizes))} max: {f(max(self.sizes))}")


def header_stamp_ns(plain: object) -> Optional[int]:
    """``header.stamp`` of a plain message in nanoseconds; None when it has no header stamp."""
    if not isinstance(plain, dict):
        return None
    header = plain.get("header")
    stamp = header.get("stamp") if isinstance(header, dict) else None
    if not isinstance(stamp, dict):
        return None
    sec, nsec = stamp.get("sec"), stamp.get("nanosec")
    if not isinstance(sec, int) or not isinstance(nsec, int):
        return None
    return sec * 1_000_000_000 + nsec


class DelayWindow:
    """The last ``window`` delays (ns), and whether new ones came since the last report."""

    def __init__(self, window: int = 10000) -> None:
        self.delays: deque[int] = deque(maxlen=window)
        self._fresh = False

    def add(self, delay_ns: int) -> None:
        self.delays.append(delay_ns)
        self._fresh = True

    def clear(self) -> None:
        self.delays.clear()
        self._fresh = False

    def report(self) -> Optional[str]:
        """ros2 topic delay's two lines; 'no new messages' when none came since the last one; None before
        the first delay."""
        if not self.delays:
            return None
        if not self._fresh:
            return "no new messages"
        self._fresh = False
        n = len(self.delays)
        mean = sum(self.delays) / n
        std = math.sqrt(sum((d - mean) ** 2 for d in self.delays) / n)
        return (f"average delay: {mean * 1e-9:.3f}\n"
                f"\tmin: {min(self.delays) * 1e-9:.3f}s max: {max(self.delays) * 1e-9:.3f}s "
                f"std dev: {std * 1e-9:.5f}s window: {n}")
