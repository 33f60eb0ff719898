"""The compiled TFMessage decoders (zentf/transport/ingest/decoders.pyx) against the Python path of each wire
that names what is wrong in a malformed message.

Whatever the compiled decoder accepts must be exactly what the Python path reads (same tuples, same
interned names, nothing malformed); whatever it doubts the ingest gives to the Python path, so a
malformed, truncated or lying payload gets that path's counts, one-line problem or exception. Both wires:
zentf (msgpack: decoders.msgpack_tf, wire.tf_samples, wire.ingest_tf) and ROS 2 (CDR: decoders.cdr_tf,
zentf.ros.tf_samples, Ros2Profile.ingest_tf).
"""
from __future__ import annotations

import logging
import math
import random
import struct
import sys
from pathlib import Path

import msgpack
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from zentf.transport.ingest import decoders
from zentf.transport.wire import codec as wire
from zentf.transport.wire import profiles as profile
from zentf.transport.wire import ros2 as ros2_wire
from zentf.transport.clock import Clock
from zentf.core.buffer_core import BufferCore
from zentf.core.ratelimit import RateLimitedLogger
from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
from zentf.core.time import Time
from zentf.transport.listener import _FutureGuard
from zentf.ros import CdrError, encode_tf as cdr_encode_tf, tf_samples
from zentf.ros.tf import _FRAMES  # the one interned-name cache every decoder shares

NS = 1_000_000_000
MAX_SEC = (2**63 - 1) // NS


def norm(samples: list | None) -> list | None:
    """Samples comparable with ==: floats by repr (nan == nan, -0.0 != 0.0), ints and names as they are."""
    if samples is None:
        return None
    return [(s[0], s[1], s[2], *(repr(v) for v in s[3:])) for s in samples]


class Recorder:
    """A BufferCore stand-in that keeps what the ingest paths hand over (and accepts every sample)."""

    def __init__(self) -> None:
        self.calls: list = []

    def set_transforms_raw(self, samples: list, authority: str, is_static: bool) -> int:
        self.calls.append((norm(samples), authority, is_static))
        return len(samples)


def test_the_compiled_decoders_are_built_and_used() -> None:
    """pip install builds zentf/transport/ingest/decoders.pyx; both wires' ingest use it (else these tests prove nothing)."""
    assert wire.msgpack_tf is decoders.msgpack_tf and ros2_wire.cdr_tf is decoders.cdr_tf
    assert decoders.__file__.endswith(".so")


# ------------------------------------------------------------------ well-formed messages (hypothesis)

names = st.text(st.characters(codec="utf-8"), max_size=12) | st.sampled_from(["world", "base_link", "/odom", "é/π"])
numbers = st.floats(allow_nan=True, allow_infinity=True) | st.integers(-(2**63), 2**64 - 1)


@st.composite
def transforms(draw, cdr: bool = False) -> dict:
    """One TransformStamped as a plain dict, fields in any order, sometimes with extra fields (CDR: floats
    only, int32 seconds)."""
    num = st.floats(allow_nan=True, allow_infinity=True) if cdr else numbers
    sec = draw(st.integers(0, 2**31 - 1 if cdr else MAX_SEC - 1) | st.sampled_from([0, 1_700_000_000]))
    nsec = draw(st.integers(0, NS - 1))

    def mapping(fields: dict) -> dict:
        items = list(fields.items())
        if draw(st.booleans()):
            items.append((draw(st.sampled_from(["extra", "seq", "x_"])),
                          draw(st.none() | st.integers() | st.text(max_size=3) | st.lists(st.integers(), max_size=2)
                               | st.dictionaries(st.text(max_size=2), st.integers(), max_size=2))))
        return dict(draw(st.permutations(items)))

    return mapping({
        "header": mapping({"stamp": mapping({"sec": sec, "nanosec": nsec}), "frame_id": draw(names)}),
        "child_frame_id": draw(names),
        "transform": mapping({"translation": mapping({k: draw(num) for k in "xyz"}),
                              "rotation": mapping({k: draw(num) for k in "xyzw"})}),
    })


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(items=st.lists(transforms(), max_size=8), single_float=st.booleans(), top_extra=st.booleans())
def test_msgpack_compiled_equals_python_on_well_formed_messages(items: list, single_float: bool,
                                                                 top_extra: bool) -> None:
    msg = {"transforms": items, **({"meta": [1, {"a": None}]} if top_extra else {})}
    try:
        payload = msgpack.packb(msg, use_single_float=single_float)
    except OverflowError:  # a double beyond float32 (the single-float variant only)
        assume(False)
    compiled = decoders.msgpack_tf(payload)
    assert compiled is not None  # well-formed: no doubt
    core = Recorder()
    assert wire.ingest_tf(payload, core, "/a", False) == (len(items), 0, 0, None)
    assert core.calls == ([(norm(compiled), "/a", False)] if items else [])
    assert wire.tf_samples(payload) == (compiled, 0, None) or norm(wire.tf_samples(payload)[0]) == norm(compiled)


