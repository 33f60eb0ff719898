"""BufferCore: known answers from the field and tf2's documented semantics (no oracle needed)."""
from __future__ import annotations

import logging
import math
import threading

import numpy as np
import pytest

from zentf import (ConnectivityException, ExtrapolationException, InvalidArgumentException,
                   LookupException, TransformException)
from zentf.core.buffer_core import NEVER_TRANSFORMABLE, BufferCore, TransformableResult
from zentf.core.math3d import quaternion_from_rpy
from zentf.core.messages import Header, Point, PointStamped, Quaternion, Transform, TransformStamped, Vector3
from zentf.core.time import Duration, Time

S = 1_000_000_000


def ts(parent: str, child: str, sec: float, xyz=(0.0, 0.0, 0.0), q=(0.0, 0.0, 0.0, 1.0)) -> TransformStamped:
    return TransformStamped(header=Header(stamp=Time.from_sec(sec), frame_id=parent), child_frame_id=child,
                            transform=Transform(Vector3(*xyz), Quaternion(*q)))


def xyz(t: TransformStamped) -> tuple[float, float, float]:
    v = t.transform.translation
    return (v.x, v.y, v.z)


def quat(t: TransformStamped) -> tuple[float, float, float, float]:
    q = t.transform.rotation
    return (q.x, q.y, q.z, q.w)


# ----------------------------------------------------------------------- known answers

def robot(yaw: float = 0.0) -> BufferCore:
    core = BufferCore()
    assert core.set_transform(ts("base_link", "laser", 0, (0.4, 0.0, 0.2), quaternion_from_rpy(0, 0, yaw)),
                              "robot", is_static=True)
    assert core.set_transform(ts("base_link", "camera", 0, (-0.5, 0.0, 0.4)), "robot", is_static=True)
    return core


def test_camera_sees_laser_offset() -> None:
    t = robot().lookup_transform("camera", "laser", 0)
    assert xyz(t) == pytest.approx((0.9, 0.0, -0.2), abs=1e-12)
    assert quat(t) == pytest.approx((0.0, 0.0, 0.0, 1.0))
    assert (t.header.frame_id, t.child_frame_id, t.header.stamp) == ("camera", "laser", Time())


@pytest.mark.parametrize("x", [0.0, 1.0, 2.5, -3.0])
def test_obstacle_in_laser_lands_in_base_link(x: float) -> None:
    core = robot()
    p = core.transform(PointStamped(Header(Time.from_sec(12.0), "laser"), Point(x, 0.0, 0.1)), "base_link")
    assert (p.point.x, p.point.y, p.point.z) == pytest.approx((x + 0.4, 0.0, 0.3), abs=1e-12)
    assert p.header.frame_id == "base_link" and p.header.stamp == Time.from_sec(12.0)  # static: any stamp


@pytest.mark.parametrize("x", [1.0, 2.0])
def test_yawed_laser_rotates_answers(x: float) -> None:
    core = robot(yaw=0.5)
    p = core.transform(PointStamped(Header(Time(), "laser"), Point(x, 0.0, 0.1)), "base_link")
    assert (p.point.x, p.point.y, p.point.z) == pytest.approx(
        (0.4 + x * math.cos(0.5), x * math.sin(0.5), 0.3), abs=1e-12)
    t = core.lookup_transform("camera", "laser", 0)
    assert xyz(t) == pytest.approx((0.9, 0.0, -0.2), abs=1e-12)
    assert quat(t) == pytest.approx((0.0, 0.0, math.sin(0.25), math.cos(0.25)), abs=1e-12)
    back = core.lookup_transform("laser", "camera", 0)  # the inverse: rotated offset
    assert xyz(back) == pytest.approx((-0.9 * math.cos(0.5), 0.9 * math.sin(0.5), 0.2), abs=1e-12)


