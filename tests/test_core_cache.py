"""The compiled per-frame caches (zentf/core/cache.pyx) against a plain model of tf2's TimeCache.

The ring storage (wrap-around, out-of-order inserts into a wrapped ring, growth, the slack given
back once pruning starts, a parent switch that gives the frame a per-sample parent column) is new
in the compiled core: these tests drive it through random operation sequences and compare every
answer with a sorted-list model written from tf2's cache.cpp (findClosest + interpolate, the
textbook slerp form), and check the compiled modules are the ones imported.
"""
from __future__ import annotations

import bisect
import importlib.machinery
import math
import random
import struct
import threading

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from zentf.core import buffer_core, cache, time
from zentf.core.cache import StaticCache, TimeCache
from zentf.core.constants import INSERT_OK, INSERT_OLD, INSERT_REPEATED


def test_the_core_is_the_compiled_extension() -> None:
    """A stale .py beside the extension, or a missing build, must not go unnoticed."""
    for mod in (cache, buffer_core, time):
        assert mod.__file__.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES)), mod.__file__


class Model:
    """tf2 0.7 TimeCache semantics on a sorted list (ROS 1 order: prune right after an insert)."""

    def __init__(self, max_ns: int) -> None:
        self.max_ns = max_ns
        self.s: list[tuple[int, int, tuple]] = []

    def insert(self, stamp: int, parent: int, v: tuple) -> int:
        stamps = [x[0] for x in self.s]
        if self.s and self.s[-1][0] - stamp > self.max_ns:
            return INSERT_OLD
        i = bisect.bisect_left(stamps, stamp)
        if i < len(stamps) and stamps[i] == stamp:
            return INSERT_REPEATED
        self.s.insert(i, (stamp, parent, v))
        stamps.insert(i, stamp)
        del self.s[:bisect.bisect_left(stamps, self.s[-1][0] - self.max_ns)]
        return INSERT_OK

    def get(self, t: int):
        s = self.s
        if not s:
            return None
        if t == 0 or t == s[-1][0]:
            return (s[-1][1], *s[-1][2])
        if len(s) == 1 or t > s[-1][0] or t < s[0][0]:
            return None
        if t == s[0][0]:
            return (s[0][1], *s[0][2])
        i = bisect.bisect_right([x[0] for x in s], t) - 1
        (t0, p0, a), (t1, p1, b) = s[i], s[i + 1]
        if p0 != p1:
            return (p0, *a)
        r = (t - t0) / (t1 - t0)
        tr = tuple(a[k] + r * (b[k] - a[k]) for k in range(3))
        qa, qb = a[3:], b[3:]
        dot = sum(x * y for x, y in zip(qa, qb))
        theta = math.acos(min(1.0, abs(dot) / math.sqrt(sum(x * x for x in qa) * sum(x * x for x in qb))))
        if theta == 0.0:
            return (p0, *tr, *qa)
        sign = -1.0 if dot < 0 else 1.0
        w0 = math.sin((1 - r) * theta) / math.sin(theta)
        w1 = sign * math.sin(r * theta) / math.sin(theta)
        return (p0, *tr, *(w0 * x + w1 * y for x, y in zip(qa, qb)))

    def parent_at(self, t: int) -> int:
        got = self.get(t)
        return 0 if got is None else got[0]


def _quat(seed: int) -> tuple:
    a = 0.37 * seed
    n = math.sqrt(0.2 ** 2 + 0.3 ** 2 + 0.933 ** 2)
    s = math.sin(a / 2) / n
    return (0.2 * s, 0.3 * s, 0.933 * s, math.cos(a / 2))


ops = st.lists(st.one_of(
    st.tuples(st.just("ins"), st.integers(1, 60), st.integers(1, 3), st.integers(0, 50)),
    st.tuples(st.just("get"), st.integers(0, 70)),
    st.tuples(st.just("clear"))), min_size=1, max_size=120)


# (origin, unit) of the stamps. A stamp is stored as its offset from the frame's first one, the
# low 32 bits per sample and the high bits once per run of samples sharing them: small units (one
# run); units of 2**29 ns (a run holds about 8); units a nanosecond either side of 2**32 (nearly
# every sample starts a run, samples inserted before the first one give negative runs)
SCALES = [(0, 1000), (3 * 2 ** 32 - 20 * 2 ** 29, 2 ** 29), (2 ** 40, 2 ** 32 - 1), (7, 2 ** 32 + 1)]


