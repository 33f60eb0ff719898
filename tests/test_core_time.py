"""Float seconds -> Time/Duration as ROS does it (whole seconds, then the rounded fraction).

The reference is roscpp's ``TimeBase::fromSec`` / ``DurationBase::fromSec`` (ros/roscpp_core
rostime) and ROS 2 tf2's ``durationFromSec`` (tf2/src/time.cpp): ``sec = floor(s)``,
``nsec = round((s - sec) * 1e9)`` with halves away from zero. Expected values here are computed
with exact rational arithmetic (fractions), not with the code under test.
"""
from __future__ import annotations

import math
import random
from fractions import Fraction

import numpy as np
import pytest

from zentf.core.buffer_core import BufferCore
from zentf.core.time import Duration, Time, ns_from_sec, ns_from_sec_array

NOW = 1_700_000_000  # a present-day stamp, where doubles are 2**-22 s (~238 ns) apart


def exact_ns(s: float) -> Fraction:
    """The float's exact value in nanoseconds (no rounding at all)."""
    return Fraction(s) * 1_000_000_000


def stamps(n: int, seed: int = 16) -> list[float]:
    rng = random.Random(seed)
    return [NOW + rng.random() * 1e7 for _ in range(n)]


def test_present_day_stamps_land_on_the_nearest_nanosecond() -> None:
    worst_naive = 0.0
    for s in stamps(20_000):
        exact = exact_ns(s)
        ns = Time.from_sec(s).nanoseconds
        assert abs(ns - exact) <= Fraction(1, 2), (s, ns, float(exact))
        worst_naive = max(worst_naive, abs(float(round(s * 1e9) - exact)))
    # the test can fail: the old round(s * 1e9) misses by tens of nanoseconds at these stamps
    assert worst_naive > 50


def test_round_trip_through_float_seconds_within_200_ns() -> None:
    """ROS 2's requirement: Time -> seconds -> Time comes back within 200 ns at present-day stamps."""
    rng = random.Random(7)
    for _ in range(20_000):
        ns = NOW * 1_000_000_000 + rng.randrange(10**16)
        back = Time.from_sec(Time(nanoseconds=ns).to_sec()).nanoseconds
        assert abs(back - ns) <= 120, (ns, back)  # half the spacing of doubles near 1.7e9 s
        d = -ns
        back_d = Duration.from_sec(Duration(nanoseconds=d).to_sec()).nanoseconds
        assert abs(back_d - d) <= 120, (d, back_d)


def test_whole_seconds_then_fraction_with_halves_away_from_zero() -> None:
    # 2**-10 s is exactly 976562.5 ns: boost::math::round / std::round give 976563 (Python's round: 976562)
    assert Time.from_sec(2.0 ** -10).nanoseconds == 976_563
    assert Duration.from_sec(2.0 ** -10).nanoseconds == 976_563
    assert Time.from_sec(NOW + 0.5).to_dict() == {"sec": NOW, "nanosec": 500_000_000}
    assert Time.from_sec(5.25) == Time(5, 250_000_000)
    assert Time.from_sec(3) == Time(3) and Duration.from_sec(-3) == Duration(-3)


def test_negative_durations_floor_the_seconds() -> None:
    d = Duration.from_sec(-0.25)
    assert (d.sec, d.nanosec, d.nanoseconds) == (-1, 750_000_000, -250_000_000)
    # ROS: floor(-2**-10) = -1 s, fraction 0.9990234375 s = 999023437.5 ns -> 999023438 -> -976562 ns
    assert Duration.from_sec(-(2.0 ** -10)).nanoseconds == -976_562
    for s in stamps(5000, seed=3):
        neg = -s
        ns = Duration.from_sec(neg).nanoseconds
        assert abs(ns - exact_ns(neg)) <= Fraction(1, 2)
        assert Duration.from_sec(neg).to_sec() == pytest.approx(neg, abs=1e-6)
    with pytest.raises(ValueError):
        Time.from_sec(-0.25)
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError, match="finite"):
            Duration.from_sec(bad)
    with pytest.raises(TypeError):
        Duration.from_sec("1.0")  # type: ignore[arg-type]


def test_every_float_entry_point_uses_the_same_conversion() -> None:
    """BufferCore's float-seconds times and the numpy batches agree with Time.from_sec."""
    xs = stamps(2000, seed=11) + [2.0 ** -10, 0.5, 1e-9, 12.000000001]
    arr = ns_from_sec_array(np.array(xs))
    assert arr.dtype == np.int64
    assert [int(v) for v in arr] == [Time.from_sec(s).nanoseconds for s in xs] == [ns_from_sec(s) for s in xs]
    assert ns_from_sec(np.float64(xs[0])) == ns_from_sec(xs[0])

    core = BufferCore()
    s = xs[0]
    core.set_transform_raw("map", "base", Time.from_sec(s).nanoseconds, 0, 0, 0, 0, 0, 0, 1, "test", False)
    # a lookup at float seconds hits the stored stamp exactly (no extrapolation by a few hundred ns)
    assert core.lookup_transform("map", "base", s).header.stamp == Time.from_sec(s)
    assert core.can_transform("map", "base", s)


def test_the_compiled_stamp_types_behave_as_plain_value_objects() -> None:
    """Time and Duration are extension types (zentf/core/time.pyx): what a Python class gave, they keep."""
    import copy
    import importlib.machinery
    import pickle

    from zentf.core import time as time_module

    assert time_module.__file__.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES)), time_module.__file__
    t, d = Time(3, 5), Duration(nanoseconds=-7)
    for v in (t, d, Time(), Duration(sec=2**70)):  # beyond int64 too: the types hold any int
        for back in (pickle.loads(pickle.dumps(v)), copy.copy(v), copy.deepcopy(v)):
            assert type(back) is type(v) and back == v and back.nanoseconds == v.nanoseconds
    assert 2 * d == d * 2 == Duration(nanoseconds=-14) and -d == abs(d) == Duration(nanoseconds=7)
    assert t + d == d + t == Time(nanoseconds=3_000_000_005 - 7) and t - Time(3) == Duration(nanoseconds=5)
    assert Time(1) != Duration(1) and not Time(1) != Time(1) and Time(1) <= Time(1) < Time(2)
    assert hash(Time(1)) != hash(Duration(1)) and {Time(1): 0}[Time(1)] == 0
    assert Time(sec=1.0) == Time(1) and Time(nanoseconds=2.0) == Time(nanoseconds=2)  # ints as before
    with pytest.raises(TypeError):
        t + Time(1)
    with pytest.raises(TypeError):
        t < d
    with pytest.raises(AttributeError):
        t.sec_ = 1  # no instance dict: a typo is an error, as with the slotted class

    class Stamp(Time):
        """Users may subclass, as they could the Python class."""

    s = Stamp(4)
    assert isinstance(s, Time) and s.nanoseconds == 4 * 10**9 and repr(s) == "Stamp(sec=4, nanosec=0)"