def test_two_drones_trace_an_ellipse_on_a_plane() -> None:
    """av1 at (cos t, sin t, 0) yawing t, av2 at (sin t, 0, cos 2t): av2 seen from av1 lies on
    2y - z + 1 = 0 and traces an ellipse with semi-axes 1/2 and sqrt(5)/2."""
    core = BufferCore(cache_time=30.0)
    t0 = 1000.0
    ts_ = np.linspace(0.0, 2 * math.pi, 400, endpoint=False)
    for t in ts_:
        stamp = t0 + t
        core.set_transform(ts("world", "av1", stamp, (math.cos(t), math.sin(t), 0.0),
                              quaternion_from_rpy(0, 0, t)), "av1")
        core.set_transform(ts("world", "av2", stamp, (math.sin(t), 0.0, math.cos(2 * t))), "av2")
    stamps = [Time.from_sec(t0 + t) for t in ts_]
    pts = np.array([xyz(core.lookup_transform("av1", "av2", s)) for s in stamps])
    assert np.abs(2 * pts[:, 1] - pts[:, 2] + 1).max() < 1e-9
    centered = pts - pts.mean(axis=0)
    eig = np.sort(np.linalg.eigvalsh(centered.T @ centered / len(pts)))
    # uniform samples of c + a sin + b cos: variance |a|^2/2 along a, |b|^2/2 along b, 0 across
    assert eig[0] == pytest.approx(0.0, abs=1e-9)
    assert math.sqrt(2 * eig[1]) == pytest.approx(0.5, abs=1e-9)
    assert math.sqrt(2 * eig[2]) == pytest.approx(math.sqrt(5) / 2, abs=1e-9)
    # the vectorized series gives the same points in one call
    v, _ = core.lookup_transforms("av1", "av2", stamps)
    assert np.abs(v - pts).max() < 1e-12


# ----------------------------------------------------------------------- insert semantics

def test_interpolates_between_samples_and_stamps_with_request() -> None:
    core = BufferCore()
    core.set_transform(ts("a", "b", 1, (1, 0, 0)), "x")
    core.set_transform(ts("a", "b", 2, (2, 0, 0)), "x")
    t = core.lookup_transform("a", "b", 1.25)
    assert xyz(t)[0] == pytest.approx(1.25) and t.header.stamp == Time.from_sec(1.25)
    assert xyz(core.lookup_transform("b", "a", 1.5))[0] == pytest.approx(-1.5)
    latest = core.lookup_transform("a", "b", 0)
    assert xyz(latest)[0] == 2.0 and latest.header.stamp == Time(2)


def test_repeated_stamp_is_refused_and_first_wins(caplog) -> None:
    core = BufferCore()
    assert core.set_transform(ts("a", "b", 1, (1, 0, 0)), "x")
    with caplog.at_level(logging.WARNING, "zentf.core.buffer_core"):
        assert not core.set_transform(ts("a", "b", 1, (5, 0, 0)), "y")
    assert "TF_REPEATED_DATA" in caplog.text
    assert xyz(core.lookup_transform("a", "b", 1))[0] == 1.0
    assert core.frame_info()[0]["broadcaster"] == "x"


def test_old_data_is_refused_and_pruned(caplog) -> None:
    core = BufferCore(cache_time=Duration(10))
    core.set_transform(ts("a", "b", 100), "x")
    assert core.set_transform(ts("a", "b", 90), "x")          # exactly cache_time older: kept
    with caplog.at_level(logging.WARNING, "zentf.core.buffer_core"):
        assert not core.set_transform(ts("a", "b", 89.999), "x")
    assert "TF_OLD_DATA" in caplog.text and "frame b" in caplog.text
    core.set_transform(ts("a", "b", 100.5), "x")               # 90 now falls out (pruned at once)
    with pytest.raises(ExtrapolationException, match="into the past"):
        core.lookup_transform("a", "b", 90)
    assert core.frame_info()[0]["oldest_transform"] == Time(100)


@pytest.mark.parametrize("bad", [
    dict(xyz=(math.nan, 0, 0)), dict(q=(0.0, 0.0, 0.0, 0.0)), dict(q=(0.0, 0.0, 0.5, 0.5)),
    dict(q=(math.nan, 0.0, 0.0, 1.0)), dict(parent="", child="c"), dict(parent="c", child=""),
    dict(parent="a", child="a"), dict(parent="/a", child="/a"), dict(parent="a", child="/"),
])
def test_malformed_input_is_refused_and_buffer_untouched(bad, caplog) -> None:
    core = BufferCore()
    core.set_transform(ts("a", "b", 1, (1, 0, 0)), "x")
    before = core.all_frames_as_yaml()
    parent, child = bad.get("parent", "a"), bad.get("child", "b")
    with caplog.at_level(logging.ERROR, "zentf.core.buffer_core"):
        ok = core.set_transform(ts(parent, child, 2, bad.get("xyz", (9, 9, 9)), bad.get("q", (0, 0, 0, 1))), "evil")
    assert ok is False
    assert "TF_" in caplog.text
    assert core.all_frames_as_yaml() == before
    assert xyz(core.lookup_transform("a", "b", 0))[0] == 1.0