def _probe_time(origin: int, unit: int, i: int) -> int:
    """A time to ask: a stored stamp's, or a third of a unit past one (between samples)."""
    return origin + i * unit + (unit // 3 if i % 2 else 0)


def _assert_answer(c: TimeCache, m: Model, t: int):
    """The cache's answer at t is the model's (None alike; values within 1e-12); returns it."""
    want, got = m.get(t), c.get(t)
    assert (want is None) == (got is None), (t, want, got)
    if want is not None:
        assert got[0] == want[0]
        assert max(abs(x - y) for x, y in zip(got[1:], want[1:])) < 1e-12, (t, want, got)
    return got


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ops, st.integers(3, 40), st.sampled_from(SCALES))
def test_time_cache_equals_the_model(seq, max_units, scale) -> None:
    origin, unit = scale
    c, m = TimeCache(max_units * unit), Model(max_units * unit)
    for op in seq:
        if op[0] == "ins":
            _, k, parent, seed = op
            v = (0.1 * seed, -0.2 * k, 0.01 * seed * k, *_quat(seed))
            stamp = origin + k * unit
            assert c.insert(stamp, parent, v) == m.insert(stamp, parent, v)
        elif op[0] == "get":
            t = _probe_time(origin, unit, op[1])
            _assert_answer(c, m, t)
            assert c.parent_at(t) == m.parent_at(t)
        else:
            c.clear()
            m.s.clear()
        assert len(c) == len(m.s)
        assert c.newest_stamp() == (m.s[-1][0] if m.s else 0)
        assert c.oldest_stamp() == (m.s[0][0] if m.s else 0)


def test_ring_wraps_grows_and_gives_slack_back() -> None:
    """Steady state (pruning every insert) keeps capacity at the samples held (+1); inserts still land."""
    c = TimeCache(1000)
    for k in range(5000):                     # 1001 samples held once pruning starts
        assert c.insert(k, 1, (k, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)) == INSERT_OK
    assert len(c) == 1001
    assert c.nbytes() <= 64 * (1001 + 1)      # steady state keeps one spare slot: 64 B a sample
    # out-of-order inserts into the wrapped ring land in order
    for k in range(4990, 4000, -3):
        c.insert(k * 1 + 0, 1, (0.0,) * 6 + (1.0,))  # repeated stamps: refused
    assert c.insert(4500, 2, (1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0)) == INSERT_REPEATED
    st_, par, d = c.columns()
    assert list(st_) == list(range(3999, 5000)) and set(par) == {1}
    assert d[0][0] == 3999.0


def test_parent_switch_keeps_each_samples_parent() -> None:
    c = TimeCache(10_000)
    ident = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    for k in range(1, 11):
        c.insert(k * 100, 1 if k <= 5 else 2, ident)
    assert [c.parent_at(k * 100) for k in range(1, 11)] == [1] * 5 + [2] * 5
    assert c.get(550)[0] == 1                 # across the switch: the older sample, as tf2
    assert c.insert(250, 3, ident) == INSERT_OK  # out of order, a third parent
    assert c.parent_at(250) == 3 and c.parent_at(299) == 3 and c.parent_at(300) == 1


def test_static_cache_holds_one_sample_at_every_time() -> None:
    s = StaticCache()
    s.insert(5, 7, (1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0))
    assert s.get(0) == s.get(123456789) == (7, 1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0)
    s.clear()                                  # statics survive clear() in tf2
    assert s.parent_at(1) == 7 and len(s) == 1


def test_buffer_lock_behaves_like_threading_lock() -> None:
    lock = buffer_core.BufferCore()._lock
    assert lock.acquire() and lock.locked()
    assert not lock.acquire(False)
    assert not lock.acquire(True, 0.05)        # times out while held
    got = []
    t = threading.Thread(target=lambda: got.append(lock.acquire(timeout=5)))
    t.start()
    lock.release()                             # the waiting thread gets it
    t.join(10)
    assert got == [True] and lock.locked()
    lock.release()
    with pytest.raises(RuntimeError):
        lock.release()
    with lock:
        assert lock.locked()
    assert not lock.locked()


