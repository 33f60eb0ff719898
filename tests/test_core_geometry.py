"""do_transform_*, transform(), and the vectorized extras against loops of single lookups."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from zentf import ConnectivityException, ExtrapolationException, LookupException, TypeException
from zentf.core import geometry
from zentf.core.buffer_core import BufferCore
from zentf.core.geometry import (do_transform_point, do_transform_pose, do_transform_vector3, lookup_transforms,
                            transform, transform_full, transform_points, transform_points_series)
from zentf.core.messages import (Header, Point, PointStamped, Pose, PoseStamped, Quaternion, Transform,
                            TransformStamped, Vector3, Vector3Stamped)
from zentf.core.time import Time

S = 1_000_000_000


@pytest.fixture(autouse=True, params=["numpy", "numba"])
def fast_path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Every test runs on both implementations of lookup_transforms' plain-chain path."""
    if request.param == "numba":
        pytest.importorskip("numba")
    monkeypatch.setattr(geometry, "USE_NUMBA", request.param == "numba")
    assert geometry.fast_path() == request.param
    return request.param


FLIP_X = (1.0, 0.0, 0.0, 0.0)  # 180 degrees about x


def edge(parent: str, child: str, sec: float, t, q) -> TransformStamped:
    return TransformStamped(Header(Time.from_sec(sec), parent), child, Transform(Vector3(*t), Quaternion(*q)))


def test_do_transform_known_values_from_tf2_geometry_msgs() -> None:
    t = edge("A", "B", 2, (10, 20, 30), FLIP_X)
    p = do_transform_point(PointStamped(Header(Time(2), "B"), Point(1, 2, 3)), t)
    assert (p.point.x, p.point.y, p.point.z) == pytest.approx((11, 18, 27))
    assert p.header.frame_id == "A" and p.header.stamp == Time(2)
    v = do_transform_vector3(Vector3Stamped(Header(Time(2), "B"), Vector3(1, 2, 3)), t)
    assert (v.vector.x, v.vector.y, v.vector.z) == pytest.approx((1, -2, -3))
    assert do_transform_vector3(Vector3(1, 0, 0), edge("a", "b", 0, (1, 2, 3), (0, 1, 0, 0))).x == pytest.approx(-1)
    pose = do_transform_pose(Pose(Point(1, 2, 3), Quaternion(0, 0, 0, 1)), t)
    assert (pose.position.x, pose.position.y, pose.position.z) == pytest.approx((11, 18, 27))
    assert (pose.orientation.x, pose.orientation.w) == pytest.approx((1, 0))


def test_transform_through_buffer_and_type_errors() -> None:
    core = BufferCore()
    core.set_transform(edge("A", "B", 2, (10, 20, 30), FLIP_X), "x")
    p = transform(core, PointStamped(Header(Time(2), "A"), Point(1, 2, 3)), "B")
    assert (p.point.x, p.point.y, p.point.z) == pytest.approx((-9, 18, 27))
    assert p.header.frame_id == "B"
    pose = core.transform(PoseStamped(Header(Time(2), "A"), Pose(Point(1, 2, 3))), "B")
    assert (pose.pose.position.x, pose.pose.position.y) == pytest.approx((-9, 18))
    full = transform_full(core, PointStamped(Header(Time(2), "A"), Point(1, 2, 3)), "B", Time(2), "A")
    assert (full.point.x, full.point.y, full.point.z) == pytest.approx((-9, 18, 27))
    with pytest.raises(TypeException, match="not loaded or supported"):
        transform(core, Point(1, 2, 3), "B")
    with pytest.raises(TypeException):
        transform(core, PointStamped(Header(Time(2), "A")), "B", new_type=PoseStamped)
    with pytest.raises(ExtrapolationException):
        transform(core, PointStamped(Header(Time(5), "A")), "B")


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


def test_lookup_transforms_lets_inserts_through_between_chunks() -> None:
    """The lock is taken per chunk, so a listener may append newer samples during a batch; the
    tables are rebuilt when data changed, and answers about the past stay exactly the same."""
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
    exactly (including the newest), 8k-time chunk borders, non-unit quaternions as tf2 stores them."""
    core = sorted_chain(non_unit)
    kernel_runs = []
    real = geometry._run_kernel
    monkeypatch.setattr(geometry, "_run_kernel", lambda *a: kernel_runs.append(1) or real(*a))
    times = np.unique(np.concatenate([np.linspace(100 * S, 105 * S, 20_000).astype(np.int64),
                                      np.arange(100 * S, 105 * S + 1, S // 10)]))
    pick = np.concatenate([times[:50], times[8150:8250], times[-60:], times[::997]])
    for target, source in CHAIN_PAIRS:
        kernel_runs.clear()
        v, q = lookup_transforms(core, target, source, times)
        assert len(kernel_runs) == (3 if fast_path == "numba" else 0), (target, source)  # one per chunk
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
            monkeypatch.setattr(geometry, "USE_NUMBA", use)
            got[use] = [np.concatenate(lookup_transforms(core, target, source, ts), axis=1)
                        for ts in (times, shuffled)]
        for a, b in zip(got[False], got[True]):
            assert np.abs(a - b).max() < 1e-12, (target, source)


def test_numba_is_imported_lazily_and_optional(fast_path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """import zentf (CLI start-up) never loads numba; without numba the numpy path runs silently."""
    code = "import sys, zentf, zentf.core.geometry, zentf.core.buffer_core; assert 'numba' not in sys.modules"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True).returncode == 0
    monkeypatch.setattr(geometry, "_kernel", None)
    monkeypatch.setitem(sys.modules, "numba", None)          # import numba raises ImportError
    monkeypatch.delitem(sys.modules, "zentf.core._chain_kernel", raising=False)
    assert geometry.fast_path() == "numpy"
    core = sorted_chain()
    times = np.linspace(100 * S, 105 * S, 500).astype(np.int64)
    v, q = lookup_transforms(core, "map", "tip", times)
    wv, wq = loop(core, "map", "tip", times)
    assert np.abs(v - wv).max() < 1e-9