def test_quaternion_is_stored_as_given_within_tolerance() -> None:
    core = BufferCore()
    assert core.set_transform(ts("a", "b", 1, q=(0.0, 0.0, 0.0, 1.004)), "x")
    assert quat(core.lookup_transform("a", "b", 1))[3] == 1.004


def test_leading_slash_stripped_on_insert_refused_on_lookup() -> None:
    core = BufferCore()
    assert core.set_transform(ts("/map", "/odom", 1, (1, 0, 0)), "x")
    assert core.get_frames() == ["odom", "map"]
    assert xyz(core.lookup_transform("map", "odom", 1))[0] == 1.0
    with pytest.raises(InvalidArgumentException, match="cannot start with a '/'"):
        core.lookup_transform("/map", "odom", 1)
    with pytest.raises(InvalidArgumentException, match="cannot be empty"):
        core.lookup_transform("map", "", 1)
    assert core.can_transform("/map", "odom", 1, return_debug_tuple=True) == (False, "")


def test_unknown_and_disconnected_frames() -> None:
    core = BufferCore()
    core.set_transform(ts("a", "b", 1), "x")
    core.set_transform(ts("x", "y", 1), "x")
    with pytest.raises(LookupException, match='"zz" passed to lookupTransform argument source_frame does not exist'):
        core.lookup_transform("a", "zz", 1)
    with pytest.raises(ConnectivityException, match="not part of the same tree"):
        core.lookup_transform("a", "y", 1)
    assert core.can_transform("a", "zz", 1, return_debug_tuple=True) == (
        False, "canTransform: source_frame zz does not exist.")
    assert core.can_transform("a", "y", 0) is False
    assert issubclass(ConnectivityException, TransformException)


def test_identity_lookup_needs_no_frames() -> None:
    core = BufferCore()
    t = core.lookup_transform("nowhere", "nowhere", 3.0)
    assert quat(t) == (0.0, 0.0, 0.0, 1.0) and t.header.stamp == Time(3)
    assert core.can_transform("", "", 0)  # tf2 short-circuits before validating


def test_extrapolation_messages_follow_ros1() -> None:
    core = BufferCore()
    core.set_transform(ts("a", "b", 1), "x")
    core.set_transform(ts("a", "b", 2), "x")
    with pytest.raises(ExtrapolationException) as e:
        core.lookup_transform("a", "b", 2.5)
    assert str(e.value) == ("Lookup would require extrapolation 0.500000000s into the future.  Requested time "
                            "2.500000000 but the latest data is at time 2.000000000, when looking up transform "
                            "from frame [b] to frame [a]")
    ok, why = core.can_transform("a", "b", 0.5, return_debug_tuple=True)
    assert not ok and "0.500000000s into the past" in why


def test_static_frames_valid_at_all_times_and_survive_clear() -> None:
    core = BufferCore()
    core.set_transform(ts("a", "s", 50, (1, 0, 0)), "x", is_static=True)
    core.set_transform(ts("a", "d", 50, (2, 0, 0)), "x")
    t = core.lookup_transform("a", "s", 7)
    assert xyz(t)[0] == 1.0 and t.header.stamp == Time(7)     # before its own stamp too
    assert core.lookup_transform("a", "s", 0).header.stamp == Time()  # static-only chain: 0
    core.clear()
    assert xyz(core.lookup_transform("a", "s", 1e6))[0] == 1.0
    with pytest.raises(ConnectivityException):
        core.lookup_transform("a", "d", 0)
    assert core.frame_exists("d")


def test_first_cache_type_is_kept() -> None:
    """ROS 1 behaviour (ROS 2 would replace the cache): dynamic first stays dynamic, and the
    reverse turns later dynamic samples into overwrites of the static slot."""
    core = BufferCore()
    core.set_transform(ts("a", "b", 1, (1, 0, 0)), "x")
    core.set_transform(ts("a", "b", 5, (3, 0, 0)), "x", is_static=True)
    with pytest.raises(ExtrapolationException, match="into the future"):
        core.lookup_transform("a", "b", 100)
    core.set_transform(ts("s", "t", 5, (3, 0, 0)), "x", is_static=True)
    core.set_transform(ts("s", "t", 6, (4, 0, 0)), "x")
    assert xyz(core.lookup_transform("s", "t", 100))[0] == 4.0