@settings(max_examples=300, deadline=None)
@given(items=st.lists(transforms(cdr=True), max_size=20), tail=st.binary(max_size=9))
def test_cdr_compiled_equals_python_on_well_formed_messages(items: list, tail: bytes) -> None:
    payload = cdr_encode_tf(items) + tail  # bytes after the last element are ignored by both
    compiled = decoders.cdr_tf(payload)
    samples, malformed, problem = tf_samples(payload)
    assert (malformed, problem) == (0, None)
    assert compiled is not None and norm(compiled) == norm(samples)


def test_broadcaster_payloads_take_the_compiled_path() -> None:
    """The bytes a zentf broadcaster writes (wire.encode_tf's template) and a ROS 2 one (CDR)."""
    ts = [TransformStamped(Header(Time(sec=5, nanosec=7), "world"), f"f{i}",
                           Transform(Vector3(1.0, 2.0, 3.0), Quaternion(0.0, 0.0, 0.0, 1.0))) for i in range(3)]
    expected = [("world", f"f{i}", 5 * NS + 7, 1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0) for i in range(3)]
    assert decoders.msgpack_tf(wire.encode_tf(ts)) == expected
    assert decoders.msgpack_tf(wire.encode_tf(ts[:1])) == expected[:1]
    assert decoders.cdr_tf(cdr_encode_tf(ts)) == expected
    assert decoders.msgpack_tf(wire.encode_tf([])) == [] and decoders.cdr_tf(cdr_encode_tf([])) == []


def test_frame_names_are_interned_and_the_cache_is_bounded() -> None:
    a = decoders.msgpack_tf(msgpack.packb({"transforms": [transform_dict("map", "odom_frame")]}))[0]
    b = decoders.cdr_tf(cdr_encode_tf([transform_dict("map", "odom_frame")]))[0]
    assert a[0] is b[0] and a[1] is b[1]  # one str object per name, whichever wire brought it
    long_name = "n" * 300
    assert decoders.msgpack_tf(msgpack.packb({"transforms": [transform_dict(long_name, "c")]}))[0][0] == long_name
    assert long_name.encode() not in _FRAMES  # forged huge names are not kept
    assert decoders.FRAME_CACHE_SIZE == wire.FRAME_CACHE_SIZE
    names = [f"forged_{'x' * 200}_{i}" for i in range(15_000)]
    for i in range(0, len(names), 500):  # forged names by the thousand: read right, the cache starts over
        batch = names[i:i + 500]
        samples = decoders.msgpack_tf(msgpack.packb({"transforms": [transform_dict("p", c) for c in batch]}))
        assert [s[1] for s in samples] == batch
        assert [s[1] for s in decoders.cdr_tf(cdr_encode_tf([transform_dict("p", c) for c in batch]))] == batch
        held = sum(sys.getsizeof(k) + sys.getsizeof(v) for k, v in _FRAMES.items())
        assert len(_FRAMES) <= decoders.FRAME_CACHE_SIZE and held < 3_000_000, (i, held)



def test_a_fleets_frame_names_stay_interned() -> None:
    """100 robots x 51 frames in one listener (``tf_topic="/*/tf"``): every name decodes to the same str
    object message after message. A cache started over each time 4096 names were reached made a new
    str (and its hash, in the buffer's frame table) for every transform of such a fleet."""
    from zentf.ros import tf as ros_tf
    from zentf.core.constants import DEFAULT_MAX_FRAMES

    assert decoders.FRAME_CACHE_SIZE > DEFAULT_MAX_FRAMES  # whatever a buffer takes fits
    ros_tf.forget_frame_names()
    payloads = _fleet_payloads()
    _assert_fleet_names_interned(payloads)
    assert len(_FRAMES) == 100 * 51


