"""lookup_transforms and transform_points (zentf.core.batch) against loops of single lookups, on both
arithmetic paths (numpy, and the numba kernel when numba is installed)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from zentf import ConnectivityException, ExtrapolationException, LookupException
from zentf.core import batch
from zentf.core.batch import lookup_transforms, transform_points, transform_points_series
from zentf.core.buffer_core import BufferCore
from zentf.core.time import Time

S = 1_000_000_000


@pytest.fixture(autouse=True, params=["numpy", "numba"])
def fast_path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Every test runs on both implementations of the batch arithmetic."""
    if request.param == "numba":
        pytest.importorskip("numba")
    monkeypatch.setattr(batch, "USE_NUMBA", request.param == "numba")
    assert batch.fast_path() == request.param
    return request.param


def moving_tree() -> BufferCore:
    """w -> a -> b -> c with rotating edges at 10 Hz over 5 s; c switches parent b -> w at 3 s."""
    core = BufferCore()
    rng = np.random.default_rng(7)
    for k in range(51):
        stamp = 100 * S + k * S // 10
        for parent, child in [("w", "a"), ("a", "b")]:
            q = Rotation.from_rotvec(rng.normal(size=3)).as_quat()
            core.set_transform_raw(parent, child, stamp, *rng.uniform(-2, 2, 3), *q, "x")
        parent = "b" if k < 30 else "w"
        core.set_transform_raw(parent, "c", stamp, *rng.uniform(-2, 2, 3),
                               *Rotation.from_rotvec(rng.normal(size=3)).as_quat(), "x")
    core.set_transform_raw("c", "cam", 0, 0.1, 0.0, 0.2, 0, 0, 0, 1, "x", True)
    return core


def loop(core: BufferCore, target: str, source: str, times_ns) -> tuple[np.ndarray, np.ndarray]:
    v, q = [], []
    for t in times_ns:
        r = core.lookup_transform(target, source, Time(nanoseconds=int(t))).transform
        v.append((r.translation.x, r.translation.y, r.translation.z))
        q.append((r.rotation.x, r.rotation.y, r.rotation.z, r.rotation.w))
    return np.array(v), np.array(q)


@pytest.mark.parametrize("target,source", [("w", "cam"), ("cam", "w"), ("a", "cam"), ("cam", "b"),
                                           ("b", "a"), ("a", "b"), ("c", "c"), ("cam", "c")])
def test_lookup_transforms_equals_single_lookups(target: str, source: str) -> None:
    core = moving_tree()
    rng = np.random.default_rng(8)
    times = np.concatenate([rng.integers(100 * S, 105 * S, 300), [100 * S, 105 * S, 0, 103 * S]])
    v, q = lookup_transforms(core, target, source, times)
    wv, wq = loop(core, target, source, times)
    assert np.abs(v - wv).max() < 1e-9
    assert np.minimum(np.abs(q - wq).max(1), np.abs(q + wq).max(1)).max() < 1e-9


def test_lookup_transforms_connectivity_over_a_parent_switch() -> None:
    core = moving_tree()
    core.set_transform_raw("z", "lost", 100 * S, 0, 0, 0, 0, 0, 0, 1, "x")
    core.set_transform_raw("w", "lost", 102 * S, 0, 0, 0, 0, 0, 0, 1, "x")
    ok = np.array([102 * S, 102 * S])
    assert np.allclose(lookup_transforms(core, "a", "lost", ok)[0], loop(core, "a", "lost", ok)[0])
    with pytest.raises(ConnectivityException):
        lookup_transforms(core, "a", "lost", np.array([102 * S, 101 * S]))


def test_lookup_transforms_raises_first_error_like_single_lookup() -> None:
    core = moving_tree()
    times = np.array([101 * S, 99 * S, 106 * S])
    with pytest.raises(ExtrapolationException) as vec:
        lookup_transforms(core, "w", "cam", times)
    with pytest.raises(ExtrapolationException) as one:
        core.lookup_transform("w", "cam", Time(99))
    assert str(vec.value) == str(one.value)
    with pytest.raises(LookupException):
        lookup_transforms(core, "w", "nope", times)
    seconds = lookup_transforms(core, "w", "cam", [101.05, Time(nanoseconds=101 * S)])
    assert seconds[0].shape == (2, 3) and seconds[1].shape == (2, 4)