def test_reparenting_uses_older_sample_between_parents() -> None:
    core = BufferCore()
    core.set_transform(ts("a", "e", 30, (1, 0, 0)), "x")
    core.set_transform(ts("x", "e", 32, (7, 0, 0)), "x")
    t = core.lookup_transform("a", "e", 31)
    assert xyz(t)[0] == 1.0 and t.header.stamp == Time(31)
    with pytest.raises(ConnectivityException):
        core.lookup_transform("x", "e", 31)
    assert xyz(core.lookup_transform("x", "e", 0))[0] == 7.0
    assert core.get_parent("e", 31) == "a" and core.get_parent("e", 0) == "x"
    assert core.get_parent("a", 31) is None and core.get_parent("zz") is None


def test_latest_common_time_legacy_examples() -> None:
    core = BufferCore()
    core.set_transform_raw("parent", "a", 1000, 0, 0, 0, 0, 0, 0, 1, "x")
    core.set_transform_raw("pp", "parent", 2000, 0, 0, 0, 0, 0, 0, 1, "x")
    assert core.get_latest_common_time("a", "pp") == Time(nanoseconds=1000)
    core.set_transform_raw("parent", "a", 3000, 0, 0, 0, 0, 0, 0, 1, "x")
    assert core.get_latest_common_time("a", "pp") == Time(nanoseconds=2000)
    for parent, child, stamp in [("parent", "b", 4000), ("b", "c", 3000), ("c", "d", 9000), ("f", "e", 5000)]:
        core.set_transform_raw(parent, child, stamp, 0, 0, 0, 0, 0, 0, 1, "x")
    for x, y in [("a", "b"), ("a", "c"), ("a", "d")]:
        assert core.get_latest_common_time(x, y) == Time(nanoseconds=3000)
        assert core.get_latest_common_time(y, x) == Time(nanoseconds=3000)
    assert core.get_latest_common_time("e", "f") == Time(nanoseconds=5000)
    with pytest.raises(ConnectivityException):
        core.get_latest_common_time("a", "e")
    with pytest.raises(LookupException):
        core.get_latest_common_time("a", "zz")


def test_loop_is_reported_as_lookup_exception() -> None:
    core = BufferCore()
    core.set_transform(ts("a", "b", 1), "x")
    core.set_transform(ts("b", "a", 1), "x")
    core.set_transform(ts("x", "z", 1), "x")
    with pytest.raises(LookupException, match="contains a loop"):
        core.lookup_transform("z", "a", 1)


def test_frame_reports_match_tf2_text() -> None:
    core = BufferCore()
    assert core.all_frames_as_yaml() == "{}"
    core.set_transform(ts("a", "b", 1), "auth")
    core.set_transform(ts("a", "b", 2), "auth")
    core.set_transform(ts("x", "y", 5), "auth")
    core.set_transform(ts("s", "t", 100), "auth2", is_static=True)
    # probed from python3-tf2 0.7.6
    assert core.all_frames_as_yaml() == (
        "b: \n  parent: 'a'\n  broadcaster: 'auth'\n  rate: 2.000\n  most_recent_transform: 2.000\n"
        "  oldest_transform: 1.000\n  buffer_length: 1.000\n"
        "y: \n  parent: 'x'\n  broadcaster: 'auth'\n  rate: 10000.000\n  most_recent_transform: 5.000\n"
        "  oldest_transform: 5.000\n  buffer_length: 0.000\n"
        "t: \n  parent: 's'\n  broadcaster: 'auth2'\n  rate: 10000.000\n  most_recent_transform: 0.000\n"
        "  oldest_transform: 0.000\n  buffer_length: 0.000\n")
    assert core.all_frames_as_string() == (
        "Frame b exists with parent a.\nFrame y exists with parent x.\nFrame t exists with parent s.\n")
    assert "transform_delay: 8.000" in core.all_frames_as_yaml(current_time=10)
    info = {i["frame"]: i for i in core.frame_info()}
    assert info["b"]["samples"] == 2 and info["b"]["most_recent_transform"] == Time(2)
    assert info["t"]["static"] and info["t"]["broadcaster"] == "auth2"
    assert set(core.get_frames()) == {"a", "b", "x", "y", "s", "t"}
    assert "digraph G {" in core._all_frames_as_dot()
    dynamic_only = BufferCore()
    dynamic_only.set_transform(ts("a", "b", 1), "auth")
    dynamic_only.clear()
    assert dynamic_only.all_frames_as_yaml() == ""  # tf2: '{}' only while no frame was ever named


