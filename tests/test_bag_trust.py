"""Hostile and damaged bags: decompression bombs stay bounded (one line naming file, chunk and what was
refused), damage reports say what was read, a damaged length is skipped over, ROS 1 damage is named."""
from __future__ import annotations

import json
import re
import shutil
import sqlite3
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from bag_reference import NAV2, ROS1
from conftest import REPO

GIB = 1 << 30
MIB = 1 << 20


def _zeros_zstd(total: int, prefix: bytes) -> bytes:
    import zstandard

    c = zstandard.ZstdCompressor(level=1, write_content_size=True).compressobj(size=total)
    out = [c.compress(prefix)]
    left = total - len(prefix)
    z = bytes(MIB)
    while left > 0:
        out.append(c.compress(z[:min(MIB, left)]))
        left -= MIB
    out.append(c.flush())
    return b"".join(out)


def _zeros_lz4(total: int, prefix: bytes) -> bytes:
    import lz4.frame

    c = lz4.frame.LZ4FrameCompressor(content_checksum=False)
    out = [c.begin(total), c.compress(prefix)]
    left = total - len(prefix)
    z = bytes(MIB)
    while left > 0:
        out.append(c.compress(z[:min(MIB, left)]))
        left -= MIB
    out.append(c.flush())
    return b"".join(out)


def _zeros_bz2(total: int, prefix: bytes) -> bytes:
    import bz2

    c = bz2.BZ2Compressor(1)
    out = [c.compress(prefix)]
    left = total - len(prefix)
    z = bytes(4 * MIB)
    while left > 0:
        out.append(c.compress(z[:min(len(z), left)]))
        left -= len(z)
    out.append(c.flush())
    return b"".join(out)


def _rec(op: int, body: bytes) -> bytes:
    return struct.pack("<BQ", op, len(body)) + body


def _s(text: str | bytes) -> bytes:
    b = text.encode() if isinstance(text, str) else text
    return struct.pack("<I", len(b)) + b


def mcap_bomb(path: Path, kind: str, expands_to: int, declares: int | None = None) -> Path:
    """An MCAP with one /tf channel and one chunk whose single message record expands to ``expands_to``
    bytes of zeros; the chunk declares ``declares`` (default: the truth)."""
    msg_head = struct.pack("<BQ", 5, expands_to - 9) + struct.pack("<HIQQ", 1, 0, 10, 10)
    data = {"zstd": _zeros_zstd, "lz4": _zeros_lz4}[kind](expands_to, msg_head)
    chunk = struct.pack("<QQQI", 10, 10, expands_to if declares is None else declares, 0) + _s(kind) + \
        struct.pack("<Q", len(data)) + data
    body = (b"\x89MCAP0\r\n" + _rec(1, _s("ros2") + _s("test"))
            + _rec(3, struct.pack("<H", 1) + _s("tf2_msgs/msg/TFMessage") + _s("ros2msg") + _s(""))
            + _rec(4, struct.pack("<HH", 1, 1) + _s("/tf") + _s("cdr") + struct.pack("<I", 0))
            + _rec(6, chunk) + _rec(0x0F, struct.pack("<I", 0)) + _rec(2, struct.pack("<QQI", 0, 0, 0)) + b"\x89MCAP0\r\n")
    path.write_bytes(body)
    return path


def _ros1_rec(fields: dict[str, bytes], data: bytes) -> bytes:
    head = b"".join(struct.pack("<I", len(k) + 1 + len(v)) + k.encode() + b"=" + v for k, v in fields.items())
    return struct.pack("<I", len(head)) + head + struct.pack("<I", len(data)) + data


def ros1_bomb(path: Path, kind: str, expands_to: int, declares: int | None = None) -> Path:
    """A ROS 1 bag (no index) with a /tf connection and one chunk expanding to ``expands_to`` bytes."""
    conn = _ros1_rec({"op": b"\x07", "conn": struct.pack("<I", 0), "topic": b"/tf"},
                     _ros1_rec({"topic": b"/tf", "type": b"tf2_msgs/TFMessage",
                                "md5sum": b"94810edda583a504dfda3829e70d7eec", "message_definition": b""}, b"")[4:-4])
    msg_head = _ros1_rec({"op": b"\x02", "conn": struct.pack("<I", 0), "time": struct.pack("<II", 1, 0)}, b"")[:-4]
    prefix = msg_head + struct.pack("<I", expands_to - len(msg_head) - 4)
    data = {"bz2": _zeros_bz2, "lz4": _zeros_lz4}[kind](expands_to, prefix)
    chunk = _ros1_rec({"op": b"\x05", "compression": kind.encode(),
                       "size": struct.pack("<I", expands_to if declares is None else declares)}, data)
    header = _ros1_rec({"op": b"\x03", "index_pos": struct.pack("<Q", 0), "conn_count": struct.pack("<I", 0),
                        "chunk_count": struct.pack("<I", 0)}, b" " * 4000)
    path.write_bytes(b"#ROSBAG V2.0\n" + header + conn + chunk)
    return path


