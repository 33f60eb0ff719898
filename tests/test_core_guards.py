"""BufferCore under hostile input (issue 10): rate-limited refusals, escaped names in log lines, bounds on
frames and frame ids, non-finite translations, stamps beyond int64 nanoseconds.

In-process on purpose: BufferCore has no Zenoh (tests/test_transport_abuse.py drives the same cases
through a real listener from another process).
"""
from __future__ import annotations

import logging

import pytest

from zentf.core.buffer_core import BufferCore
from zentf.core.ratelimit import ARG_LIMIT, RateLimitedLogger
from zentf.core.text import printable

S = 1_000_000_000
Q = (0.0, 0.0, 0.0, 1.0)
NAN, INF = float("nan"), float("inf")
LOGGER = "zentf.core.buffer_core"


class FakeClock:
    """Monotonic seconds the test moves by hand (the rate limiter's period passes without sleeping)."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def lines(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records]


# ------------------------------------------------------------------ point 5: rate-limited warnings

def test_refusals_are_rate_limited_per_reason_and_sender_with_a_suppressed_count(caplog) -> None:
    core = BufferCore()
    clock = core._warn.clock = FakeClock()
    core.set_transform_raw("w", "a", 100 * S, 0.0, 0.0, 0.0, *Q, "/good")
    with caplog.at_level(logging.WARNING, LOGGER):
        for i in range(5000):
            assert not core.set_transform_raw("w", "a", S + i, NAN, 0.0, 0.0, *Q, "/flooder")
            assert not core.set_transform_raw("w", "a", S + i, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0, "/flooder")
            assert not core.set_transform_raw("w", "a", 100 * S, 1.0, 0.0, 0.0, *Q, "/flooder")  # repeated
            assert not core.set_transform_raw("w", "a", S, 1.0, 0.0, 0.0, *Q, "/other")        # old
        first = lines(caplog)
        caplog.clear()
        clock.now += 5.0  # the period is over: the next line of a key says what was suppressed
        assert not core.set_transform_raw("w", "a", S, NAN, 0.0, 0.0, *Q, "/flooder")
        assert not core.set_transform_raw("w", "a", S, 1.0, 0.0, 0.0, *Q, "/other")
        later = lines(caplog)
    assert [m.split()[0].rstrip(":") for m in first] == [
        "TF_NAN_INPUT", "TF_DENORMALIZED_QUATERNION", "TF_REPEATED_DATA", "TF_OLD_DATA"]
    assert all("suppressed" not in m for m in first)
    assert later[0].startswith("TF_NAN_INPUT") and later[0].endswith("(4999 similar suppressed)")
    assert later[1].startswith("TF_OLD_DATA") and later[1].endswith("(4999 similar suppressed)")
    assert core.lookup_transform("w", "a", 0).transform.translation.x == 0.0  # nothing got in


def test_every_sender_gets_its_own_first_line_until_the_global_budget_is_spent(caplog) -> None:
    core = BufferCore()
    core._warn.clock = FakeClock()
    with caplog.at_level(logging.WARNING, LOGGER):
        for i in range(1000):  # forged sender names: each a new key
            core.set_transform_raw("w", "a", S, NAN, 0.0, 0.0, *Q, f"/forged{i}")
    assert len(caplog.records) == core._warn.burst  # a flood of keys is bounded as a whole
    assert len(core._warn._next) <= core._warn.max_keys


def test_rate_limiter_key_table_is_bounded() -> None:
    clock = FakeClock()
    lim = RateLimitedLogger(logging.getLogger("zentf.test"), rate=1e9, burst=10**9, max_keys=100, clock=clock)
    for i in range(10_000):
        lim.allow(("r", i))
        clock.now += 0.001
    assert len(lim._next) <= 100 and len(lim._suppressed) <= 100


def test_hot_path_does_not_log_or_consult_the_limiter() -> None:
    core = BufferCore()
    core.set_transform_raw("w", "a", S, 0.0, 0.0, 0.0, *Q, "/x")
    core._warn = None  # type: ignore[assignment]  # any refusal would now raise
    for i in range(2, 100):
        assert core.set_transform_raw("w", "a", i * S, 0.0, 0.0, 0.0, *Q, "/x")
    assert core.set_transforms_raw([("w", "a", 200 * S + i, 0.0, 0.0, 0.0, *Q) for i in range(50)], "/x") == 50


# ------------------------------------------------------------------ point 7: names escaped in log lines

EVIL = "evil\x1b[2J\r\nTF_FAKE: all good\x07"


def test_log_lines_escape_control_characters_in_frame_ids_and_senders(caplog) -> None:
    core = BufferCore()
    with caplog.at_level(logging.WARNING, LOGGER):
        core.set_transform_raw("w", EVIL, S, NAN, 0.0, 0.0, *Q, EVIL)
        core.set_transform_raw(EVIL, EVIL, S, 0.0, 0.0, 0.0, *Q, "/x")
        core.set_transform_raw("w", EVIL, 100 * S, 0.0, 0.0, 0.0, *Q, "/x")
        core.set_transform_raw("w", EVIL, 100 * S, 0.0, 0.0, 0.0, *Q, "/x")
    text = caplog.text
    assert len(caplog.records) == 3
    for ch in "\x1b\r\x07":
        assert ch not in text
    assert text.count("\n") == 3  # one line each, none forged
    assert r"evil\x1b[2J\r\nTF_FAKE: all good\x07" in text


def test_printable_keeps_printable_names_and_cuts_long_ones() -> None:
    assert printable("base_link") == "base_link" and printable("bäse/λ") == "bäse/λ"
    assert printable("a\nb") == r"a\nb"
    long = printable("x" * 100_000, ARG_LIMIT)
    assert len(long) < 300 and long.endswith("...(100000 chars)")


# ------------------------------------------------------------------ point 9: infinite translations

@pytest.mark.parametrize("xyz", [(INF, 0.0, 0.0), (0.0, -INF, 0.0), (0.0, 0.0, INF), (INF, -INF, 0.0)])
def test_infinite_translations_are_refused_like_nan(xyz, caplog) -> None:
    core = BufferCore()
    assert core.set_transform_raw("w", "a", S, 1.0, 2.0, 3.0, *Q, "/x")
    with caplog.at_level(logging.WARNING, LOGGER):
        assert not core.set_transform_raw("w", "a", 2 * S, *xyz, *Q, "/x")
        assert core.set_transforms_raw([("w", "a", 3 * S, *xyz, *Q), ("w", "b", 3 * S, *xyz, *Q)], "/x") == 0
    assert "TF_NAN_INPUT" in caplog.text and "infinite value" in caplog.text
    assert not core.frame_exists("b")
    inv = core.lookup_transform("a", "w", 0)  # the reverse lookup stays finite: only the good sample is there
    v = inv.transform.translation
    assert (v.x, v.y, v.z) == (-1.0, -2.0, -3.0) and inv.header.stamp.nanoseconds == S


def test_huge_finite_translations_are_still_accepted() -> None:
    core = BufferCore()
    assert core.set_transform_raw("w", "a", S, 1e308, 1e308, 0.0, *Q, "/x")  # sum overflows: full path
    assert core.lookup_transform("w", "a", 0).transform.translation.x == 1e308


# ------------------------------------------------------------------ point 10: stamps beyond int64 ns

BIG = 2**62 + 5  # inside int64 but above the old 'no data' sentinel of the latest-common-time walk


@pytest.mark.parametrize("stamp", [2**62 - 1, 2**62, BIG, 2**63 - 1])
def test_latest_lookup_returns_the_stamp_however_large(stamp: int) -> None:
    core = BufferCore()
    assert core.set_transform_raw("w", "a", stamp, 1.0, 0.0, 0.0, *Q, "/x")
    assert core.set_transform_raw("a", "b", stamp, 2.0, 0.0, 0.0, *Q, "/x")
    assert core.set_transform_raw("w", "c", 0, 0.0, 0.0, 0.0, *Q, "/x", is_static=True)
    for target, source in (("w", "a"), ("w", "b"), ("b", "w"), ("c", "b"), ("a", "b")):
        t = core.lookup_transform(target, source, 0)
        assert t.header.stamp.nanoseconds == stamp, (target, source)
        assert core.get_latest_common_time(target, source).nanoseconds == stamp
    assert core.lookup_transform("w", "b", 0).transform.translation.x == 3.0


def test_a_chain_takes_the_oldest_of_its_large_stamps() -> None:
    core = BufferCore()
    for parent, child, newest in (("w", "a", BIG + 10), ("a", "b", BIG), ("w", "c", BIG + 20)):
        assert core.set_transform_raw(parent, child, BIG - 100, 1.0, 0.0, 0.0, *Q, "/x")
        assert core.set_transform_raw(parent, child, newest, 1.0, 0.0, 0.0, *Q, "/x")
    assert core.get_latest_common_time("c", "b").nanoseconds == BIG
    assert core.lookup_transform("c", "b", 0).header.stamp.nanoseconds == BIG


def test_stamps_beyond_int64_are_refused_with_a_clear_line(caplog) -> None:
    core = BufferCore()
    assert core.set_transform_raw("w", "a", S, 1.0, 0.0, 0.0, *Q, "/x")
    with caplog.at_level(logging.WARNING, LOGGER):
        assert not core.set_transform_raw("w", "a", 2**63, 1.0, 0.0, 0.0, *Q, "/x")
        assert core.set_transforms_raw([("w", "a", 2**64, 5.0, 0.0, 0.0, *Q), ("w", "z", 2**63, 5.0, 0.0, 0.0, *Q),
                                        ("w", "a", 2 * S, 2.0, 0.0, 0.0, *Q)], "/y") == 1
    msgs = lines(caplog)
    assert len(msgs) == 2 and all("is beyond the largest the buffer holds" in m for m in msgs)
    latest = core.lookup_transform("w", "a", 0)
    assert latest.header.stamp.nanoseconds == 2 * S and latest.transform.translation.x == 2.0


def test_lookup_time_beyond_int64_is_a_clear_error() -> None:
    core = BufferCore()
    core.set_transform_raw("w", "a", S, 1.0, 0.0, 0.0, *Q, "/x")
    with pytest.raises(ValueError, match="beyond the latest a buffer holds"):
        core.lookup_transform("w", "a", 1e300)
    with pytest.raises(ValueError, match="beyond the latest a buffer holds"):
        core.can_transform("w", "a", 10**12)


# ------------------------------------------------------------------ point 8: bounds on frames and frame ids

def test_defaults_are_documented_values() -> None:
    core = BufferCore()
    assert (core.max_frames, core.max_frame_id_length) == (10_000, 256)


def test_distinct_frames_are_capped_with_one_logged_refusal(caplog) -> None:
    core = BufferCore(max_frames=100)
    with caplog.at_level(logging.WARNING, LOGGER):
        accepted = core.set_transforms_raw([("w", f"f{i}", S, 0.0, 0.0, 0.0, *Q) for i in range(1000)], "/flood")
    assert accepted == 99 and len(core.get_frames()) == 100  # 'w' + 99 children
    assert len(caplog.records) == 1
    assert "TF_TOO_MANY_FRAMES" in caplog.text and "max_frames 100" in caplog.text and "/flood" in caplog.text
    # known frames keep working, new data on them too
    assert core.set_transform_raw("w", "f5", 2 * S, 1.0, 0.0, 0.0, *Q, "/ok")
    assert core.lookup_transform("w", "f5", 0).transform.translation.x == 1.0
    # a sample naming two new frames is refused whole: no half-added frame
    assert not core.set_transform_raw("new_parent", "new_child", S, 0.0, 0.0, 0.0, *Q, "/x")
    assert not core.frame_exists("new_parent") and not core.frame_exists("new_child")


def test_frame_cap_counts_parents_too_and_can_be_lifted() -> None:
    core = BufferCore(max_frames=3)
    assert core.set_transform_raw("a", "b", S, 0.0, 0.0, 0.0, *Q, "/x")
    assert not core.set_transform_raw("c", "d", S, 0.0, 0.0, 0.0, *Q, "/x")  # 2 + 2 > 3
    assert core.set_transform_raw("b", "c", S, 0.0, 0.0, 0.0, *Q, "/x")      # 2 + 1 = 3
    core.max_frames = None
    assert core.set_transforms_raw([("w", f"f{i}", S, 0.0, 0.0, 0.0, *Q) for i in range(20_000)], "/x") == 20_000


@pytest.mark.parametrize("name", ["x" * 257, "é" * 129, "x" * 10_000_000])
def test_frame_ids_longer_than_the_limit_are_refused(name: str, caplog) -> None:
    core = BufferCore()
    with caplog.at_level(logging.WARNING, LOGGER):
        assert not core.set_transform_raw("w", name, S, 0.0, 0.0, 0.0, *Q, "/x")
        assert not core.set_transform_raw(name, "c", S, 0.0, 0.0, 0.0, *Q, "/x")
    assert not core.frame_exists(name) and core.get_frames() == []
    assert "TF_FRAME_ID_TOO_LONG" in caplog.text and "max_frame_id_length 256" in caplog.text
    assert len(caplog.text) < 2000  # the name is cut in the log line too
    assert core.set_transform_raw("w", "x" * 256, S, 0.0, 0.0, 0.0, *Q, "/x")  # exactly the limit
    assert core.set_transform_raw("w", "é" * 128, S, 0.0, 0.0, 0.0, *Q, "/x")


def test_buffer_takes_the_bounds_too() -> None:
    from zentf.transport.buffer import Buffer

    buf = Buffer(max_frames=5, max_frame_id_length=8)
    assert (buf.max_frames, buf.max_frame_id_length) == (5, 8)
    assert not buf.set_transform_raw("w", "123456789", S, 0.0, 0.0, 0.0, *Q, "/x")


def test_rate_limiter_survives_threads_logging_at_once() -> None:
    import threading

    lim = RateLimitedLogger(logging.getLogger("zentf.test"), period=0.0, rate=1e9, burst=10**9, max_keys=50)
    errors: list[BaseException] = []

    def spam(t: int) -> None:
        try:
            for i in range(20_000):
                lim.allow((t, i))
        except BaseException as e:  # pragma: no cover - the failure being tested for
            errors.append(e)

    threads = [threading.Thread(target=spam, args=(t,)) for t in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not errors and len(lim._next) <= 50 + 4