@pytest.mark.parametrize("max_units", [3, 5, 17])
def test_stream_through_the_wrapped_ring_equals_the_model(max_units) -> None:
    """A stream pruned on every insert wraps the ring over and over: every time in range is asked."""
    c, m = TimeCache(max_units * 1000), Model(max_units * 1000)
    for k in range(1, 120):
        v = ((k * k) % 7 * 1.0, (k * 3) % 5 * 1.0, 0.5, *_quat((k * k) % 11))
        c.insert(k * 1000, 1 + (k // 40) % 2, v)
        m.insert(k * 1000, 1 + (k // 40) % 2, v)
        for t in range((k - max_units - 1) * 1000, k * 1000 + 1, 250):
            want, got = m.get(t), c.get(t)
            assert (want is None) == (got is None), (k, t)
            if want is not None:
                assert got[0] == want[0] and max(abs(x - y) for x, y in zip(got[1:], want[1:])) < 1e-12, (k, t)


def _check_against(c: TimeCache, m: Model, times) -> None:
    """Every stored column and the answer at each of times equal the model's."""
    st_, par, d = c.columns()
    assert list(st_) == [x[0] for x in m.s] and list(par) == [x[1] for x in m.s]
    assert [tuple(row) for row in d] == [x[2] for x in m.s]
    for t in times:
        want, got = m.get(t), c.get(t)
        assert (want is None) == (got is None), t
        if want is not None:
            assert got[0] == want[0] and max(abs(x - y) for x, y in zip(got[1:], want[1:])) < 1e-12, t
        assert c.parent_at(t) == m.parent_at(t), t


@pytest.mark.parametrize("origin, unit", [(0, 1000), (7 * 2 ** 32 - 3000 * 2 ** 20, 2 ** 20)])
def test_a_ring_crossing_the_mapping_threshold_grows_wraps_and_shrinks_like_the_model(origin, unit) -> None:
    """Large rings live in a mapping of their own (mremap growth), small ones in malloc: a stream
    fills past the threshold, runs steady and wrapped, doubles its rate (wrapped growth), takes
    out-of-order samples, then slows down until the ring gives its room back below the threshold.
    The second origin puts the stamps 2**32 ns runs apart every 4096 units all along."""
    rng = random.Random(15)
    max_units = 2000
    c, m = TimeCache(max_units * unit), Model(max_units * unit)
    k = 0.0

    def feed(count: int, step: float, late: float = 0.0) -> None:
        nonlocal k
        for _ in range(count):
            k += step
            stamp = origin + int(k * unit)
            if late and rng.random() < late:  # now and then a sample from the recent past
                stamp -= rng.randrange(1, 50) * unit + rng.randrange(unit)
            v = (rng.random(), k, -k, *_quat(rng.randrange(100)))
            parent = 1 + (int(k) // 700) % 2
            assert c.insert(stamp, parent, v) == m.insert(stamp, parent, v)

    def probe() -> list[int]:
        lo, hi = m.s[0][0], m.s[-1][0]
        return [rng.randint(lo - unit, hi + unit) for _ in range(300)] + [lo, hi, m.s[len(m.s) // 2][0]]

    feed(600, 4.0)                             # steady at 501 samples: below the threshold, malloc'd
    assert not c.mapped and len(c) == 501
    _check_against(c, m, probe())
    feed(6000, 0.5, late=0.05)                 # 8x the rate, out-of-order samples: wrapped growth into
    assert c.mapped and len(c) > 3900          # a mapping, then mremap growth, wrapped
    _check_against(c, m, probe())
    feed(3000, 8.0)                            # one sample every 8 units: the ring shrinks, malloc again
    assert len(c) == 251 and not c.mapped and c.capacity < 300
    _check_against(c, m, probe())
    c.clear()
    m.s.clear()
    assert len(c) == 0 and c.capacity == 0 and not c.mapped and c.get(origin) is None
    feed(100, 1.0)                             # a fast frame: mapped from its first growth on, the room
    assert c.mapped and len(c) == 100 and c.capacity > 1000  # ahead costs untouched pages only
    _check_against(c, m, probe())
    feed(3000, 1.0)                            # steady: trimmed to what it holds, to the page
    assert c.mapped and len(c) == 2001 and c.capacity * 56 <= 2002 * 56 + 4096
    _check_against(c, m, probe())
    c.clear()
    assert len(c) == 0 and c.capacity == 0 and not c.mapped and c.get(origin) is None


def test_runs_of_high_words_fall_out_with_pruning() -> None:
    """Stamps spanning many 2**32 ns runs in a cache longer than one run: exact stamps and answers
    while whole runs are pruned, and a sample inserted into the middle of a run."""
    step = 2 ** 31 + 12345                      # two samples per run, more or less
    c, m = TimeCache(10 * step), Model(10 * step)
    for k in range(1, 200):
        v = (float(k), 0.0, 0.0, *_quat(k))
        assert c.insert(k * step, 1, v) == m.insert(k * step, 1, v)
        if k % 17 == 0:                         # in between two stored samples
            late = (k - 3) * step + step // 2
            assert c.insert(late, 1, v) == m.insert(late, 1, v)
    _check_against(c, m, [m.s[0][0] + i * step // 7 for i in range(80)])
    assert c.capacity <= len(c) + 5 and c.nbytes() <= c.capacity * 60 + 8 * 16  # 4 + 56 B a slot, 16 B a run


# Constant columns: a column that has held one value (bit for bit) since a frame's first sample is
# stored once, not per slot, until a sample brings another value (then every slot gets the column).
# Pools of a few values per column, -0.0 beside 0.0, keep columns constant for a while, then not.
_POOLS = [(0.5, 0.25), (0.0, -0.0), (-1.5, 2.0), (0.0, -0.0, 0.125), (0.0, 0.6), (0.0, -0.0), (1.0, 0.8)]
_TWIN = (1e6, 1e6, 1e6, 0.5, 0.5, 0.5, 0.5)  # differs from every pool value: a cache storing every column


def _bits(values) -> list:
    """Values as their IEEE bit patterns (-0.0 differs from 0.0; == would not tell)."""
    return [struct.pack("<d", float(x)) for x in values]


def _row(col_seeds: tuple) -> tuple:
    return tuple(_POOLS[c][s % len(_POOLS[c])] for c, s in enumerate(col_seeds))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(
    st.tuples(st.just("ins"), st.integers(1, 60), st.integers(1, 2),
              st.lists(st.integers(0, 20), min_size=7, max_size=7).map(tuple)),
    st.tuples(st.just("get"), st.integers(0, 70))), min_size=1, max_size=80),
    st.integers(3, 40), st.sampled_from(SCALES))
def test_constant_columns_are_stored_once_and_answers_stay_bit_identical(seq, max_units, scale) -> None:
    """Against the model (values), and against a twin cache whose extra oldest sample makes every
    column vary from the start: the same stored bits, the same answers to the last bit."""
    origin, unit = scale
    c, m, twin = TimeCache(max_units * unit), Model(max_units * unit), TimeCache(max_units * unit)
    twin.insert(origin, 1, _TWIN)
    for op in seq:
        if op[0] == "ins":
            _, k, parent, seeds = op
            # mostly the first value of each pool: columns stay constant for a while, then change
            v = _row(tuple(s if s < len(_POOLS[i]) else 0 for i, s in enumerate(seeds)))
            stamp = origin + k * unit
            assert c.insert(stamp, parent, v) == m.insert(stamp, parent, v)
            twin.insert(stamp, parent, v)
        else:
            t = _probe_time(origin, unit, op[1])
            got = _assert_answer(c, m, t)
            if got is not None and m.s[0][0] <= t and twin.oldest_stamp() <= m.s[0][0]:  # same samples held
                assert _bits(got[1:]) == _bits(twin.get(t)[1:]), (t, got, twin.get(t))
    st_, par, d = c.columns()
    assert list(st_) == [x[0] for x in m.s] and list(par) == [x[1] for x in m.s]
    assert [_bits(row) for row in d] == [_bits(x[2]) for x in m.s]


def test_a_fixed_translation_costs_nothing_per_sample_until_it_moves() -> None:
    """A joint that only rotates stores 4 values a sample, not 7; the first sample that moves it
    (here by a sign bit: -0.0) widens every stored slot, and each sample keeps its own bits."""
    c = TimeCache(10 ** 12)
    for k in range(1, 301):
        assert c.insert(k * 1000, 1, (0.25, 0.0, 1.5, *_quat(k))) == INSERT_OK
    rotating = c.nbytes()
    assert rotating <= c.capacity * (4 + 4 * 8) + 16 * 4     # low stamp word + 4 values, a few runs
    assert c.insert(301_000, 1, (0.25, -0.0, 1.5, *_quat(301))) == INSERT_OK
    assert c.nbytes() > rotating                             # ty now stored per slot
    _, _, d = c.columns()
    assert _bits(d[:, 1]) == _bits([0.0] * 300 + [-0.0])
    assert _bits(c.get(300_500)[1:4]) == _bits([0.25, 0.0 + 0.5 * (-0.0 - 0.0), 1.5])  # tf2's lerp of them
    assert c.get(150_000)[1:4] == (0.25, 0.0, 1.5) and _bits(c.get(301_000)[2:3]) == _bits([-0.0])


def test_a_wrapped_mapped_ring_widens_in_place_like_the_model() -> None:
    """A large ring (its own mapping), wrapped by pruning and holding out-of-order samples, whose
    constant columns start to vary one by one: every slot keeps its sample."""
    rng = random.Random(7)
    c, m = TimeCache(3000), Model(3000)
    for k in range(1, 12_000):
        stamp = k if rng.random() > 0.02 else k - rng.randrange(1, 40)
        if k < 5000:
            v = (0.0, 2.0, -0.0, *_quat(k))
        elif k < 8000:
            v = (k * 1e-3, 2.0, -0.0, *_quat(k))             # tx varies from here on
        else:
            v = (k * 1e-3, 2.0, -0.0 if k % 3 else 0.0, 0.0, 0.0, math.sin(k), math.cos(k))
        assert c.insert(stamp, 1, v) == m.insert(stamp, 1, v)
        if k in (4999, 5001, 7999, 8001, 11_999):
            _check_against(c, m, [rng.randint(m.s[0][0] - 5, m.s[-1][0] + 5) for _ in range(200)])
            assert [_bits(row) for row in c.columns()[2]] == [_bits(x[2]) for x in m.s]
    assert c.mapped


# One allocation per ring: the values (stride _w doubles), then the stamps' low words. Growing moves
# the low words up after the resize, shrinking moves them down first, a wrapped ring moves one of
# its two parts: a low word left behind would pair a sample with another one's stamp.
@pytest.mark.parametrize("steady", [300, 317, 333, 351])
def test_a_ring_in_one_allocation_keeps_every_stamp_with_its_values(steady) -> None:
    """Growth while filling, steady and wrapped (head at several places), wrapped growth (4x the
    rate, out-of-order samples), a shrink (1/8 the rate), a column that starts to vary in the
    wrapped ring: the stored columns and the answers equal the model's at every stage."""
    rng = random.Random(steady)
    c, m = TimeCache(100_000), Model(100_000)
    k = 0.0

    def feed(count: int, step: float, late: float = 0.0, ty=lambda k: 0.5) -> None:
        nonlocal k
        for _ in range(count):
            k += step
            stamp = int(k * 1000)
            if late and rng.random() < late:
                stamp -= rng.randrange(1, 20_000)
            v = (rng.random(), ty(k), -k, *_quat(rng.randrange(100)))
            assert c.insert(stamp, 1, v) == m.insert(stamp, 1, v)

    def check() -> None:
        _check_against(c, m, [rng.randint(m.s[0][0] - 500, m.s[-1][0] + 500) for _ in range(150)])
        assert [_bits(row) for row in c.columns()[2]] == [_bits(x[2]) for x in m.s]

    feed(60, 1.0)                              # filling: a resize every few samples, never wrapped
    check()
    feed(steady, 1.0)                          # steady at 101 samples, wrapped
    check()
    feed(800, 0.25, late=0.05)                 # 4x the rate: the full wrapped ring grows, and again
    assert len(c) > 390
    check()
    feed(400, 8.0)                             # 1/8 the rate: the ring unrolls and shrinks
    assert len(c) <= 14 and c.capacity < 60
    check()
    feed(150, 1.0, late=0.05, ty=lambda k: k)  # ty varies from here on: a wider ring, low words copied
    check()
    assert c.nbytes() == c.capacity * (4 + 7 * 8)  # one allocation, one run in the object, no constants block


def test_caches_are_not_tracked_by_the_garbage_collector() -> None:
    """The caches hold no Python object (the authority is BufferCore's): nothing for the GC to walk."""
    import gc

    c = TimeCache(1000)
    c.insert(5, 1, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    assert not gc.is_tracked(c) and not gc.is_tracked(StaticCache())