def test_transform_points_and_series() -> None:
    core = moving_tree()
    pts = np.random.default_rng(9).normal(size=(1000, 3))
    out = transform_points(core, pts, "w", "cam", 102.5)
    t = core.lookup_transform("w", "cam", 102.5).transform
    rot = Rotation.from_quat([t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w])
    assert np.abs(out - (rot.apply(pts) + [t.translation.x, t.translation.y, t.translation.z])).max() < 1e-9
    assert np.array_equal(core.transform_points(pts, "w", "cam", 102.5), out)
    times = np.linspace(100.5, 104.5, 1000)
    series = transform_points_series(core, pts, "w", "cam", times)
    k = 123
    one = transform_points(core, pts[k:k + 1], "w", "cam", Time.from_sec(times[k]))
    assert np.abs(series[k] - one[0]).max() < 1e-9
    with pytest.raises(ValueError):
        transform_points(core, np.zeros((3, 2)), "w", "cam", 0)


def test_lookup_transforms_matches_single_lookups_on_dense_random_buffers() -> None:
    """Re-parenting, statics, loops, repeated stamps: the batch raises what the first failing single
    lookup raises (same class and text), or returns what the loop returns."""
    import logging

    logging.getLogger("zentf.core.buffer_core").setLevel(logging.CRITICAL)
    try:
        frames = ["a", "b", "c", "d", "e", "f"]
        checked = errors = 0
        for seed in range(25):
            rng = np.random.default_rng(seed)
            core = BufferCore(cache_time=float(rng.choice([1.0, 10.0])))
            for _ in range(150):
                parent, child = rng.choice(frames, 2, replace=False)
                stamp = 1000 * S + int(rng.integers(0, 24)) * S // 4
                q = Rotation.random(random_state=int(rng.integers(1 << 30))).as_quat()
                core.set_transform_raw(str(parent), str(child), stamp, *rng.uniform(-2, 2, 3), *q, "r",
                                       bool(rng.random() < 0.1))
            for _ in range(10):
                target, source = (str(x) for x in rng.choice(frames, 2))
                times = 1000 * S + rng.integers(-S, 7 * S, 30)
                times[rng.random(30) < 0.1] = 0
                try:
                    want = loop(core, target, source, times)
                    want_exc = None
                except Exception as e:  # noqa: BLE001 - compared below
                    want_exc = e
                try:
                    got = lookup_transforms(core, target, source, times)
                    got_exc = None
                except Exception as e:  # noqa: BLE001
                    got_exc = e
                checked += 1
                if want_exc is not None:
                    errors += 1
                    assert type(got_exc) is type(want_exc) and str(got_exc) == str(want_exc)
                else:
                    assert got_exc is None, got_exc
                    assert np.abs(got[0] - want[0]).max() < 1e-9
                    assert np.minimum(np.abs(got[1] - want[1]).max(1), np.abs(got[1] + want[1]).max(1)).max() < 1e-9
        assert 0 < errors < checked
    finally:
        logging.getLogger("zentf.core.buffer_core").setLevel(logging.NOTSET)


def test_lookup_transforms_lets_inserts_through_during_a_batch() -> None:
    """The lock is held only while a piece is planned, so a listener may append newer samples during
    a batch, and answers about the past stay exactly the same."""
    import threading

    core = moving_tree()
    times = np.linspace(100.2, 104.8, 50_000)
    want = lookup_transforms(core, "w", "cam", times)
    stop = threading.Event()
    inserted = []

    def listener() -> None:
        k = 0
        while not stop.is_set() and k < 20000:
            stamp = 105 * S + 1 + k * 1000
            for parent, child in [("w", "a"), ("a", "b"), ("w", "c")]:
                core.set_transform_raw(parent, child, stamp, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, "l")
            k += 1
            inserted.append(k)

    th = threading.Thread(target=listener)
    th.start()
    try:
        got = lookup_transforms(core, "w", "cam", times)
    finally:
        stop.set()
        th.join()
    assert inserted, "the listener never ran"
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


def sorted_chain(non_unit: bool = False) -> BufferCore:
    """map -> odom -> w static, w -> a -> b dynamic (large and small turns), b -> cam static,
    cam -> arm dynamic, arm -> tool -> tip static; x -> y apart."""
    core = BufferCore()
    rng = np.random.default_rng(11)
    for k in range(51):
        stamp = 100 * S + k * S // 10
        for parent, child, scale in [("w", "a", 3.0), ("a", "b", 0.01), ("cam", "arm", 0.3)]:
            q = Rotation.from_rotvec(rng.normal(size=3) * scale).as_quat()
            if non_unit:
                q = q * np.sqrt(1.0 + rng.uniform(-0.009, 0.009))  # tf2 accepts |q|² within 0.01
            core.set_transform_raw(parent, child, stamp, *rng.uniform(-2, 2, 3), *q, "x")
        core.set_transform_raw("x", "y", stamp, 1.0, 0.0, 0.0, 0, 0, 0, 1, "x")
    for parent, child, rv in [("b", "cam", [0.3, 0.2, 0.1]), ("map", "odom", [0.0, 0.0, 1.0]),
                              ("odom", "w", [0.1, -0.2, 0.0]), ("arm", "tool", [0.0, 0.5, 0.0]),
                              ("tool", "tip", [0.2, 0.0, 0.3])]:
        core.set_transform_raw(parent, child, 0, *rng.uniform(-1, 1, 3), *Rotation.from_rotvec(rv).as_quat(), "x", True)
    return core