def _fleet_payloads() -> list[tuple[bytes, bytes]]:
    robots = [[transform_dict(f"robot{i}/base_link", f"robot{i}/link_{j}") for j in range(50)] for i in range(100)]
    return [(msgpack.packb({"transforms": r}), cdr_encode_tf(r)) for r in robots]


def _assert_fleet_names_interned(payloads: list[tuple[bytes, bytes]]) -> None:
    first = [[(s[0], s[1]) for s in decoders.msgpack_tf(m)] for m, _ in payloads]
    for (m, c), names in zip(payloads, first):
        for decode, payload in ((decoders.msgpack_tf, m), (decoders.cdr_tf, c)):
            again = [(s[0], s[1]) for s in decode(payload)]
            assert all(a is b and p is q for (a, p), (b, q) in zip(again, names)), again[0]


def test_a_fleets_names_stay_interned_after_the_name_cache_starts_over() -> None:
    """Forged long names fill the names cache until it starts over: the memo in front of it forgets with
    it, so a fleet's names (decoded before and after) are again one str each, message after message. A
    memo that kept its names handed out strs the cache no longer held: a name it let go of (another name
    took its slot) came back as a second str."""
    from zentf.ros import tf as ros_tf

    ros_tf.forget_frame_names()
    payloads = _fleet_payloads()
    _assert_fleet_names_interned(payloads)  # the memo now holds most of the fleet's names
    forged = [transform_dict("p", f"forged_{'x' * 200}_{i}") for i in range(15_000)]
    for i in range(0, len(forged), 500):  # through the compiled path: the cache starts over on its own
        decoders.msgpack_tf(msgpack.packb({"transforms": forged[i:i + 500]}))
    assert len(_FRAMES) < 15_000
    _assert_fleet_names_interned(payloads)
    for m, _ in payloads:  # what the memo hands out is what the cache holds
        for parent, child, *_rest in decoders.msgpack_tf(m):
            assert _FRAMES.get(parent.encode()) is parent and _FRAMES.get(child.encode()) is child

# ------------------------------------------------------------------ anything else: same as before

def transform_dict(parent: str = "world", child: str = "c", sec: int = 1, nsec: int = 0, x: float = 1.0) -> dict:
    return {"header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": parent}, "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": 2.0, "z": 3.0},
                          "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}


def mutations(payload: bytes, rng: random.Random, n: int) -> list[bytes]:
    """Truncations, flipped bytes, inserted and deleted bytes of a good payload."""
    out = [payload[:i] for i in range(len(payload))]
    for _ in range(n):
        b = bytearray(payload)
        kind = rng.randrange(4)
        at = rng.randrange(len(b))
        if kind == 0:
            b[at] = rng.randrange(256)
        elif kind == 1:
            b[at] ^= 1 << rng.randrange(8)
        elif kind == 2:
            b[at:at] = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 4)))
        else:
            del b[at:at + rng.randrange(1, 4)]
        out.append(bytes(b))
    return out


def agrees_with_the_python_path(payloads: list[bytes], compiled, python, ingest) -> list:
    """For each payload: the compiled decoder reads exactly what the Python path reads with nothing wrong,
    or doubts it; the ingest's result is the Python path's (counts, problem, or its exception)."""
    results = []
    for p in payloads:
        fast = compiled(p)
        try:
            samples, malformed, problem = python(p)
        except (ValueError, CdrError) as e:
            assert fast is None, p
            expected = f"{type(e).__name__}: {e}"
        else:
            if fast is not None:
                assert (norm(fast), malformed, problem) == (norm(samples), 0, None), p
            expected = (len(samples), 0, malformed, problem)
        try:
            got = ingest(p, Recorder(), "/a", False)
        except (ValueError, CdrError) as e:
            got = f"{type(e).__name__}: {e}"
        assert got == expected, p
        results.append(got)
    assert all("\n" not in str(r) for r in results)
    return results


