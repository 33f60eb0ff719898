"""The compiled bag loader (tools/bag/tfload.pyx via bulk.py) stores exactly what the sample-by-sample load
stores, for every fixture and format, and time windows read only their chunks."""
from __future__ import annotations

import random
import re
import struct
from pathlib import Path

import pytest

from bag_generate import NS, dump, sample_by_sample, transforms, write_ros1, write_ros2_mcap, write_rosbag2, write_zentf
from bag_reference import FIXTURES, NAV2, ROS1, reference_core

TF = "tf2_msgs/msg/TFMessage"


@pytest.mark.parametrize("name", list(FIXTURES))
def test_fixtures_load_bit_for_bit_as_sample_by_sample_and_as_rosbags(name):
    from zentf.tools.bag import load_buffer

    fast = load_buffer(FIXTURES[name])
    assert dump(fast) == dump(sample_by_sample(FIXTURES[name]))
    # and as rosbags' own reader and decoder give them (authorities aside: the reference names itself)
    assert dump(fast, authorities=False) == dump(reference_core(FIXTURES[name]), authorities=False)


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    d = tmp_path_factory.mktemp("gen")
    recs = transforms(seed=7)
    return {"ros2_mcap": write_rosbag2(d / "r2mcap", recs, "mcap"),
            "ros2_sqlite": write_rosbag2(d / "r2db3", recs, "sqlite3"),
            "ros2_mcap_chunks": write_ros2_mcap(d / "chunks.mcap", recs),
            "ros1_lz4": write_ros1(d / "lz4.bag", recs, "lz4"),
            "ros1_bz2": write_ros1(d / "bz2.bag", recs, "bz2"),
            "ros1_none": write_ros1(d / "none.bag", recs, "none"),
            "zentf": write_zentf(d / "z.mcap", recs)}


@pytest.mark.parametrize("kind", ["ros2_mcap", "ros2_mcap_chunks", "ros2_sqlite", "ros1_lz4", "ros1_bz2", "ros1_none",
                                  "zentf"])
def test_generated_bags_load_bit_for_bit_as_sample_by_sample(generated, kind):
    """Many frames, static and dynamic, stamps out of order and repeated, three publishers, a re-parented frame."""
    from zentf.tools.bag import load_buffer

    fast = dump(load_buffer(generated[kind]))
    assert len(fast) == 71
    assert fast == dump(sample_by_sample(generated[kind]))
    if kind.startswith("ros1"):  # the callerid is the authority
        assert {v[-1] for v in fast.values()} == {"/a", "/b", "/c", "/static_pub"}


def test_the_compiled_path_is_taken():
    from zentf.tools.bag.bulk import load_into
    from zentf.tools.bag import open_bag
    from zentf.core.buffer_core import BufferCore

    for path in (NAV2, ROS1):
        core = BufferCore(cache_time=1e9)
        problem, messages = load_into(open_bag(path), core)
        assert problem is None and messages > 500
        assert core.frame_info()


def _nav2_chunks():
    from zentf.tools.bag.mcapscan import McapScan

    scan = McapScan(NAV2)
    scan.read_summary()
    with open(NAV2, "rb") as f:
        f.read(8)
        return scan, [scan.chunk_data(body, where)[0] for op, where, body in scan.units(f) if op == 6]


def _loader(core, scan, framing=0):
    from zentf.ros.tf import tf_samples
    from zentf.tools.bag.tfload import KIND_CDR, TfLoader

    statics = {}

    def fallback(cid, payload):
        rows = tf_samples(payload)[0]
        if rows:
            core.set_transforms_raw(rows, "bag", statics[cid])

    loader = TfLoader(core, fallback, None, framing)
    for ch in scan.channels.values():
        if ch.topic in ("/tf", "/tf_static"):
            statics[ch.id] = ch.topic == "/tf_static"
            loader.set_channel(ch.id, KIND_CDR, "bag", statics[ch.id])
    return loader