def sqlite_bomb(tmp_path: Path, expands_to: int) -> Path:
    """A rosbag2 SQLite bag compressed per message (zstd) whose one /tf row expands to ``expands_to`` bytes."""
    from bag_generate import transforms, write_rosbag2

    folder = write_rosbag2(tmp_path / "sq", transforms(seed=1, messages=3, frames=2), "sqlite3")
    meta = (folder / "metadata.yaml").read_text()
    meta = re.sub(r"compression_format: ''", "compression_format: zstd", meta)
    meta = re.sub(r"compression_mode: ''", "compression_mode: MESSAGE", meta)
    (folder / "metadata.yaml").write_text(meta)
    db = next(folder.glob("*.db3"))
    con = sqlite3.connect(db)
    import zstandard

    rows = con.execute("SELECT id, data FROM messages").fetchall()
    for rid, data in rows:
        con.execute("UPDATE messages SET data=? WHERE id=?", (zstandard.ZstdCompressor().compress(data), rid))
    con.execute("UPDATE messages SET data=? WHERE id=?", (_zeros_zstd(expands_to, b"\x00\x01\x00\x00"), rows[-1][0]))
    con.commit()
    con.close()
    return folder


_PROBE = r"""
import json, resource, sys
def rss():
    for line in open("/proc/self/status"):
        if line.startswith(("VmRSS", "VmHWM")):
            yield line.split()[1]
from zentf.tools.bag import load_buffer, bag_info
import zentf.tools.bag.ros, rosbags.typesys, zstandard, lz4.frame, bz2
base = int(next(rss()))
problems = []
what = sys.argv[2]
try:
    if what == "info":
        problems.append(bag_info(sys.argv[1])["problem"])
    else:
        load_buffer(sys.argv[1], on_problem=problems.append)
except Exception as e:
    problems.append(f"{type(e).__name__}: {e}"[:300])
peak = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0].split()[1]
print(json.dumps({"growth_mb": (int(peak) - base) / 1024, "problems": problems}))
"""


def _probe(path: Path, what: str) -> dict:
    r = subprocess.run([sys.executable, "-c", _PROBE, str(path), what], capture_output=True, text=True, timeout=300,
                       cwd=REPO)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