def test_msgpack_malformed_payloads_give_the_python_paths_problems() -> None:
    rng = random.Random(15)
    good = msgpack.packb({"transforms": [transform_dict("world", "a", 3, 5), transform_dict("a", "bé", 4, 6, -2.5)]})
    lying = [
        msgpack.packb({"transforms": [transform_dict(sec=-1)]}),                      # stamp out of range
        msgpack.packb({"transforms": [transform_dict(nsec=NS)]}),
        msgpack.packb({"transforms": [transform_dict(sec=2**63)]}),
        msgpack.packb({"transforms": [transform_dict(sec=True)]}),                    # a bool is not an int
        msgpack.packb({"transforms": [transform_dict(x=True)]}),                      # ... nor a number (msgspec)
        msgpack.packb({"transforms": [transform_dict(sec=1.0)]}),
        msgpack.packb({"transforms": [{**transform_dict(), "child_frame_id": b"bin"}]}),
        msgpack.packb({"transforms": [{**transform_dict(), "child_frame_id": None}]}),
        msgpack.packb({"transforms": [{"header": {}, "child_frame_id": "c"}]}),       # missing fields
        msgpack.packb({"transforms": [transform_dict()], "x": msgpack.ExtType(1, b"e")}),
        msgpack.packb({b"transforms": [transform_dict()]}, use_bin_type=True),        # bin key
        msgpack.packb({"transforms": None}), msgpack.packb([]), msgpack.packb({"transforms": {}}),
        msgpack.packb({"transforms": [transform_dict()]}) + b"\x00",                   # trailing bytes
        b"\x81\xaatransforms\x91" + msgpack.packb(transform_dict())[:-1],
        msgpack.packb({"transforms": [transform_dict("\udcff", "c")]}, unicode_errors="surrogateescape"),
    ]
    payloads = [good, *lying, *mutations(good, rng, 3000)]
    results = agrees_with_the_python_path(payloads, decoders.msgpack_tf, wire.tf_samples, wire.ingest_tf)
    problems = [r for r in results if isinstance(r, str) or r[2]]
    assert len(problems) > 1000  # the mutations did hit


def test_cdr_malformed_payloads_give_the_python_paths_problems() -> None:
    rng = random.Random(14)
    good = cdr_encode_tf([transform_dict("world", "a", 3, 5), transform_dict("a", "bé", 4, 6, -2.5)])
    no_nul = bytearray(good)
    no_nul[8 + 8 + 4 + 5] = ord("!")  # after count, stamp, length and "world": its NUL replaced (malformed)
    lying = [bytes(no_nul), good[:4] + struct.pack("<I", 10**6) + good[8:], b"\x00\x00\x00\x00" + good[4:],
             good[:4] + struct.pack("<I", 0) + good[8:], struct.pack("<4sI", b"\x00\x01\x00\x00", 1) + b"\x00" * 72]
    payloads = [good, *lying, *mutations(good, rng, 3000)]
    results = agrees_with_the_python_path(payloads, decoders.cdr_tf, tf_samples, profile.Ros2Profile().ingest_tf)
    assert results[1] == (1, 0, 1, "transforms[0]: frame_id has no closing NUL")
    assert len([r for r in results if isinstance(r, str) or r[2]]) > 1000


def test_payloads_that_are_not_bytes_take_the_python_path() -> None:
    good = msgpack.packb({"transforms": [transform_dict()]})
    assert decoders.msgpack_tf(bytearray(good)) is None and decoders.cdr_tf(memoryview(cdr_encode_tf([]))) is None
    core = Recorder()
    assert wire.ingest_tf(bytearray(good), core, "/a", False) == (1, 0, 0, None)


# ------------------------------------------------------------------ the listener's compiled ingest

def listener_ingest(wire_name: str, compiled: bool, clock: Clock, is_static: bool = False):
    """(ingest(payload, authority), buffer, guard) as a TransformListener builds them, without Zenoh."""
    buffer = BufferCore()
    guard = _FutureGuard(buffer, clock, 5 * NS, RateLimitedLogger(logging.getLogger("zentf.transport.listener")))
    prof = profile.make_profile(wire_name)
    target = buffer if is_static else guard
    if compiled:  # what the listener asks the profile for
        return prof.tf_ingest(target, buffer, None if is_static else guard.now_ns, guard.tolerance_ns,
                              is_static), buffer, guard
    return (lambda p, a: prof.ingest_tf(p, target, a, is_static)), buffer, guard