def test_records_cut_anywhere_by_piece_boundaries_load_the_same():
    from zentf.core.buffer_core import BufferCore

    scan, chunks = _nav2_chunks()
    whole, pieces = BufferCore(cache_time=1e9), BufferCore(cache_time=1e9)
    a, b = _loader(whole, scan), _loader(pieces, scan)
    rnd = random.Random(3)
    for data in chunks:
        a.feed(data)
        assert a.end_chunk()
        i = 0
        while i < len(data):
            n = rnd.choice((1, 2, 9, 10, 11, 23, rnd.randrange(1, 5000)))
            b.feed(data[i:i + n])
            i += n
        assert b.end_chunk()
    assert a.messages == b.messages > 5000
    assert dump(whole) == dump(pieces)


def _rows_generic(payload: bytes) -> list:
    from zentf.ros import decode_plain

    out = []
    for t in decode_plain(payload, TF)["transforms"]:
        h, tr = t["header"], t["transform"]
        p, q = tr["translation"], tr["rotation"]
        out.append((h["frame_id"], t["child_frame_id"], h["stamp"]["sec"] * 1_000_000_000 + h["stamp"]["nanosec"],
                    p["x"], p["y"], p["z"], q["x"], q["y"], q["z"], q["w"]))
    return out


def _compiled_rows(payload: bytes, ros1: bool = False) -> list | None:
    """What the compiled decoder stores for one message (None: it handed the message to the fallback)."""
    from zentf.core.buffer_core import BufferCore
    from zentf.tools.bag.tfload import KIND_CDR, KIND_ROS1, ROS1 as FRAMING_ROS1, TfLoader

    core = BufferCore(cache_time=1e9)
    fell = []
    loader = TfLoader(core, lambda cid, p: fell.append(p), None, FRAMING_ROS1 if ros1 else 0)
    loader.set_channel(0, KIND_ROS1 if ros1 else KIND_CDR, "x", False)
    loader.message(0, payload)
    if fell:
        return None
    return dump(core)


def _stored(rows) -> dict:
    from zentf.core.buffer_core import BufferCore

    core = BufferCore(cache_time=1e9)
    core.set_transforms_raw(rows, "x", False)
    return dump(core)


def _random_message(rnd: random.Random) -> dict:
    names = ["map", "odom", "base_link", "ä/ü", "a" * rnd.randrange(1, 40), "", "x y"]
    return {"transforms": [
        {"header": {"stamp": {"sec": rnd.randrange(0, 2**31), "nanosec": rnd.randrange(0, 10**9)},
                    "frame_id": rnd.choice(names)},
         "child_frame_id": rnd.choice(names) + str(rnd.randrange(3)),
         "transform": {"translation": {k: rnd.uniform(-1e6, 1e6) for k in "xyz"},
                       "rotation": dict(zip("xyzw", _unit(rnd)))}} for _ in range(rnd.randrange(0, 9))]}


def _unit(rnd):
    q = [rnd.gauss(0, 1) for _ in range(4)]
    n = sum(v * v for v in q) ** 0.5 or 1.0
    return [v / n for v in q]


def test_the_compiled_cdr_decoder_equals_the_generic_decoder_on_random_and_real_messages():
    from zentf.ros import cdr, definition
    from zentf.tools.bag import open_bag

    rnd = random.Random(11)
    for _ in range(400):
        payload = cdr.serialize(_random_message(rnd), TF, definition)
        got = _compiled_rows(payload)
        assert got is not None and got == _stored(_rows_generic(payload))
    real = [m.payload for m in open_bag(NAV2).raw(["/tf", "/tf_static"])]
    assert len(real) == 5423
    for payload in real:
        assert _compiled_rows(payload) == _stored(_rows_generic(payload))


def test_damaged_cdr_messages_go_to_the_python_decoder_whole():
    """A mutated payload is either handed over untouched or stored as the Python TFMessage decoder stores it
    (an element whose name is not UTF-8 skipped), and as the generic decoder decodes it where that one can."""
    from zentf.ros import CdrError, cdr, definition, tf_samples

    rnd = random.Random(5)
    handed = 0
    for _ in range(1500):
        b = bytearray(cdr.serialize(_random_message(rnd), TF, definition))
        for _ in range(rnd.randrange(1, 4)):
            if len(b) > 8:
                b[rnd.randrange(4, len(b))] = rnd.randrange(256)
        if rnd.random() < 0.2:
            b = b[:rnd.randrange(len(b) + 1)]
        got = _compiled_rows(bytes(b))
        if got is None:
            handed += 1
            continue
        assert got == _stored(tf_samples(bytes(b))[0])
        try:
            generic = _rows_generic(bytes(b))
        except CdrError:
            continue
        assert got == _stored(generic)
    assert handed > 100