BOMBS = {
    "mcap_zstd": lambda d: mcap_bomb(d / "bomb.mcap", "zstd", 3 * GIB // 2),
    "mcap_zstd_lying": lambda d: mcap_bomb(d / "lie.mcap", "zstd", GIB, declares=MIB),
    "mcap_lz4": lambda d: mcap_bomb(d / "bomb.mcap", "lz4", GIB),
    "mcap_lz4_lying": lambda d: mcap_bomb(d / "lie.mcap", "lz4", GIB, declares=2 * MIB),
    "ros1_bz2": lambda d: ros1_bomb(d / "bomb.bag", "bz2", 256 * MIB),
    "ros1_bz2_lying": lambda d: ros1_bomb(d / "lie.bag", "bz2", 256 * MIB, declares=MIB),
    "ros1_lz4": lambda d: ros1_bomb(d / "bomb.bag", "lz4", GIB),
    "rosbag2_sqlite_zstd": lambda d: sqlite_bomb(d, GIB),
}


@pytest.mark.parametrize("name", list(BOMBS))
def test_decompression_bombs_are_refused_in_one_line_within_100_mb(tmp_path, name):
    path = BOMBS[name](tmp_path)
    assert path.stat().st_size < 8 * MIB if path.is_file() else True
    for what in ("info", "load"):
        r = _probe(path, what)
        assert r["growth_mb"] <= 100, (what, r)
        assert len(r["problems"]) == 1 and r["problems"][0], r
        line = r["problems"][0]
        assert re.search(r"(over the 64\.0 MiB cap|expands past)", line), line
        assert "sqlite" in name or re.search(r"chunk at byte \d+", line), line
        if what == "load":
            assert str(path) in line
    cli = subprocess.run([sys.executable, "-m", "zentf.cli", "tf", "echo", "a", "b", "--bag", str(path)],
                         capture_output=True, text=True, timeout=300, cwd=REPO)
    assert "Traceback" not in cli.stderr and f"zentf: warning: {path}: " in cli.stderr, cli.stderr


# ---------------------------------------------------------------- damage reports


def test_a_cut_ros2_mcap_says_how_many_messages_were_read(tmp_path):
    from zentf.tools.bag import bag_info

    data = NAV2.read_bytes()
    for frac in (0.3, 0.6):
        cut = tmp_path / f"cut{frac}.mcap"
        cut.write_bytes(data[:int(len(data) * frac)])
        info = bag_info(cut)
        m = re.fullmatch(r"the chunk at byte (\d+) is cut by the end of the file \(truncated at byte (\d+)\); kept its "
                         r"first (\d+) messages; read (\d+) messages", info["problem"])
        assert m, info["problem"]
        assert int(m[2]) == cut.stat().st_size and int(m[4]) == info["messages"] > 1000


def test_a_flipped_length_byte_in_a_zentf_mcap_is_skipped_and_the_rest_is_read(tmp_path):
    from zentf.tools.bag import BagReader, bag_info, load_buffer
    from zentf.tools.bag.mcapscan import McapScan

    from bag_generate import transforms, write_zentf

    path = write_zentf(tmp_path / "z.mcap", transforms(seed=2, messages=3000, frames=8))
    full = bag_info(path)["messages"]
    scan = McapScan(path)
    with open(path, "rb") as f:
        f.read(8)
        chunks = [where for op, where, _ in scan.units(f) if op == 6]
    assert len(chunks) > 10
    for summary in (True, False):
        data = bytearray(path.read_bytes())
        at = chunks[len(chunks) // 3]
        data[at + 8] ^= 0x40  # the top byte of the chunk record's length: past the end of the file
        if not summary:  # a killed recorder: no summary to find the next chunk from
            data = data[:chunks[-1]]
        bad = tmp_path / f"flip{summary}.mcap"
        bad.write_bytes(bytes(data))
        info = bag_info(bad)
        m = re.match(rf"the record at byte {at} has a damaged length \([\d,]+ bytes, past the end of the file\); "
                     r"resumed at the next record, byte (\d+)", info["problem"])
        assert m and at < int(m[1]) <= chunks[len(chunks) // 3 + 1], info["problem"]
        # everything but that one chunk (and, without the summary, the last) is read
        assert info["messages"] > full * 0.8, (info["messages"], full)
        problems = []
        buf = load_buffer(bad, on_problem=problems.append)
        assert len(problems) == 1 and "damaged length" in problems[0]
        newest = max(f["most_recent_transform"].nanoseconds for f in buf.frame_info() if not f["static"])
        assert newest > transforms(seed=2, messages=3000, frames=8)[-1][2] - (5 if summary else 40) * 10**9


def test_a_damaged_ros1_chunk_is_named_not_an_empty_assertion(tmp_path):
    from zentf.tools.bag import bag_info, load_buffer

    from bag_generate import transforms, write_ros1

    path = write_ros1(tmp_path / "r.bag", transforms(seed=4, messages=2000, frames=6), "lz4")
    data = bytearray(path.read_bytes())
    mid = len(data) // 2
    data[mid:mid + 64] = b"\xa5" * 64
    bad = tmp_path / "bad.bag"
    bad.write_bytes(bytes(data))
    info = bag_info(bad)
    line = info["problem"]
    assert "AssertionError" not in line and re.search(r"chunk at byte \d+ \(\w+", line), line
    assert info["messages"] > 1000
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "bag", "info", str(bad)], capture_output=True, text=True,
                       timeout=60, cwd=REPO)
    assert r.stderr.count("\n") == 1 and "AssertionError" not in r.stderr and "chunk at byte" in r.stderr, r.stderr
    problems = []
    load_buffer(bad, on_problem=problems.append)
    assert len(problems) == 1 and "AssertionError" not in problems[0] and "chunk at byte" in problems[0]