@pytest.mark.parametrize("wire_name", ["zentf", "ros2"])
@pytest.mark.parametrize("is_static", [False, True])
def test_compiled_listener_ingest_equals_the_python_path(wire_name: str, is_static: bool,
                                                         caplog: pytest.LogCaptureFixture) -> None:
    """Decode, future-stamp guard and insert in one compiled call: same results, buffer, refusals and
    log lines as the profile's ingest_tf through the listener's _FutureGuard."""
    rng = random.Random(10)
    clock = Clock(sim=True)
    clock.set_sim_time(1000 * NS)
    encode = cdr_encode_tf if wire_name == "ros2" else (lambda items: msgpack.packb({"transforms": items}))
    payloads = []
    for i in range(300):
        sec = rng.choice([999, 1000, 1004, 1006, 2000])  # now is 1000 s, tolerance 5 s
        items = [transform_dict("world", f"c{rng.randrange(4)}", sec, rng.randrange(NS), rng.uniform(-1, 1))
                 for _ in range(rng.randrange(0, 4))]
        payload = encode(items)
        if rng.random() < 0.2 and payload:
            payload = mutations(payload, rng, 1)[-1]
        payloads.append(payload)
    runs = []
    for compiled in (True, False):
        ingest, buffer, guard = listener_ingest(wire_name, compiled, clock, is_static)
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="zentf"):
            results = []
            for p in payloads:
                try:
                    results.append(ingest(p, "/a"))
                except (ValueError, CdrError) as e:
                    results.append(str(e))
        frames = [(d["frame"], d["parent"], d["samples"], d["most_recent_transform"].nanoseconds,
                   d["oldest_transform"].nanoseconds, repr(buffer.lookup_transform(d["parent"], d["frame"], 0)))
                  for d in buffer.frame_info()]
        runs.append((results, guard.refused, frames, [r.getMessage() for r in caplog.records]))
    assert runs[0] == runs[1]
    assert (runs[0][1] > 0) != is_static  # the guard did refuse samples (not on tf_static)
    assert len(runs[0][2]) == 4 and any(isinstance(r, tuple) and r[2] for r in runs[0][0])  # stored; some malformed


# ------------------------------------------------------------------ interop: a real ROS 2 bag

def test_every_tf_message_of_a_real_bag_decodes_like_rosbags() -> None:
    """tests/data/nav2_turtlebot.mcap (a nav2 TurtleBot run recorded by ROS 2, tests/data/README.md): every /tf and
    /tf_static payload is read by the compiled decoder (no doubt) to the values rosbags deserializes."""
    typesys = pytest.importorskip("rosbags.typesys")
    reader_mod = pytest.importorskip("mcap.reader")
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    transforms = 0
    with (Path(__file__).parent / "data" / "nav2_turtlebot.mcap").open("rb") as f:
        for _, _, message in reader_mod.make_reader(f).iter_messages(topics=["/tf", "/tf_static"]):
            ref = store.deserialize_cdr(message.data, "tf2_msgs/msg/TFMessage")
            expected = [(t.header.frame_id, t.child_frame_id, t.header.stamp.sec * NS + t.header.stamp.nanosec,
                         t.transform.translation.x, t.transform.translation.y, t.transform.translation.z,
                         t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                         t.transform.rotation.w) for t in ref.transforms]
            assert decoders.cdr_tf(bytes(message.data)) == expected
            transforms += len(expected)
    assert transforms == 7313


# ------------------------------------------------------------------ zentf's own layout (canonical fast path)

def canonical(parent: str, child: str, sec: int, nsec: int, values: list) -> dict:
    """A TransformStamped dict in the field order zentf's encoders write (wire.tf_to_plain's)."""
    return {"header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": parent}, "child_frame_id": child,
            "transform": {"translation": dict(zip("xyz", values[:3])), "rotation": dict(zip("xyzw", values[3:]))}}


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(items=st.lists(st.tuples(names | st.text(min_size=32, max_size=40), names,
                                st.integers(0, MAX_SEC - 1) | st.integers(-5, -1) | st.integers(MAX_SEC, 2**64 - 1),
                                st.integers(0, NS - 1) | st.integers(NS, 2**32 - 1),
                                st.lists(numbers, min_size=7, max_size=7)), max_size=6),
       single_float=st.booleans())