def test_ros1_time_is_unsigned(tmp_path):
    """sec = 0xFFFFFFFF is 2106, not -1 s (rosbags' ROS 1 decode gives -1; the buffer refused the sample)."""
    from zentf.tools.bag import load_buffer

    recs = [("/tf", "/a", 5 * 1_000_000_000, [("odom", "base_link", -1, 5, (1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))])]
    path = write_ros1(tmp_path / "u.bag", recs)  # rosbags writes int32 -1: the bytes of uint32 0xFFFFFFFF
    buf = load_buffer(path)
    stamps = [x["most_recent_transform"].nanoseconds for x in buf.frame_info() if not x["static"]]
    assert stamps == [0xFFFFFFFF * 1_000_000_000 + 5]


# ---------------------------------------------------------------- time windows


def _window_of(full: dict, start: int, end: int) -> dict:
    """A full load's dump restricted to stamps in [start, end] (statics kept)."""
    import numpy as np

    out = {}
    for name, v in full.items():
        if v[0] == "static":
            out[name] = v
            continue
        st = np.frombuffer(v[1], dtype=np.int64)
        keep = (st >= start) & (st <= end)
        if not keep.any():
            continue
        d = np.frombuffer(v[3], dtype=np.float64).reshape(-1, 7)
        out[name] = ("dynamic", st[keep].tobytes(), tuple(p for p, k in zip(v[2], keep) if k), d[keep].tobytes(), v[4])
    return out


@pytest.mark.parametrize("kind", ["ros2_mcap_chunks", "ros1_lz4", "zentf", "ros2_sqlite"])
def test_a_window_loads_exactly_its_transforms(generated, kind):
    from zentf.tools.bag import load_buffer

    full = dump(load_buffer(generated[kind]))
    for start, end in ((12 * 10**9, 13 * 10**9), (10**9, 11 * 10**9 + 5), (20 * 10**9, 30 * 10**9)):
        win = dump(load_buffer(generated[kind], start=start, end=end))
        want = _window_of(full, start, end)
        # the authority of a frame is its last sample's: compare it only where the window holds the last one
        assert {k: v[:-1] for k, v in win.items()} == {k: v[:-1] for k, v in want.items()}


@pytest.mark.parametrize("fmt", ["ros2_mcap", "ros1"])
def test_a_lookup_at_one_time_reads_only_the_chunks_around_it(tmp_path, fmt, monkeypatch):
    from zentf.core.time import Time
    from zentf.tools.bag import load_buffer, load_buffer_at
    from zentf.tools.bag import mcapscan, ros1scan

    recs = transforms(seed=3, messages=6000, frames=12)
    path = write_ros2_mcap(tmp_path / "w.mcap", recs) if fmt == "ros2_mcap" else write_ros1(tmp_path / "w.bag", recs, "lz4")
    full = load_buffer(path)
    reads = []
    if fmt == "ros2_mcap":
        real = mcapscan.McapScan.chunk_data
        monkeypatch.setattr(mcapscan.McapScan, "chunk_data", lambda self, *a, **k: reads.append(1) or real(self, *a, **k))
    else:
        real = ros1scan.chunk_records
        monkeypatch.setattr(ros1scan, "chunk_records", lambda *a, **k: reads.append(1) or real(*a, **k))
    total = len(reads)
    load_buffer(path)
    total = len(reads) - total
    assert total > 60
    for t in (40.123, 10.5, 69.0):
        reads.clear()
        win = load_buffer_at(path, Time.from_sec(t), ("odom", "link_7"))
        assert len(reads) < total // 4, (len(reads), total)
        at = Time.from_sec(t)
        a, b = win.lookup_transform("odom", "link_7", at), full.lookup_transform("odom", "link_7", at)
        assert (a.transform.translation, a.transform.rotation, a.header.stamp) == \
            (b.transform.translation, b.transform.rotation, b.header.stamp)