def test_chain_as_vector() -> None:
    core = BufferCore()
    for parent, child in [("a", "b"), ("b", "c"), ("a", "d"), ("d", "e")]:
        core.set_transform(ts(parent, child, 1), "x")
    assert core.chain_as_vector("c", 0, "c", 0, "c") == []
    assert core.chain_as_vector("a", 0, "c", 0, "a") == ["c", "b", "a"]
    assert core.chain_as_vector("c", 0, "a", 0, "a") == ["a", "b", "c"]
    for fixed in "cae":
        assert core.chain_as_vector("c", 0, "e", 0, fixed) == ["e", "d", "a", "b", "c"]


def test_set_transform_raw_matches_set_transform() -> None:
    a, b = BufferCore(), BufferCore()
    q = quaternion_from_rpy(0.1, 0.2, 0.3)
    a.set_transform(ts("/p", "c", 1.5, (1, 2, 3), q), "x")
    assert b.set_transform_raw("/p", "c", int(1.5 * S), 1, 2, 3, *q, "x") is True
    assert b.set_transforms_raw([("p", "c", 2 * S, 1, 2, 3, *q), ("p", "c", 2 * S, 1, 2, 3, *q)], "x") == 1
    assert a.all_frames_as_string() == b.all_frames_as_string()
    assert xyz(a.lookup_transform("p", "c", 1.5)) == xyz(b.lookup_transform("p", "c", 1.5))


# ----------------------------------------------------------------------- callbacks and threads

def test_insert_callbacks_and_transformable_requests() -> None:
    core = BufferCore()
    woke = []
    core.add_insert_callback(lambda: woke.append(1))
    fired = []
    cb = lambda *args: fired.append(args)  # noqa: E731
    assert core.add_transformable_request(cb, "a", "a", 1) == 0
    h = core.add_transformable_request(cb, "foo", "bar", 10)
    assert h not in (0, NEVER_TRANSFORMABLE)
    h2 = core.add_transformable_request(cb, "foo", "bar", 20)
    core.cancel_transformable_request(h2)
    for sec in range(1, 10):
        core.set_transform(ts("foo", "bar", sec), "x")
    assert fired == [] and len(woke) == 9
    core.set_transform(ts("foo", "bar", 10), "x")
    assert fired == [(h, "foo", "bar", Time(10), TransformableResult.TransformAvailable)]
    assert core.add_transformable_request(cb, "foo", "bar", 5) == 0          # already transformable
    core.set_transform(ts("foo", "bar", 30), "x")
    assert core.add_transformable_request(cb, "foo", "bar", 1) == NEVER_TRANSFORMABLE
    h3 = core.add_transformable_request(cb, "foo", "bar", 35)
    core.set_transform(ts("foo", "bar", 50), "x")                           # 35 + 10 < 50: failure
    assert fired[-1] == (h3, "foo", "bar", Time(35), TransformableResult.TransformFailure)
    assert not core.set_transform(ts("foo", "foo", 1), "x") and len(woke) == 12  # refused: no wake