def test_canonical_layout_reads_like_the_general_path(items: list, single_float: bool) -> None:
    """The whole-key-run path reads every element in zentf's layout (any number encoding, str8 names,
    stamps in or out of range) exactly as the key-by-key path does, and doubts what it doubts."""
    try:
        payload = msgpack.packb({"transforms": [canonical(*i) for i in items]}, use_single_float=single_float)
    except OverflowError:
        assume(False)
    before = decoders.canonical_hits()
    fast, general = decoders.msgpack_tf(payload), decoders.msgpack_tf(payload, canonical=False)
    assert norm(fast) == norm(general)
    if fast is not None:
        assert decoders.canonical_hits() - before == len(items)  # every element took the fast path
        if not single_float:
            assert norm(fast) == norm([(p, c, s * NS + n, *map(float, vals)) for p, c, s, n, vals in items])


def test_zentf_encoders_take_the_canonical_path_and_mutations_agree() -> None:
    """What wire.encode_tf writes (template and dict paths) is read by the fast path; truncated, flipped,
    inserted and deleted bytes give the key-by-key path's answer (None or the same samples)."""
    ts = [TransformStamped(Header(Time(sec=1_700_000_000, nanosec=i), "map"), f"link_{'é' * i}",
                           Transform(Vector3(1.0 * i, -2.0, 3.5), Quaternion(0.0, 0.0, 0.6, 0.8))) for i in range(3)]
    plain = [wire.tf_to_plain(t) for t in ts]
    plain[1]["transform"]["translation"]["x"] = 7  # an int where zentf writes a float64 (the dict path)
    for payload in (wire.encode_tf(ts), wire.encode_tf(ts[:1]), wire.encode_tf(plain)):
        before = decoders.canonical_hits()
        got = decoders.msgpack_tf(payload)
        assert decoders.canonical_hits() - before == len(got) > 0
        assert norm(got) == norm(decoders.msgpack_tf(payload, canonical=False))
    rng = random.Random(1515)
    good = wire.encode_tf(ts)
    taken = 0
    for p in mutations(good, rng, 4000):
        fast = decoders.msgpack_tf(p)
        assert norm(fast) == norm(decoders.msgpack_tf(p, canonical=False)), p
        taken += fast is not None
    assert taken > 100  # some mutations (a changed value, a name) are still well-formed


# ------------------------------------------------------------------ the future guard's clock reads

class CountingClock(Clock):
    """A sim clock that counts its reads (the guard's calls to now_ns)."""

    def __init__(self) -> None:
        super().__init__(sim=True)
        self.reads = 0

    def now_ns(self) -> int:
        self.reads += 1
        return super().now_ns()


def test_the_guard_refuses_only_against_a_fresh_clock_read() -> None:
    """TfIngest reads the clock once for a run of stamps below the last read's limit; a stamp beyond it
    is compared with a fresh read (the clock moved on: accepted; it did not: refused and logged by the
    listener's guard), and after reset_clock (the listener's jump-back callback) the next stamp too."""
    clock = CountingClock()
    clock.set_sim_time(1000 * NS)
    ingest, buffer, guard = listener_ingest("zentf", True, clock)
    encode = lambda sec, child="c": msgpack.packb({"transforms": [transform_dict("world", child, sec, 0)]})  # noqa: E731
    assert ingest(encode(1001), "/a") == (1, 0, 0, None) and clock.reads == 1
    for sec in range(1001, 1005):
        assert ingest(encode(sec, f"d{sec}"), "/a")[0] == 1
    assert clock.reads <= 2  # (a second read only if the machine stalled 0.1 s)
    clock.set_sim_time(1010 * NS)
    reads = clock.reads
    assert ingest(encode(1012), "/a") == (1, 0, 0, None) and clock.reads == reads + 1  # beyond 1005: re-read
    reads = clock.reads
    assert ingest(encode(1016), "/a")[0] == 0 and guard.refused == 1  # (the guard reads the clock too)
    clock.set_sim_time(100 * NS)  # backwards: the listener calls reset_clock
    ingest.reset_clock()
    assert ingest(encode(1013, "e"), "/a")[0] == 0 and guard.refused == 2