def test_tf_echo_at_a_time_in_a_bag_whose_stamps_are_not_its_receive_times():
    """The nav2 bag is stamped in sim time (~928-1026 s), received in wall time: the window is found by stamp."""
    import subprocess
    import sys

    from conftest import REPO

    from zentf.core.time import Time

    ref = reference_core(NAV2)
    for t in ("1000.25", "950"):
        want = ref.lookup_transform("map", "oakd_rgb_camera_optical_frame", Time.from_sec(float(t)))
        r = subprocess.run([sys.executable, "-m", "zentf.cli", "tf", "echo", "map", "oakd_rgb_camera_optical_frame",
                            "--bag", str(NAV2), "--time", t, "-p", "9"], capture_output=True, text=True, timeout=60,
                           cwd=REPO)
        tr = want.transform.translation
        assert f"- Translation: [{tr.x:.9f}, {tr.y:.9f}, {tr.z:.9f}]" in r.stdout, r.stdout + r.stderr
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "tf", "echo", "odom", "base_link", "--bag", str(NAV2),
                        "--start", "990", "--end", "991"], capture_output=True, text=True, timeout=60, cwd=REPO)
    assert r.returncode == 0 and r.stdout.startswith("At time 99"), r.stderr
    t = float(r.stdout.split()[2])
    assert 990 <= t <= 991


# ---------------------------------------------------------------- zentf recordings and rosbag2 SQLite in C

STAGED = NAV2.parent / "tf_doctor_staged.mcap"  # a zentf recording (msgpack TFMessages)


def _bulk_load(path, monkeypatch=None):
    """load_into's pieces, to see the loader's counters: (problem, loader)."""
    from zentf.core.buffer_core import BufferCore
    from zentf.tools.bag import bulk, open_bag
    from zentf.tools.bag.formats import BagFormat

    bag = open_bag(path)
    load = bulk._Load(bag, BufferCore(cache_time=1e9), None, None, None, bulk.MCAP)
    problem = bulk._mcap(load, bag.path, True) if bag.format is BagFormat.ZENTF else bulk._sqlite(load)
    return problem, load.loader


@pytest.mark.parametrize("kind", ["zentf_fixture", "zentf", "ros2_db3_fixture", "ros2_folder_fixture", "ros2_sqlite"])
def test_zentf_recordings_and_sqlite_bags_load_in_c_bit_for_bit_as_sample_by_sample(generated, kind, monkeypatch):
    """No message goes through Python (no fallback, no sqlite3 row), and every sample is the Python path's."""
    from zentf.tools.bag import load_buffer
    from zentf.tools.bag.ros2sqlite import SqliteBag

    path = {"zentf_fixture": STAGED, "ros2_db3_fixture": FIXTURES["ros2_db3"],
            "ros2_folder_fixture": FIXTURES["ros2_folder"]}.get(kind) or generated[kind]
    want = dump(sample_by_sample(path))
    monkeypatch.setattr(SqliteBag, "rows", lambda *a, **k: pytest.fail("a row was read through Python's sqlite3"))
    problem, loader = _bulk_load(path)
    assert problem is None and loader.fallbacks == 0 and loader.messages > 0
    assert loader.transforms >= len(want)
    assert dump(load_buffer(path)) == want
    if kind == "zentf":
        assert len(want) == 71


def test_sqlite_without_the_c_library_reads_through_python_with_the_same_result(generated, monkeypatch):
    from zentf.tools.bag import load_buffer, sqliteapi

    fast = dump(load_buffer(generated["ros2_sqlite"]))
    monkeypatch.setattr(sqliteapi, "unavailable", lambda: "no library")
    assert dump(load_buffer(generated["ros2_sqlite"])) == fast == dump(sample_by_sample(generated["ros2_sqlite"]))