def test_concurrent_inserts_and_lookups() -> None:
    core = BufferCore()
    core.set_transform(ts("w", "r", 1), "x")
    errors: list[BaseException] = []
    stop = threading.Event()

    def reader() -> None:
        try:
            while not stop.is_set():
                t = core.lookup_transform("w", "r", 0)
                assert t.transform.translation.x == t.header.stamp.to_sec() - 1  # consistent sample
        except BaseException as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=reader) for _ in range(3)]
    for th in threads:
        th.start()
    for i in range(2, 3000):
        core.set_transform_raw("w", "r", i * S // 100, i / 100 - 1, 0, 0, 0, 0, 0, 1, "x")
    stop.set()
    for th in threads:
        th.join()
    assert not errors


def test_times_accept_seconds_and_reject_garbage() -> None:
    core = BufferCore()
    core.set_transform(ts("a", "b", 1), "x")
    assert core.can_transform("a", "b", 1) and core.can_transform("a", "b", Time(1))
    assert core.can_transform("a", "b", np.float64(1.0)) and core.can_transform("a", "b", np.int64(1))
    with pytest.raises(TypeError):
        core.lookup_transform("a", "b", "now")
    with pytest.raises(ValueError):
        core.lookup_transform("a", "b", -1.0)


# ----------------------------------------------------------------------- tf2 oddities we match on purpose

def test_tf2_oddities_are_matched() -> None:
    """Each of these was probed on python3-tf2 0.7.6 and is reproduced deliberately."""
    core = BufferCore()
    core.set_transform(ts("a", "b", 1), "x")
    core.set_transform(ts("a", "b", 2), "x")
    core.set_transform(ts("b", "c", 5), "x")
    core.set_transform(ts("b", "c", 6), "x")
    # the target's own (stale) edge is queried but never needed when it is an ancestor
    assert core.can_transform("b", "c", 5.5) and core.lookup_transform("b", "c", 5.5).header.stamp == Time.from_sec(5.5)
    # advanced can_transform explains only its second half; an unknown fixed frame gives no reason
    assert core.can_transform_full("a", 1.5, "b", 1.5, "nope", return_debug_tuple=True) == (False, "")
    # identity short-cut happens before validation, and is stamped with the frame's newest sample at 0
    assert core.lookup_transform("c", "c", 0).header.stamp == Time(6)
    assert core.lookup_transform("", "", 0).header.frame_id == ""
    # after clear(), a dynamic edge looked up at a time fails with an empty cache text
    core.clear()
    with pytest.raises(ExtrapolationException) as e:
        core.lookup_transform("a", "b", 1)
    assert str(e.value) == ", when looking up transform from frame [b] to frame [a]"
    # ...and at time 0 the emptied caches look parentless: connectivity, not extrapolation
    with pytest.raises(ConnectivityException):
        core.lookup_transform("a", "b", 0)
    # a child named like tf2's sentinel is accepted and ignored
    assert core.set_transform(ts("a", "NO_PARENT", 1), "x") and not core.frame_exists("NO_PARENT")


def test_raw_insert_stores_floats() -> None:
    core = BufferCore()
    core.set_transform_raw("a", "b", 5, 1, 2, 3, 0, 0, 0, 1, "x")
    core.set_transform_raw("a", "s", 5, 1, 2, 3, 0, 0, 0, 1, "x", True)
    for child in "bs":
        t = core.lookup_transform("a", child, 0).transform
        assert all(type(v) is float for v in (t.translation.x, t.translation.y, t.rotation.w))


def test_frame_info_names_the_authority_of_each_frames_last_accepted_sample() -> None:
    """tf2 keeps the authority of a frame's last accepted sample (BufferCore holds it per frame id):
    a refused sample (old data) does not change it, a later accepted one does."""
    from zentf.core.buffer_core import BufferCore

    b = BufferCore(1.0)
    assert b.set_transform_raw("map", "a", 10 ** 10, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, "/first")
    assert b.set_transform_raw("map", "b", 10 ** 10, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, "/other")
    assert not b.set_transform_raw("map", "a", 10 ** 8, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, "/late")
    info = {i["frame"]: i["broadcaster"] for i in b.frame_info()}
    assert info == {"a": "/first", "b": "/other"}
    assert b.set_transform_raw("map", "a", 2 * 10 ** 10, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, "/second")
    assert {i["frame"]: i["broadcaster"] for i in b.frame_info()}["a"] == "/second"
    assert "broadcaster: '/second'" in b.all_frames_as_yaml()


def test_new_frames_leave_no_python_blocks_behind_beyond_what_they_hold() -> None:
    """Creating a frame (tf2's full path) keeps its cache and id, nothing more: no temporaries
    parked in CPython's free lists (tuple(generator) left one 7-tuple per new frame there, 96 B
    each until a full collection cleared them)."""
    import gc
    import sys

    b = BufferCore(10.0)
    b.set_transform_raw("root", "warm", 10 ** 10, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 1.0, "test")
    names = [f"frame{i}" for i in range(600)]
    gc.collect()
    start = sys.getallocatedblocks()
    for name in names:
        assert b.set_transform_raw("root", name, 10 ** 10, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0, 1.0, "test")
    during = sys.getallocatedblocks() - start
    gc.collect()                              # a full collection clears the free lists
    held = sys.getallocatedblocks() - start
    assert during - held < 0.2 * len(names), (during, held)
