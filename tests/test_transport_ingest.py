"""The listener's batch paths, in-process: set_transforms_raw == set_transform one by one, and the
broadcaster's byte-template encoder == packing the plain dict (Zenoh itself is covered elsewhere)."""
from __future__ import annotations

import copy
import itertools
import logging
import math
import random
import sys

import msgpack
import pytest

from zentf.transport.ingest import decoders, tf_encoder
from zentf.transport.wire import codec as wire
from zentf.core.buffer_core import BufferCore
from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
from zentf.core.time import Time

S = 1_000_000_000
FRAMES = ["world", "base", "/base", "arm", "", "cam", "tool"]


def random_sample(rng: random.Random) -> tuple:
    """Mostly good samples on a small tree, plus every kind tf2 refuses or takes the slow path for."""
    parent, child = rng.choice(FRAMES), rng.choice(FRAMES)
    stamp = rng.choice([rng.randrange(0, 50) * S // 10, rng.randrange(0, 50) * S // 10, -1, 3 * S])
    tx, ty, tz = (rng.uniform(-5, 5) for _ in range(3))
    q = rng.choice([(0.0, 0.0, 0.0, 1.0), (0.0, 0.0, math.sin(0.3), math.cos(0.3)), (0.0, 0.0, 0.0, 2.0),
                    (0.0, 0.0, 0.0, 1.0)])
    if rng.random() < 0.05:
        tx = float("nan")
    return (parent, child, stamp, tx, ty, tz, *q)


def as_msg(s: tuple) -> TransformStamped:
    return TransformStamped(Header(Time(nanoseconds=max(s[2], 0)), s[0]), s[1],
                            Transform(Vector3(*s[3:6]), Quaternion(*s[6:10])))


@pytest.mark.parametrize("seed", range(6))
def test_batch_insert_matches_one_by_one(seed: int, caplog: pytest.LogCaptureFixture) -> None:
    rng = random.Random(seed)
    samples = [random_sample(rng) for _ in range(400)]
    samples = [s for s in samples if s[2] >= 0]  # Time() cannot hold a negative stamp; raw path below
    one, batch = BufferCore(cache_time=2.0), BufferCore(cache_time=2.0)
    calls: list[int] = []
    batch.add_insert_callback(lambda: calls.append(1))
    with caplog.at_level(logging.WARNING, logger="zentf"):
        accepted_one = [one.set_transform(as_msg(s), "/auth", s[1] == "tool") for s in samples]
        logs_one = [r.getMessage() for r in caplog.records]
        caplog.clear()
        accepted_batch = batches = 0
        for i in range(0, len(samples), 37):  # runs of one static flag, in order
            for is_static, run in itertools.groupby(samples[i:i + 37], key=lambda s: s[1] == "tool"):
                batches += 1
                accepted_batch += batch.set_transforms_raw(list(run), "/auth", is_static)
        logs_batch = [r.getMessage() for r in caplog.records]
    assert accepted_batch == sum(accepted_one)
    assert logs_batch == logs_one  # same refusals, same words, same order
    assert 0 < len(calls) <= batches < len(samples) // 2  # once per batch, not per sample
    assert batch.all_frames_as_yaml(0) == one.all_frames_as_yaml(0)
    for target in ("world", "arm", "cam"):
        for source in ("base", "tool", "cam"):
            for t in (0, 1.25, 3.0):
                a = one.can_transform(target, source, t, True)
                assert batch.can_transform(target, source, t, True) == a
                if a[0]:
                    x = one.lookup_transform(target, source, t).transform.translation
                    y = batch.lookup_transform(target, source, t).transform.translation
                    assert (x.x, x.y, x.z) == (y.x, y.y, y.z)


def test_batch_insert_negative_stamp_and_lock_released(caplog: pytest.LogCaptureFixture) -> None:
    core = BufferCore()
    q = (0.0, 0.0, 0.0, 1.0)
    with caplog.at_level(logging.ERROR, logger="zentf"):
        n = core.set_transforms_raw([("w", "a", S, 1.0, 0.0, 0.0, *q), ("w", "a", -5, 1.0, 0.0, 0.0, *q),
                                     ("w", "a", 2 * S, 1.0, 0.0, 0.0, *q)], "/x")
    assert n == 2
    assert any("negative" in r.getMessage() for r in caplog.records)
    assert core._lock.acquire(blocking=False)  # never left held
    core._lock.release()
    assert core.lookup_transform("w", "a", 2).transform.translation.x == 1.0


def plain_payload(items: list) -> bytes:
    return wire.pack({"transforms": [wire.tf_to_plain(t) for t in items]})


def tsm(ns: int, x: object = 1.0, parent: str = "world", child: str = "lat", w: object = 1) -> TransformStamped:
    return TransformStamped(Header(Time(nanoseconds=ns), parent), child,
                            Transform(Vector3(x, 2.0, 3.0), Quaternion(0, 0, 0, w)))  # type: ignore[arg-type]


@pytest.mark.parametrize("items", [
    [tsm(1_700_000_000_123_456_789)], [tsm(0)], [tsm(2**32 * S + 5)], [tsm(5, x="bad")], [tsm(5, w=True)],
    [tsm(7, parent="é" * 40, child="c" * 300)], [tsm(i) for i in range(20)], [tsm(i) for i in range(70_000)],
    [wire.tf_to_plain(tsm(3)), tsm(4)], [],
], ids=["now", "zero", "sec>=2^32", "not-a-number", "bool", "long-names", "array16", "array32", "mixed", "empty"])
def test_encode_tf_fast_path_decodes_like_plain(items: list) -> None:
    assert msgpack.unpackb(wire.encode_tf(items)) == msgpack.unpackb(plain_payload(items))


def _no_nan(value: object) -> object:
    """A decoded message with NaN spelled out (NaN != NaN would fail every comparison)."""
    if isinstance(value, dict):
        return {k: _no_nan(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_no_nan(v) for v in value]
    return "nan" if isinstance(value, float) and math.isnan(value) else value


def test_compiled_transform_encoder_writes_what_the_dict_path_writes() -> None:
    """tf_encoder.ts_payload / ts_item (send_transform's path) against msgpack packing tf_to_plain's dicts."""
    rng = random.Random(15)
    odd = [float("nan"), float("inf"), -float("inf"), -0.0, 5e-324, 1.7976931348623157e308, 7, True]
    for i in range(3000):
        name = "".join(rng.choice("ab/_é π") for _ in range(rng.choice([0, 1, 31, 32, 255, 256, rng.randrange(60)])))
        t = tsm(rng.choice([0, rng.randrange(2**32 * S), 2**32 * S - 1]), x=rng.choice(odd + [rng.uniform(-1e9, 1e9)]),
                parent=name, child=name[::-1] + str(i % 7), w=rng.choice(odd + [1.0]))
        want = _no_nan(msgpack.unpackb(plain_payload([t])))
        assert _no_nan(msgpack.unpackb(tf_encoder.ts_payload(t))) == want
        assert _no_nan(msgpack.unpackb(b"\x81\xaatransforms\x91" + tf_encoder.ts_item(t))) == want
    # the same name objects again (the writer's last-names memo) and in turns with others: each call
    # writes its own message's names
    a, b, c = "base", "arm" + str(rng.random()), "arm" + str(rng.random())
    msgs = [tsm(i * S, parent=a, child=b), tsm(i * S, parent=a, child=c), tsm(i * S, parent=b, child=a)]
    for i in range(30):
        t = msgs[(i // 2) % 3]
        t.header.stamp = Time(nanoseconds=i * S + 1)
        assert _no_nan(msgpack.unpackb(tf_encoder.ts_payload(t))) == _no_nan(msgpack.unpackb(plain_payload([t])))
    # fields of other types than the messages' own (a Vector3 subclass, an object with x, y, z): read by
    # name, as the dict path reads them
    class MyVector(Vector3):
        pass

    class Point3:
        x, y, z = 0.5, -1.5, 2.5

    for tr in (MyVector(1.0, 2.0, 3.0), Point3()):
        t = tsm(9 * S)
        t.transform.translation = tr  # type: ignore[assignment]
        want = _no_nan(msgpack.unpackb(plain_payload([t])))
        assert _no_nan(msgpack.unpackb(tf_encoder.ts_payload(t))) == want
        assert want["transforms"][0]["transform"]["translation"] == {"x": tr.x, "y": tr.y, "z": tr.z}
    # unusual: left to the dict path (which packs it or says why not)
    for t in (tsm(2**32 * S), tsm(5, x="bad"), tsm(5, parent="\udc80"), wire.tf_to_plain(tsm(5)),
              TransformStamped(Header(Time(nanoseconds=5), 5), "a")):  # type: ignore[arg-type]
        assert tf_encoder.ts_payload(t) is None and tf_encoder.ts_item(t) is None


def test_encode_tf_nan_and_ingest_round_trip() -> None:
    core = BufferCore()
    items = [tsm(S, x=float("nan")), tsm(2 * S, x=0.5), tsm(3 * S, child="other")]
    accepted, rejected, malformed, _ = wire.ingest_tf(wire.encode_tf(items), core, "/a", False)
    assert (accepted, rejected, malformed) == (2, 1, 0)
    assert core.lookup_transform("world", "lat", 2).transform.translation.x == 0.5


class Recorder:
    """A BufferCore stand-in that keeps what ingest_tf hands over."""

    def __init__(self) -> None:
        self.samples: list = []

    def set_transforms_raw(self, samples: list, authority: str, is_static: bool) -> int:
        self.samples.append([(s[0], s[1], s[2], *map(repr, s[3:])) for s in samples])  # repr: nan == nan
        return len(samples)


ODD_VALUES = [True, False, b"bytes", "str", None, 0, 1, 2**40, 2**63 + 1, -1, -(2**40), 1.5, float("nan"),
              float("inf"), {}, [], [1.0], {"x": 1.0}, msgpack.ExtType(1, b"x"), "é/π", ""]
PATHS = [("header", "stamp", "sec"), ("header", "stamp", "nanosec"), ("header", "stamp"), ("header", "frame_id"),
         ("child_frame_id",), ("transform", "translation", "x"), ("transform", "rotation", "w"),
         ("transform", "rotation"), ("header",), ("extra",), ("header", "stamp", "extra")]


def mutated_payload(rng: random.Random) -> bytes:
    items = [wire.tf_to_plain(tsm(rng.randrange(0, 10**19), x=rng.uniform(-1, 1), child=f"c{rng.randrange(5)}"))
             for _ in range(rng.randrange(0, 6))]
    for _ in range(rng.randrange(0, 3)):
        if not items:
            break
        d = rng.choice(items)
        path = rng.choice(PATHS)
        for k in path[:-1]:
            d = d.get(k) if isinstance(d, dict) else None
        if not isinstance(d, dict):
            continue
        if rng.random() < 0.2:
            d.pop(path[-1], None)
        else:
            d[path[-1]] = copy.deepcopy(rng.choice(ODD_VALUES))
    msg: object = {"transforms": items}
    if rng.random() < 0.05:
        msg = rng.choice([[], {"transforms": None}, {"transforms": items, 1: 2}, {b"transforms": items}])
    data = msgpack.packb(msg, use_bin_type=rng.random() < 0.8)
    if rng.random() < 0.1 and data:
        data = data[:rng.randrange(len(data))]
    return data


def test_compiled_decoder_agrees_with_per_element_path() -> None:
    """Whatever the compiled decoder accepts, the per-element path reads the same with nothing wrong;
    anything else ingest_tf reads with the per-element path (its counts, its problem, its exception)."""
    rng = random.Random(7)
    payloads = [mutated_payload(rng) for _ in range(3000)]
    ingested, read = Recorder(), Recorder()
    results = []
    for p in payloads:
        try:
            results.append(wire.ingest_tf(p, ingested, "/a", False))
        except ValueError as e:
            results.append(str(e))
            continue
        samples, malformed, problem = wire.tf_samples(p)
        fast = decoders.msgpack_tf(p)
        if fast is not None:
            assert (malformed, problem) == (0, None)
            assert [(*s[:3], *map(repr, s[3:])) for s in fast] == [(*s[:3], *map(repr, s[3:])) for s in samples]
        assert results[-1] == (len(samples), 0, malformed, problem)
        if samples:
            read.set_transforms_raw(samples if fast is None else fast, "/a", False)
    assert ingested.samples == read.samples
    assert sum(r[2] for r in results if isinstance(r, tuple)) > 100  # the mutations did hit


def test_per_element_path_keeps_few_frame_names(monkeypatch: pytest.MonkeyPatch) -> None:
    """Forged names on the per-element path (a malformed element in every message sends it there) are read
    right, but the decoded-name cache stays within FRAME_CACHE_SIZE (it kept 100,000: ~60 MB of long names)."""
    monkeypatch.setattr(wire, "_FRAME_CACHE", {})
    rec = Recorder()
    n = 0
    for m in range(30):
        items = [wire.tf_to_plain(tsm(S, child=f"forged_{'x' * 200}_{m * 500 + i}")) for i in range(500)]
        items.append({"header": {}})  # malformed: the whole message takes the per-element path
        accepted, _, malformed, _ = wire.ingest_tf(wire.pack({"transforms": items}), rec, "/a", False)
        assert (accepted, malformed) == (500, 1)
        n += accepted
        held = sum(sys.getsizeof(k) + sys.getsizeof(v) for k, v in wire._FRAME_CACHE.items())
        assert len(wire._FRAME_CACHE) <= wire.FRAME_CACHE_SIZE and held < 3_000_000, (m, held)
    assert [s[1] for batch in rec.samples for s in batch] == [f"forged_{'x' * 200}_{i}" for i in range(n)]


def test_a_sender_tail_names_each_sender_by_its_own_bytes() -> None:
    """ROS 2's queue key is the GID after rmw_zenoh's per-sample fields: a flood's sender gets its key
    again without a copy, and a different sender of the same attachment size never gets the last one's."""
    from zentf.transport.ingest.handler import SenderTail

    tail = SenderTail(33, 16, 16)
    a = bytes(range(16)) + b"\x10" + b"A" * 16
    a2 = bytes(range(1, 17)) + b"\x10" + b"A" * 16   # the same sender, the next sequence number
    b = bytes(range(16)) + b"\x10" + b"A" * 15 + b"B"
    first = tail(a)
    assert first == b"A" * 16
    assert tail(a2) is first                          # the same GID: the same key object, no slice
    assert tail(b) == b"A" * 15 + b"B"                # another GID: its own bytes
    assert tail(a) == b"A" * 16
    odd = bytes(range(16)) + b"\x11" + b"A" * 16      # no marker: the whole attachment is the key
    assert tail(odd) == odd
    assert tail(b"short") == b"short"