def _zentf_item(rnd: random.Random) -> dict:
    return {"header": {"stamp": {"sec": rnd.randrange(0, 2**31), "nanosec": rnd.randrange(0, 10**9)},
                       "frame_id": rnd.choice(["map", "odom", "ä/ü", "a" * rnd.randrange(1, 40)])},
            "child_frame_id": rnd.choice(["base_link", "x y", "c"]) + str(rnd.randrange(3)),
            "transform": {"translation": {k: rnd.uniform(-1e6, 1e6) for k in "xyz"},
                          "rotation": dict(zip("xyzw", _unit(rnd)))}}


def _odd_zentf_payloads() -> list[bytes]:
    """Valid TFMessages laid out unlike zentf's writer, and malformed ones (each a case the listener meets)."""
    import msgpack

    from zentf.transport.wire import codec as wire

    rnd = random.Random(17)
    good = _zentf_item(rnd)
    bad_utf8 = msgpack.packb({"transforms": [good]}).replace(b"base_link", b"base\xfflink")
    out = [msgpack.packb({"transforms": [good, _zentf_item(rnd)]}),                 # msgpack.packb's own layout
           msgpack.packb({"transforms": [dict(reversed(list(good.items())))]}),     # keys in another order
           msgpack.packb({"extra": [1, {"a": None}], "transforms": [good]}),        # an unknown field
           msgpack.packb({"transforms": [good]}, use_single_float=True),            # float32 values
           msgpack.packb({"transforms": [{**good, "child_frame_id": b"bin"}]}),     # a bin name
           msgpack.packb({"transforms": [{**good, "header": {**good["header"],
                                                             "stamp": {"sec": True, "nanosec": 0}}}]}),
           msgpack.packb({"transforms": [{**good, "header": {"frame_id": "map"}}, good]}),  # one element without stamp
           msgpack.packb({"transforms": [{**good, "transform": {"translation": {"x": 1}}}]}),
           msgpack.packb({"transforms": [good], "transforms ": 1}) + b"\x00",       # trailing byte
           wire.encode_tf([good])[:-3],                                             # cut short
           bad_utf8,
           b"\xc1not msgpack",
           msgpack.packb([1, 2, 3]),
           msgpack.packb({"transforms": "no"}),
           msgpack.packb({"transforms": []})]
    for _ in range(300):  # zentf's own writer, bytes flipped
        b = bytearray(wire.encode_tf([_zentf_item(rnd) for _ in range(rnd.randrange(1, 5))]))
        for _ in range(rnd.randrange(1, 3)):
            b[rnd.randrange(len(b))] = rnd.randrange(256)
        out.append(bytes(b))
    return out


def test_odd_and_malformed_messages_in_a_zentf_recording_load_as_the_python_path_loads_them(tmp_path, caplog):
    import logging

    from zentf.tools.bag import BagWriter, load_buffer

    payloads = _odd_zentf_payloads()
    path = tmp_path / "odd.mcap"
    with BagWriter(path, chunk_size=4096) as w:
        for i, payload in enumerate(payloads):
            w.write("tf", payload, "application/msgpack;tf2_msgs/msg/TFMessage", "/pub", (i + 1) * NS)
    with caplog.at_level(logging.DEBUG, logger="zentf.tools.bag"):
        problem, loader = _bulk_load(path)
    assert problem is None and loader.messages == len(payloads)
    # the compiled walker read the valid layouts; the rest went to the Python path whole, which named the
    # payloads that are no TFMessage at all
    assert loader.fallbacks > 100 and len(payloads) - loader.fallbacks > 50, loader.fallbacks
    assert loader.transforms >= 6
    undecodable = [r for r in caplog.records if "undecodable TFMessage" in r.getMessage()]
    assert len(undecodable) >= 3 and all(path.name in r.getMessage() for r in undecodable)
    assert dump(load_buffer(path)) == dump(sample_by_sample(path))


def _msgpack_rows(payload: bytes):
    """What TfLoader's msgpack decoder stores for one message (None: handed to the fallback)."""
    from zentf.core.buffer_core import BufferCore
    from zentf.tools.bag.tfload import KIND_MSGPACK, TfLoader

    core = BufferCore(cache_time=1e9)
    fell = []
    loader = TfLoader(core, lambda cid, p: fell.append(p), None, 0)
    loader.set_channel(0, KIND_MSGPACK, "x", False)
    loader.message(0, payload)
    return None if fell else dump(core)