CHAIN_PAIRS = [("w", "cam"), ("cam", "w"), ("a", "cam"), ("cam", "a"), ("b", "a"), ("a", "b"), ("b", "w"),
               ("w", "b"), ("map", "tip"), ("tip", "map"), ("odom", "arm"), ("tool", "odom"), ("tip", "tool"),
               ("arm", "tip"), ("tip", "cam"), ("map", "w")]


@pytest.mark.parametrize("non_unit", [False, True])
def test_lookup_transforms_sorted_chain_matches_loop(non_unit: bool, fast_path: str,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """Sorted times (run-length interval gather), statics, early outs on either side, samples hit
    exactly (including the newest), 8k-time numpy pass borders, non-unit quaternions as tf2 stores them."""
    core = sorted_chain(non_unit)
    kernel_runs = []
    real = batch._run_kernel
    monkeypatch.setattr(batch, "_run_kernel", lambda *a: kernel_runs.append(1) or real(*a))
    times = np.unique(np.concatenate([np.linspace(100 * S, 105 * S, 20_000).astype(np.int64),
                                      np.arange(100 * S, 105 * S + 1, S // 10)]))
    pick = np.concatenate([times[:50], times[8150:8250], times[-60:], times[::997]])
    for target, source in CHAIN_PAIRS:
        kernel_runs.clear()
        v, q = lookup_transforms(core, target, source, times)
        assert len(kernel_runs) == (1 if fast_path == "numba" else 0), (target, source)  # one planned piece
        wv, wq = loop(core, target, source, pick)
        k = np.searchsorted(times, pick)
        assert np.abs(v[k] - wv).max() < 1e-9, (target, source)
        assert np.minimum(np.abs(q[k] - wq).max(1), np.abs(q[k] + wq).max(1)).max() < 1e-9
        perm = np.random.default_rng(3).permutation(times.shape[0])   # unsorted: sorted per chunk
        pv, pq = lookup_transforms(core, target, source, times[perm])
        assert np.abs(pv - v[perm]).max() < 1e-12 and np.abs(pq - q[perm]).max() < 1e-12
    with pytest.raises(ConnectivityException):
        lookup_transforms(core, "w", "y", times[:10])
    with pytest.raises(ExtrapolationException):
        lookup_transforms(core, "w", "cam", np.append(times, 106 * S))


def test_lookup_transforms_numba_and_numpy_paths_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled kernel repeats the numpy path's arithmetic: results agree to rounding."""
    pytest.importorskip("numba")
    core = sorted_chain(True)
    times = np.linspace(100 * S, 105 * S, 9000).astype(np.int64)
    shuffled = times[np.random.default_rng(5).permutation(times.shape[0])]
    for target, source in CHAIN_PAIRS:
        got = {}
        for use in (False, True):
            monkeypatch.setattr(batch, "USE_NUMBA", use)
            got[use] = [np.concatenate(lookup_transforms(core, target, source, ts), axis=1)
                        for ts in (times, shuffled)]
        for a, b in zip(got[False], got[True]):
            assert np.abs(a - b).max() < 1e-12, (target, source)


def test_numba_is_imported_lazily_and_optional(fast_path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """import zentf (CLI start-up) never loads numba; without numba the numpy path runs silently."""
    code = "import sys, zentf, zentf.core.batch, zentf.core.buffer_core; assert 'numba' not in sys.modules"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True).returncode == 0
    monkeypatch.setattr(batch, "_kernel", None)
    monkeypatch.setitem(sys.modules, "numba", None)          # import numba raises ImportError
    monkeypatch.delitem(sys.modules, "zentf.core._chain_kernel", raising=False)
    assert batch.fast_path() == "numpy"
    core = sorted_chain()
    times = np.linspace(100 * S, 105 * S, 500).astype(np.int64)
    v, q = lookup_transforms(core, "map", "tip", times)
    wv, wq = loop(core, "map", "tip", times)
    assert np.abs(v - wv).max() < 1e-9


def test_chain_plan_is_the_single_lookups_walk_over_a_range() -> None:
    """BufferCore.chain_plan: the links of the walk for every time of a range, where it changes, or None."""
    core = moving_tree()
    links, n_source = core.chain_plan("w", "cam", 100 * S + 1, 102 * S + 5)
    # cam (static) -> c -> b -> a -> w: four links on the source side, none on the target side
    assert n_source == 4 and len(links) == 4
    assert links[0][0] is None and links[0][1].tolist() == [[0.1, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0]]
    for stamps, values in links[1:]:
        # the samples read: the one at or before the first time through the one after the last
        assert stamps[0] == 100 * S and stamps[-1] == 102 * S + S // 10 and values.shape == (stamps.shape[0], 7)
    assert core.chain_plan("w", "cam", 102 * S, 104 * S) == 103 * S        # c's parent switches at 103 s
    assert core.chain_plan("w", "cam", 99 * S, 101 * S) == 100 * S         # the buffers begin at 100 s
    assert core.chain_plan("w", "cam", 104 * S, 106 * S) == 105 * S + 1     # ... and end at 105 s
    assert core.chain_plan("w", "cam", 106 * S, 107 * S) is None           # no data at any of these times
    # after 103 s the walks meet at w: a -> w from the source, cam -> c -> w from the target
    links, n_source = core.chain_plan("cam", "a", 104 * S, 104 * S + 5)
    assert n_source == 1 and len(links) == 3
    # before, a is an ancestor of cam: the target's walk reaches it (cam -> c -> b -> a), the source's is unused
    links, n_source = core.chain_plan("cam", "a", 101 * S, 101 * S)
    assert n_source == 0 and len(links) == 3
    assert core.chain_plan("a", "a", 1, 2) == ([], 0)
    with pytest.raises(LookupException):
        core.chain_plan("w", "nope", 1, 2)
    with pytest.raises(ValueError):
        core.chain_plan("w", "cam", 0, 5)
    # a parent switch right after the range: its last sample applies as is (tf2 does not interpolate)
    links, _ = core.chain_plan("w", "cam", 102 * S + S // 2, 102 * S + 95 * S // 100)
    assert [s.tolist() for s, _ in links[1:2]] == [[102 * S + S // 2, 102 * S + 6 * S // 10, 102 * S + 7 * S // 10,
                                                     102 * S + 8 * S // 10, 102 * S + 9 * S // 10]]


def test_lookup_transforms_plans_pieces_where_the_walk_changes(monkeypatch: pytest.MonkeyPatch) -> None:
    """A parent switch inside the series costs one more planned piece, not a loop of single lookups."""
    core = moving_tree()
    plans, singles = [], []
    real_plan, real_single = core.chain_plan, core.lookup_transform
    monkeypatch.setattr(core, "chain_plan", lambda *a: plans.append(a[2:]) or real_plan(*a))
    monkeypatch.setattr(core, "lookup_transform", lambda *a: singles.append(a) or real_single(*a))
    times = np.linspace(100.2, 104.8, 50_000)
    v, q = lookup_transforms(core, "w", "cam", times)
    assert len(plans) == 3 and not singles               # whole range, then both sides of 103 s
    wv, wq = loop(core, "w", "cam", (times[::499] * 1e9).round().astype(np.int64))
    assert np.abs(v[::499] - wv).max() < 1e-9


def test_lookup_transforms_matches_single_lookups_over_switching_parents() -> None:
    """Long series over trees whose frames switch parents: every piece of the plan agrees with the loop."""
    frames = ["a", "b", "c", "d", "e", "f"]
    for seed in range(6):
        rng = np.random.default_rng(100 + seed)
        core = BufferCore()
        for k in range(48):
            for ci in range(1, len(frames)):
                if rng.random() < 0.3 and k not in (0, 47):
                    continue
                parent = frames[int(rng.integers(0, ci))] if rng.random() < 0.15 else frames[ci - 1]
                q = Rotation.random(random_state=int(rng.integers(1 << 30))).as_quat()
                core.set_transform_raw(parent, frames[ci], 1000 * S + k * S // 8, *rng.uniform(-2, 2, 3), *q, "r")
        core.set_transform_raw("f", "tip", 0, 1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0, "r", True)
        for target, source in [("a", "tip"), ("tip", "a"), ("c", "f"), ("e", "b"), ("tip", "d")]:
            times = 1000 * S + rng.integers(0, 47 * S // 8 + 1, 2000)
            want = loop(core, target, source, times)
            got = lookup_transforms(core, target, source, times)
            assert np.abs(got[0] - want[0]).max() < 1e-9, (seed, target, source)
            assert np.minimum(np.abs(got[1] - want[1]).max(1), np.abs(got[1] + want[1]).max(1)).max() < 1e-9


def test_the_batch_engine_reads_no_private_field_of_the_buffer() -> None:
    """zentf.core.batch talks to BufferCore through its public methods only (chain_plan, lookup_transform)."""
    import ast

    tree = ast.parse(Path(batch.__file__).read_text())
    private = [node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)
               and node.attr.startswith("_") and isinstance(node.value, ast.Name) and node.value.id == "core"]
    assert not private