def test_a_listener_forgets_its_clock_read_when_the_clock_jumps_back(node_options) -> None:
    """The listener's jump-back callback resets its compiled ingests: a stamp ahead of the new sim time is
    refused at once, not accepted against the read taken before the jump."""
    from zentf.transport.buffer import Buffer
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node

    with Node("jumper", options=node_options.with_(params={"use_sim_time": True})) as node:
        buf = Buffer(node=node)
        tl = TransformListener(buf, node)
        clock = node.get_clock()
        clock.set_sim_time(1000 * NS)
        static_ingest, tf_ingest = tl._ingests  # (tf_static's first)
        payload = lambda sec, child: msgpack.packb({"transforms": [transform_dict("world", child, sec, 0)]})  # noqa: E731
        assert tf_ingest(payload(1003, "before"), "/a")[0] == 1
        clock.set_sim_time(100 * NS)  # jump back: buffer cleared, clock read forgotten
        assert tf_ingest(payload(1003, "after"), "/a")[0] == 0
        assert tl.stats()["future"] == 1 and not buf.frame_exists("after")


# ------------------------------------------------------------------ the listener's compiled handler

def test_the_encoding_is_checked_when_the_payload_is_not_a_tfmessage(node_options, zenoh_session, caplog) -> None:
    """The handler reads a sample's encoding only when the payload is not a well-formed TFMessage: a
    Point labelled as a Point on tf gets the type check's one line (naming type and sender); a payload
    that is a TFMessage applies whatever its label."""
    from conftest import matched_tf_publisher
    from zentf.transport.buffer import Buffer
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node

    with Node("labels", options=node_options) as node, caplog.at_level(logging.WARNING, logger="zentf"):
        buf = Buffer(node=node)
        tl = TransformListener(buf, node)
        pub = matched_tf_publisher(zenoh_session, node, "geometry_msgs/msg/Point")
        pub.put(msgpack.packb({"x": 1.0, "y": 2.0, "z": 3.0}), attachment=b"/liar")
        pub.put(wire.encode_tf([TransformStamped(Header(node.get_clock().now(), "world"), "labelled", Transform(
            Vector3(1.0, 0.0, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0)))]), attachment=b"/liar")
        assert buf.can_transform("world", "labelled", Time(), timeout=30)  # one sender: the Point came first
        assert tl.stats()["bad_messages"] == 1 and tl.stats()["transforms"] == 1
        lines = [r.getMessage() for r in caplog.records if "dropped bad message" in r.getMessage()]
        assert len(lines) == 1 and "wrong type geometry_msgs/msg/Point" in lines[0] and "/liar" in lines[0], lines


# ---------------------------------------------------------------- JointState, out

def test_compiled_joint_state_encoder_writes_the_generic_bytes() -> None:
    """joint_state_encoder.js_payload (wire.encode's JointState path) gives msgpack.packb(msg.to_dict())'s bytes when
    every number is a float, the same decoded message when some are ints, and None (the generic path)
    for anything unusual; the cached name list is not reused after the names change."""
    from zentf.core.messages import Header as H, JointState
    from zentf.transport.ingest.joint_state_encoder import js_payload

    rng = random.Random(12)
    for i in range(2000):
        n = rng.choice([0, 1, 15, 16, 100, 3] + ([70_000] if i % 400 == 0 else []))
        names = [("j%dé" % k)[: rng.randrange(1, 5)] for k in range(n)]  # often equal to the last ones
        ns = rng.choice([0, 127 * NS, 255 * NS + 5, 2**32 * NS + 7, rng.randrange(2**63)])
        msg = JointState(H(Time(nanoseconds=ns), rng.choice(["", "base", "x" * 40])), names,
                         [rng.uniform(-10, 10) for _ in range(n)], [math.nan] * rng.choice([0, n]),
                         [-math.inf] * rng.choice([0, n]))
        assert js_payload(msg) == msgpack.packb(msg.to_dict())
    ints = JointState(H(Time(nanoseconds=5)), ["a", "b"], [1, 2.5], [0], [])
    assert msgpack.unpackb(js_payload(ints)) == msgpack.unpackb(msgpack.packb(ints.to_dict()))
    for odd in (JointState(H(Time()), ["a"], [True]), JointState(H(Time()), [5], [1.0]),  # type: ignore[list-item]
                JointState(H(Time()), ["\udc80"], [1.0]), JointState(H(Time()), ("a",), [1.0]),  # type: ignore[arg-type]
                JointState(H(Time(), 5), ["a"], [1.0]), JointState(H(Time()), ["a"], (1.0,)),  # type: ignore[arg-type]
                JointState(H(Time()), ["a"], [2**2000])):
        assert js_payload(odd) is None
        try:
            want = msgpack.packb(odd.to_dict())
        except Exception as e:  # the generic path's own error, as before
            with pytest.raises(type(e)):
                wire.encode(odd)
        else:
            assert wire.encode(odd) == want


