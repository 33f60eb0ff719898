# cython: annotation_typing=False
"""ROS-style Time and Duration held as integer nanoseconds, so stamps never lose precision.

Compiled (extension types, zentf/core/time.pxd): building a stamp is on every send and lookup path,
and a Python ``__init__`` costs ~1.9 us cold against ~0.4 us here (docs/architecture.md). The hint
annotations stay hints (``annotation_typing=False``): ``Time(sec=1.0)`` is accepted as before."""
from __future__ import annotations

import math
from typing import Any, Union

NSEC_PER_SEC = 1_000_000_000

__all__ = ["Time", "Duration", "NSEC_PER_SEC", "to_time", "to_duration", "fmt_stamp", "ns_from_sec",
           "ns_from_sec_array"]


def ns_from_sec(seconds: float, what: str = "time") -> int:
    """Float seconds -> integer ns as ROS does it: whole seconds first, then the rounded fraction.

    ``sec = floor(s); nsec = round_half_away((s - sec) * 1e9)`` is roscpp's ``fromSec``
    (ros/roscpp_core rostime) and ROS 2 tf2's ``durationFromSec`` (tf2/src/time.cpp), so a
    present-day stamp (1.7e9 s) lands on the nanosecond nearest its double; ``round(s * 1e9)``
    would round the product at 1.7e18, whose doubles are 256 ns apart. ``s - floor(s)`` is exact
    in binary floating point, so only the fraction's scaling is rounded. (rospy and rclpy truncate
    ``s * 1e9`` instead; zentf follows the C++ client libraries and tf2 of both ROS versions.)
    Negative spans work the same way: -0.25 s is -1 s + 750000000 ns. Integers are exact.
    """
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)):
        if hasattr(seconds, "item"):  # numpy scalars
            return ns_from_sec(seconds.item(), what)
        raise TypeError(f"{what} must be a number of seconds, got {type(seconds).__name__}")
    if isinstance(seconds, int):
        return seconds * NSEC_PER_SEC
    if not math.isfinite(seconds):
        raise ValueError(f"{what} must be finite, got {seconds!r}")
    sec = math.floor(seconds)
    x = (seconds - sec) * 1e9  # in [0, 1e9]
    nsec = math.floor(x)
    if x - nsec >= 0.5:  # half away from zero (x >= 0), as boost::math::round / std::round
        nsec += 1
    return sec * NSEC_PER_SEC + nsec