def test_the_compiled_msgpack_decoder_stores_what_the_python_decoder_stores():
    from zentf.transport.wire import codec as wire

    handed = taken = 0
    for payload in _odd_zentf_payloads():
        got = _msgpack_rows(payload)
        if got is None:
            handed += 1
            continue
        taken += 1
        samples, malformed, _ = wire.tf_samples(payload)
        assert malformed == 0 and got == _stored(samples)
    assert handed > 100 and taken > 50


def _sqlite_bag(tmp_path: Path, messages: int = 1500) -> Path:
    from bag_generate import write_rosbag2

    return write_rosbag2(tmp_path / "sq", transforms(seed=9, messages=messages, frames=20), "sqlite3")


def _problems(path, python: bool, monkeypatch) -> tuple[list[str], dict]:
    from zentf.tools.bag import load_buffer, sqliteapi

    with monkeypatch.context() as m:
        if python:
            m.setattr(sqliteapi, "unavailable", lambda: "test")
        problems = []
        buf = load_buffer(path, on_problem=problems.append)
    return problems, dump(buf)


def test_a_damaged_sqlite_bag_gives_one_line_in_c_as_in_python(tmp_path, monkeypatch):
    import sqlite3

    folder = _sqlite_bag(tmp_path)
    db = next(folder.glob("*.db3"))
    data = bytearray(db.read_bytes())
    page = sqlite3.connect(db).execute("PRAGMA page_size").fetchone()[0]
    pages = len(data) // page
    assert pages > 20
    for name, damage in (("garbage", lambda b: b.__setitem__(slice(page * (pages // 2), page * (pages // 2) + 300),
                                                             bytes(range(256)) + bytes(44))),
                         ("zeroed", lambda b: b.__setitem__(slice(page * (pages * 3 // 4), page * (pages * 3 // 4 + 3)),
                                                            bytes(3 * page)))):
        bad = tmp_path / name
        bad.mkdir()
        (bad / "metadata.yaml").write_text((folder / "metadata.yaml").read_text())
        b = bytearray(data)
        damage(b)
        (bad / db.name).write_bytes(bytes(b))
        fast, fast_dump = _problems(bad, False, monkeypatch)
        slow, slow_dump = _problems(bad, True, monkeypatch)
        assert len(fast) == len(slow) == 1 and "\n" not in fast[0], (fast, slow)
        line = re.compile(rf"{re.escape(str(bad))}: stopped after (\d+) tf messages \((\w+Error: [^)]+)\); loaded "
                          r"the readable part")
        f, s = line.fullmatch(fast[0]), line.fullmatch(slow[0])
        assert f and s and f[2] == s[2], (fast, slow)
        # Python's sqlite3 cursor steps one row ahead and drops the row it holds when that step fails; the C
        # loop keeps it
        assert int(f[1]) == int(s[1]) + 1 > 100
        assert sum(len(v[1]) for v in fast_dump.values()) >= sum(len(v[1]) for v in slow_dump.values())


def test_sqlite_cells_that_are_not_blobs_are_skipped_in_c_as_in_python(tmp_path, monkeypatch):
    import sqlite3

    folder = _sqlite_bag(tmp_path, messages=40)
    db = next(folder.glob("*.db3"))
    con = sqlite3.connect(db)
    ids = [r[0] for r in con.execute("SELECT id FROM messages ORDER BY id")]
    for rid, value in zip(ids[3:8], ("text", 7, 1.5, b"", b"\x00\x01\x00\x00" + b"\xff" * 3)):
        con.execute("UPDATE messages SET data=? WHERE id=?", (value, rid))
    con.commit()
    con.close()
    fast, fast_dump = _problems(folder, False, monkeypatch)
    slow, slow_dump = _problems(folder, True, monkeypatch)
    assert fast == slow == [] and fast_dump == slow_dump and len(fast_dump) > 10


def test_messages_larger_than_the_walkers_first_buffer_decode_as_the_python_path():
    """129 elements outgrow the listener's stack buffer; 5,000 the loader's kept one (both allocate, then free)."""
    from zentf.transport.ingest import decoders
    from zentf.transport.wire import codec as wire

    rnd = random.Random(23)
    for n in (127, 128, 129, 300, 5000, 40):
        payload = wire.encode_tf([_zentf_item(rnd) for _ in range(n)])
        rows = wire.tf_samples(payload)[0]
        assert len(rows) == n and decoders.msgpack_tf(payload) == rows
        assert _msgpack_rows(payload) == _stored(rows)


def test_a_sqlite_blob_larger_than_any_tf_message_is_skipped_in_c_as_in_python(tmp_path, monkeypatch):
    import sqlite3

    from zentf.ros.tf import MAX_PAYLOAD

    folder = _sqlite_bag(tmp_path, messages=20)
    db = next(folder.glob("*.db3"))
    con = sqlite3.connect(db)
    rid = con.execute("SELECT id FROM messages WHERE topic_id=(SELECT id FROM topics WHERE name='/tf') LIMIT 1 OFFSET 5"
                      ).fetchone()[0]
    con.execute("UPDATE messages SET data=? WHERE id=?", (b"\x00\x01\x00\x00" + bytes(MAX_PAYLOAD), rid))
    con.commit()
    con.close()
    _, loader = _bulk_load(folder)
    assert loader.skipped_records == 1 and loader.fallbacks == 0
    fast, fast_dump = _problems(folder, False, monkeypatch)
    slow, slow_dump = _problems(folder, True, monkeypatch)
    assert fast == slow == [] and fast_dump == slow_dump and len(fast_dump) > 10


def test_tf_why_at_a_time_in_a_bag_reads_only_the_chunks_around_it(tmp_path, monkeypatch):
    """`tf why --bag B TARGET SOURCE --time T` loads as `tf echo --bag --time` does (load_buffer_at)."""
    from zentf.cli.tf_doctor import _why_bag
    from zentf.core.time import Time
    from zentf.tools.bag import mcapscan

    path = write_ros2_mcap(tmp_path / "w.mcap", transforms(seed=3, messages=6000, frames=12))
    reads = []
    real = mcapscan.McapScan.chunk_data
    monkeypatch.setattr(mcapscan.McapScan, "chunk_data", lambda self, *a, **k: reads.append(1) or real(self, *a, **k))
    whole = _why_bag(str(path), "odom", "link_7", None, None, None, 1.0)
    total = len(reads)
    reads.clear()
    at = _why_bag(str(path), "odom", "link_7", Time.from_sec(40.123), None, None, 1.0)
    assert total > 60 and len(reads) < total // 4, (len(reads), total)
    assert whole.ok and at.ok and "link_7" in at.text()


def test_a_window_of_a_sqlite_bag_reads_only_the_rows_around_it(tmp_path):
    """rosbag2's timestamp index: receive-time slices found by bisection on stamps, as MCAP chunks are."""
    from zentf.core.buffer_core import BufferCore
    from zentf.core.time import Time
    from zentf.tools.bag import bulk, load_buffer, load_buffer_at, open_bag

    folder = write_rosbag2(tmp_path / "w", transforms(seed=3, messages=6000, frames=12), "sqlite3")
    full = load_buffer(folder)
    _, whole = _bulk_load(folder)
    for t in (40.123, 10.5, 69.0):
        load = bulk._Load(open_bag(folder), BufferCore(cache_time=1e9), None, int((t - 2) * NS), int((t + 2) * NS),
                          bulk.MCAP)
        assert bulk._sqlite(load) is None
        assert 0 < load.loader.messages < whole.messages // 4, (load.loader.messages, whole.messages)
        win = load_buffer_at(folder, Time.from_sec(t), ("odom", "link_7"))
        at = Time.from_sec(t)
        a, b = win.lookup_transform("odom", "link_7", at), full.lookup_transform("odom", "link_7", at)
        assert (a.transform.translation, a.transform.rotation, a.header.stamp) == \
            (b.transform.translation, b.transform.rotation, b.header.stamp)
        assert win.lookup_transform("base_link", "sensor_3", Time(0))  # the statics, always