# ---------------------------------------------------------------- TransformStamped, out on ROS 2's wire

def test_compiled_cdr_sender_writes_the_encoders_bytes_and_rmw_zenohs_attachment() -> None:
    """tf_encoder.cdr_ts_payload gives zentf.ros.encode_tf's bytes for one TransformStamped (names of any
    length and script, any stamp CDR holds) and None for what that encoder must judge; OneTransformSenderCdr
    puts it with rmw_zenoh's attachment: the publisher's next sequence number, the time, its GID."""
    import itertools
    import time

    from zentf.transport.ingest.tf_encoder import OneTransformSenderCdr, cdr_ts_payload
    from zentf.transport.wire.profiles import parse_ros2_attachment

    rng = random.Random(31)
    for _ in range(3000):
        parent = "".join(rng.choice("ab/é_π") for _ in range(rng.randrange(0, 12)))
        child = "".join(rng.choice("xy/ç") for _ in range(rng.randrange(0, 9)))
        ns = rng.choice([0, NS - 1, (2**31 - 1) * NS + NS - 1, rng.randrange(2**31 * NS)])
        ts = TransformStamped(Header(Time(nanoseconds=ns), parent), child, Transform(
            Vector3(rng.uniform(-9, 9), math.inf, -0.0), Quaternion(0.0, math.nan, 0.6, 0.8)))
        assert cdr_ts_payload(ts) == cdr_encode_tf([ts]), (parent, child, ns)
    late = TransformStamped(Header(Time(nanoseconds=2**31 * NS), "a"), "b")  # beyond int32 seconds
    assert cdr_ts_payload(late) is None and cdr_ts_payload(transform_dict()) is None
    sent, slow = [], []
    seq = itertools.count(1)
    sender = OneTransformSenderCdr(lambda p, attachment: sent.append((p, attachment)), seq, b"G" * 16, slow.append)
    one = TransformStamped(Header(Time(sec=5), "world"), "c", Transform(Vector3(1.0, 2.0, 3.0),
                                                                           Quaternion(0.0, 0.0, 0.0, 1.0)))
    before = time.time_ns()
    sender(one)
    sender(one)
    sender([one])  # a list: the Python method
    assert slow == [[one]] and next(seq) == 3
    assert [p for p, _ in sent] == [cdr_encode_tf([one])] * 2
    atts = [parse_ros2_attachment(a) for _, a in sent]
    assert [a[0] for a in atts] == [1, 2] and all(a[2] == b"G" * 16 for a in atts)
    assert all(before <= a[1] <= time.time_ns() for a in atts)


def test_the_ros2_sender_key_is_the_publisher_gid() -> None:
    """Ros2Profile.sender_of (read in C by the listener's thread): the GID of rmw_zenoh's attachment, whose
    sequence number and time change with every sample; any other attachment is its own key."""
    from zentf.transport.wire.profiles import Ros2Profile, ros2_attachment

    key = Ros2Profile().sender_of
    rng = random.Random(33)
    for _ in range(500):
        gid = bytes(rng.randrange(256) for _ in range(16))
        assert key(ros2_attachment(rng.randrange(2**62), rng.randrange(2**62), gid)) == gid
        other = bytes(rng.randrange(256) for _ in range(rng.choice([0, 1, 32, 33, 34])))
        if not (len(other) == 33 and other[16] == 16):
            assert key(other) == other