def ns_from_sec_array(seconds: "Any") -> "Any":
    """ns_from_sec over a float numpy array (same arithmetic, element by element) -> int64 array."""
    import numpy as np  # only batch callers pay for numpy

    a = np.asarray(seconds, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError("times must be finite")
    sec = np.floor(a)
    x = (a - sec) * 1e9
    nsec = np.floor(x)
    nsec += (x - nsec) >= 0.5
    return sec.astype(np.int64) * NSEC_PER_SEC + nsec.astype(np.int64)


cdef class _Nanoseconds:
    """Shared accessors and ordering of Time and Duration (same-type comparisons only); ``_ns`` is the
    integer nanoseconds (a Python int: no range limit here, the buffer checks its own)."""

    @property
    def nanoseconds(self) -> int:
        return self._ns

    @property
    def sec(self) -> int:
        return self._ns // NSEC_PER_SEC

    @property
    def nanosec(self) -> int:
        return self._ns % NSEC_PER_SEC

    def to_sec(self) -> float:
        return self._ns / NSEC_PER_SEC

    def to_nsec(self) -> int:
        return self._ns

    def is_zero(self) -> bool:
        return self._ns == 0

    def to_dict(self) -> dict:
        return {"sec": self.sec, "nanosec": self.nanosec}

    def __eq__(self, other: object) -> bool:
        return type(other) is type(self) and self._ns == other._ns  # type: ignore[attr-defined]

    def __lt__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._ns < other._ns  # type: ignore[attr-defined]

    def __le__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._ns <= other._ns  # type: ignore[attr-defined]

    def __gt__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._ns > other._ns  # type: ignore[attr-defined]

    def __ge__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._ns >= other._ns  # type: ignore[attr-defined]

    def __hash__(self) -> int:
        return hash((type(self).__name__, self._ns))

    def __repr__(self) -> str:
        return f"{type(self).__name__}(sec={self.sec}, nanosec={self.nanosec})"


cdef class Duration(_Nanoseconds):
    """A signed span of time in integer nanoseconds (builtin_interfaces/Duration)."""

    def __init__(self, sec: int = 0, nanosec: int = 0, *, nanoseconds: int | None = None) -> None:
        self._ns = int(nanoseconds) if nanoseconds is not None else int(sec) * NSEC_PER_SEC + int(nanosec)

    @classmethod
    def from_sec(cls, seconds: float) -> "Duration":
        return cls(nanoseconds=ns_from_sec(seconds, "Duration"))

    @classmethod
    def from_nsec(cls, nanoseconds: int) -> "Duration":
        return cls(nanoseconds=nanoseconds)

    def __add__(self, other: object) -> "Duration | Time":
        if isinstance(other, Duration):
            return Duration(nanoseconds=self._ns + other._ns)
        if isinstance(other, Time):
            return Time(nanoseconds=self._ns + other._ns)
        return NotImplemented

    def __sub__(self, other: object) -> "Duration":
        if isinstance(other, Duration):
            return Duration(nanoseconds=self._ns - other._ns)
        return NotImplemented

    def __neg__(self) -> "Duration":
        return Duration(nanoseconds=-self._ns)

    def __abs__(self) -> "Duration":
        return Duration(nanoseconds=abs(self._ns))

    def __mul__(self, k: float) -> "Duration":
        if isinstance(k, (int, float)) and not isinstance(k, bool):
            return Duration(nanoseconds=round(self._ns * k))
        return NotImplemented

    def __rmul__(self, k: float) -> "Duration":
        return self.__mul__(k)

    def __truediv__(self, k: float) -> "Duration":
        if isinstance(k, (int, float)) and not isinstance(k, bool):
            return Duration(nanoseconds=round(self._ns / k))
        return NotImplemented

    def __bool__(self) -> bool:
        return self._ns != 0

    @classmethod
    def from_dict(cls, d: object) -> "Duration":
        sec, nsec = _sec_nanosec(d, "Duration")
        return cls(sec, nsec)


cdef class Time(_Nanoseconds):
    """A point in time in integer nanoseconds (builtin_interfaces/Time); Time() means 'latest'."""

    def __init__(self, sec: int = 0, nanosec: int = 0, *, nanoseconds: int | None = None) -> None:
        ns = int(nanoseconds) if nanoseconds is not None else int(sec) * NSEC_PER_SEC + int(nanosec)
        if ns < 0:
            raise ValueError(f"Time cannot be negative ({ns} ns)")
        self._ns = ns

    @classmethod
    def from_sec(cls, seconds: float) -> "Time":
        return cls(nanoseconds=ns_from_sec(seconds, "Time"))

    @classmethod
    def from_nsec(cls, nanoseconds: int) -> "Time":
        return cls(nanoseconds=nanoseconds)

    def __add__(self, other: object) -> "Time":
        if isinstance(other, Duration):
            return Time(nanoseconds=self._ns + other._ns)
        if isinstance(other, Time):
            raise TypeError("cannot add two Time values (Time + Duration is allowed)")
        return NotImplemented

    def __radd__(self, other: object) -> "Time":
        if isinstance(other, Time):
            raise TypeError("cannot add two Time values (Time + Duration is allowed)")
        return NotImplemented

    def __sub__(self, other: object) -> "Time | Duration":
        if isinstance(other, Time):
            return Duration(nanoseconds=self._ns - other._ns)
        if isinstance(other, Duration):
            return Time(nanoseconds=self._ns - other._ns)
        return NotImplemented

    @classmethod
    def from_dict(cls, d: object) -> "Time":
        sec, nsec = _sec_nanosec(d, "Time")
        if sec < 0:
            raise ValueError(f"Time.sec must not be negative, got {sec}")
        return cls(sec, nsec)


def _sec_nanosec(d: object, what: str) -> tuple[int, int]:
    if not isinstance(d, dict):
        raise ValueError(f"{what} must be a dict with sec and nanosec, got {type(d).__name__}")
    unknown = set(d) - {"sec", "nanosec"}
    if unknown:
        raise ValueError(f"{what} has unknown field(s) {sorted(map(str, unknown))}")
    sec, nsec = d.get("sec", 0), d.get("nanosec", 0)
    for name, v in (("sec", sec), ("nanosec", nsec)):
        if isinstance(v, bool) or not isinstance(v, int):
            raise ValueError(f"{what}.{name} must be an integer, got {v!r}")
    if not 0 <= nsec < NSEC_PER_SEC:
        raise ValueError(f"{what}.nanosec must be in [0, 1e9), got {nsec}")
    return sec, nsec


TimeLike = Union[Time, int, float]


def to_time(t: TimeLike) -> Time:
    """Accept Time or seconds (0 = latest) wherever tf2 takes a time."""
    if isinstance(t, Time):
        return t
    return Time.from_sec(t)


def to_duration(d: Union[Duration, int, float]) -> Duration:
    """Accept Duration or seconds wherever tf2 takes a timeout or a span."""
    if isinstance(d, Duration):
        return d
    return Duration.from_sec(d)


def fmt_stamp(ns: int) -> str:
    """ros::Time / ros::Duration stream format (seconds with 9 decimals), as tf2's messages print times."""
    if ns < 0:
        return "-" + fmt_stamp(-ns)
    return f"{ns // NSEC_PER_SEC}.{ns % NSEC_PER_SEC:09d}"
