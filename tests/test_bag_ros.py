"""ROS recordings without a network: read every format, info, the offline buffer against rosbags,
convert both ways (read back with rosbags and mcap-ros2-support), damaged and unknown files."""
from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bag_reference import FIXTURES, NAV2, ROS1, ROS2_DB3, ROS2_DIR, pairs_for, reference_core, rosbags_transforms
from conftest import REPO

pytest.importorskip("rosbags")

ZENTF = [sys.executable, "-m", "zentf.cli"]
DRONES = REPO / "configs" / "recordings" / "drones.mcap"


def run(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run([*ZENTF, *args], capture_output=True, text=True, timeout=120, cwd=REPO)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def same_ts(a, b) -> None:
    assert a.header.frame_id == b.header.frame_id and a.child_frame_id == b.child_frame_id
    assert a.header.stamp.nanoseconds == b.header.stamp.nanoseconds
    ta, tb = a.transform, b.transform
    for x, y in zip((ta.translation.x, ta.translation.y, ta.translation.z, ta.rotation.x, ta.rotation.y,
                     ta.rotation.z, ta.rotation.w),
                    (tb.translation.x, tb.translation.y, tb.translation.z, tb.rotation.x, tb.rotation.y,
                     tb.rotation.z, tb.rotation.w)):
        assert x == pytest.approx(y, abs=1e-12)


def outcome(core, target: str, source: str, t: int):
    """The lookup's result, or the exception's class name (errors must match too)."""
    from zentf.core.exceptions import TransformException
    from zentf.core.time import Time

    try:
        return core.lookup_transform(target, source, Time(nanoseconds=t))
    except TransformException as e:
        return type(e).__name__


# ---------------------------------------------------------------- the offline buffer


@pytest.fixture(scope="module")
def loaded():
    from zentf.tools.bag import load_buffer

    return {name: (load_buffer(path), reference_core(path)) for name, path in FIXTURES.items()}


@pytest.mark.parametrize("name", list(FIXTURES))
def test_load_buffer_answers_like_rosbags_sample_by_sample(loaded, name):
    buf, ref = loaded[name]
    path = FIXTURES[name]
    assert sorted(buf.get_frames()) == sorted(ref.get_frames())
    stamps = sorted({s for topic, _, _, s, _, _ in rosbags_transforms(path) if topic == "/tf"})
    exact = stamps[:: max(1, len(stamps) // 60)]
    between = [(a + b) // 2 for a, b in zip(exact, exact[1:])]
    outside = [stamps[0] - 10**9, stamps[-1] + 10**9]
    checked = 0
    for target, source in pairs_for(path):
        for t in [0, *exact, *between, *outside]:
            got, want = outcome(buf, target, source, t), outcome(ref, target, source, t)
            if isinstance(want, str):
                assert got == want, (target, source, t)
            else:
                assert not isinstance(got, str), (target, source, t, got)
                same_ts(got, want)
                checked += 1
    assert checked > 100
    # the batch API (lookup_transforms) over the span agrees with the reference's one-by-one lookups
    import numpy as np

    from zentf.core.time import Time

    target, source = pairs_for(path)[0]
    latest = ref.get_latest_common_time(target, source).nanoseconds
    first = stamps[len(stamps) // 10]
    times = np.array([first + (latest - first) * i // 49 for i in range(50)], dtype=np.int64)
    trans, quats = buf.lookup_transforms(target, source, times)
    for t, tr, q in zip(times, trans, quats):
        r = ref.lookup_transform(target, source, Time(nanoseconds=int(t))).transform
        assert list(tr) == pytest.approx([r.translation.x, r.translation.y, r.translation.z], abs=1e-9)
        assert list(q) == pytest.approx([r.rotation.x, r.rotation.y, r.rotation.z, r.rotation.w], abs=1e-9)


def test_load_buffer_holds_the_whole_recording(loaded):
    buf, _ = loaded["nav2_mcap"]
    stamps = [s for topic, _, _, s, _, _ in rosbags_transforms(NAV2) if topic == "/tf"]
    assert buf.cache_time.nanoseconds == max(stamps) - min(stamps)  # the span, not tf2's 10 s
    info = {f["frame"]: f for f in buf.frame_info()}
    assert info["base_link"]["oldest_transform"].nanoseconds == min(
        s for topic, _, c, s, _, _ in rosbags_transforms(NAV2) if c == "base_link")
    assert len(info) == 33  # every child frame of the nav2 run, statics included


def test_zentf_bag_load_buffer_is_reachable_by_its_documented_name():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import zentf.tools.bag
    from zentf.tools.bag import load_buffer

    assert zentf.tools.bag.load_buffer is load_buffer
    buf = zentf.tools.bag.load_buffer(DRONES)  # zentf's own MCAP too
    ts = buf.lookup_transform("world", "ground", 0)
    assert (ts.transform.translation.z, len(buf.get_frames())) == (-0.5, 4)


# ---------------------------------------------------------------- info


@pytest.mark.parametrize("name,fmt,encoding", [("nav2_mcap", "ROS 2 rosbag2 MCAP", "cdr"),
                                               ("ros1_bag", "ROS 1 bag", "ros1"),
                                               ("ros2_folder", "ROS 2 rosbag2 SQLite3", "cdr"),
                                               ("ros2_db3", "ROS 2 rosbag2 SQLite3", "cdr")])
def test_info_every_format(name, fmt, encoding):
    info = json.loads(run("bag", "info", str(FIXTURES[name]), "--json").stdout)
    assert info["format"].startswith(fmt) and info["encoding"] == encoding and info["complete"]
    counts = {t["key"]: t["count"] for t in info["topics"]}
    types = {t["key"]: t["type"] for t in info["topics"]}
    assert types["/tf"] == types["/tf_static"] == "tf2_msgs/msg/TFMessage"
    if name == "nav2_mcap":
        assert counts == {"/tf": 5422, "/tf_static": 1, "/odom": 2639, "/amcl_pose": 135}
        assert types["/odom"] == "nav_msgs/msg/Odometry"
        assert info["duration"] == pytest.approx(97.355, abs=1e-3)
        assert len(info["frames"]) == 34  # 33 child frames and the root, map
        assert ["odom", "base_link"] in info["tf_edges"]["tf"] and ["map", "odom"] in info["tf_edges"]["tf"]
        assert len(info["tf_edges"]["tf"]) == 4 and len(info["tf_edges"]["tf_static"]) == 29
    else:
        assert counts == {"/tf": 517, "/tf_static": 1}
        assert info["duration"] == pytest.approx(51.685, abs=1e-3)
        assert info["frames"] == ["base_footprint", "base_link", "odom"]
    rate = next(t["frequency"] for t in info["topics"] if t["key"] == "/tf")
    assert rate == pytest.approx(55.68 if name == "nav2_mcap" else 10.0, abs=0.01)
    text = run("bag", "info", str(FIXTURES[name])).stdout
    assert re.search(r"format:\s+" + re.escape(info["format"]), text)
    assert re.search(r"/tf\s+\d+ msgs\s+[\d.]+ Hz\s+tf2_msgs/msg/TFMessage", text)
    assert re.search(r"^/tf_static: \d+ transforms? between \d+ frames$", text, re.M) and "odom -> base" in text
    if name != "nav2_mcap":  # one edge under each topic: two frames each
        assert "\n/tf: 1 transform between 2 frames\n  odom -> base_footprint\n" in text


def test_info_names_topics_as_topic_list_does_and_counts_edges_and_frames():
    """A zentf recording keeps Zenoh keys ('tf'); info shows the topic names `topic list` prints."""
    info = json.loads(run("bag", "info", str(DRONES), "--json").stdout)
    assert {t["key"]: t["topic"] for t in info["topics"]} == {
        "tf": "/tf", "tf_static": "/tf_static", "visual_markers": "/visual_markers"}
    text = run("bag", "info", str(DRONES)).stdout
    assert re.search(r"^  /tf +501 msgs", text, re.M) and not re.search(r"^  tf ", text, re.M)
    assert "\n/tf: 2 transforms between 3 frames\n  world -> av1\n  world -> av2\n" in text


def test_a_rosbag2_metadata_yaml_stands_for_its_folder():
    """ros2 bag tools take a bag's folder or its metadata.yaml; so does every zentf bag command."""
    meta = ROS2_DIR / "metadata.yaml"
    by_meta = json.loads(run("bag", "info", str(meta), "--json").stdout)
    by_dir = json.loads(run("bag", "info", str(ROS2_DIR), "--json").stdout)
    assert {k: v for k, v in by_meta.items() if k != "path"} == {k: v for k, v in by_dir.items() if k != "path"}
    r = run("tf", "echo", "odom", "base_link", "--bag", str(meta))
    assert r.stdout.startswith("At time ") and "- Translation:" in r.stdout


def test_unknown_formats_are_named_in_one_line(tmp_path):
    cases = {"text.bag": b"hello world\n", "empty.mcap": b"", "pic.db3": b"\x89PNG\r\n\x1a\n" + bytes(64),
             "zip.bag": b"PK\x03\x04" + bytes(40)}
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder" / "notes.txt").write_text("x")
    want = {"text.bag": "a text file starting 'hello world'", "empty.mcap": "an empty file",
            "pic.db3": "a PNG image", "zip.bag": "a zip archive", "folder": "found: notes.txt"}
    for name, found in want.items():
        for cmd in (["bag", "info"], ["bag", "play"], ["tf", "echo", "a", "b", "--bag"]):
            r = run(*cmd, str(tmp_path / name), check=False)
            assert r.returncode == 1 and r.stderr.count("\n") == 1 and found in r.stderr, (cmd, r.stderr)
            assert r.stderr.startswith("zentf: error: ") and "Traceback" not in r.stderr


# ---------------------------------------------------------------- convert


def plain_of_rosbags(msg):
    from zentf.tools.bag.plain import to_plain

    return to_plain(msg)


def close(a, b, path="") -> None:
    """Plain values equal (floats to float32 precision)."""
    if isinstance(a, dict):
        for k in a:
            close(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            close(x, y, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):  # float32 fields (colors) round to 7 digits
        assert float(a) == pytest.approx(float(b), rel=1e-7, abs=1e-12), path
    else:
        assert a == b, path


@pytest.mark.parametrize("name", ["nav2_mcap", "ros1_bag", "ros2_folder"])
def test_convert_ros_to_zentf_keeps_every_message(tmp_path, name):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    from zentf.tools.bag import BagReader
    from zentf.transport.wire.codec import unpack

    out = tmp_path / "out.mcap"
    r = run("bag", "convert", str(FIXTURES[name]), str(out))
    assert re.match(r"wrote .*out\.mcap: \d+ msgs as zentf", r.stdout)
    got = [m for m in BagReader(out)]
    with AnyReader([FIXTURES[name]], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        want = [(c.topic, t, plain_of_rosbags(reader.deserialize(raw, c.msgtype)))
                for c, t, raw in reader.messages()]
    assert len(got) == len(want)
    want.sort(key=lambda w: (w[1], w[0]))
    got.sort(key=lambda m: (m.log_time, "/" + m.key))
    for m, (topic, t, plain) in zip(got, want):
        assert ("/" + m.key, m.log_time) == (topic, t)
        assert m.encoding == f"application/msgpack;{m.type_name}"
        assert m.latched == (topic == "/tf_static" or topic == "/amcl_pose")  # transient local in nav2
        close(plain, unpack(m.payload))
    # what zentf decodes from the converted file is what zentf decodes from the original
    from zentf.tools.bag import load_buffer

    a, b = load_buffer(out), load_buffer(FIXTURES[name])
    target, source = pairs_for(FIXTURES[name])[0]
    same_ts(a.lookup_transform(target, source, 0), b.lookup_transform(target, source, 0))


def test_round_trip_drones_to_ros2_mcap_read_back_by_rosbags_and_mcap_ros2(tmp_path):
    """zentf MCAP -> ROS 2 MCAP (single file and rosbag2 folder) -> two independent readers -> same messages."""
    pytest.importorskip("mcap_ros2")
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    from zentf.tools.bag import BagReader
    from zentf.transport.wire.codec import unpack

    original = [(("/" + m.key), m.log_time, unpack(m.payload), m.type_name) for m in BagReader(DRONES)]
    assert len(original) == 553
    single, folder = tmp_path / "drones_ros2.mcap", tmp_path / "drones_ros2"
    run("bag", "convert", str(DRONES), str(single))
    run("bag", "convert", str(DRONES), str(folder), "--to", "ros2")
    assert (folder / "metadata.yaml").is_file()

    for path in (single, folder):
        with AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:  # the bag's own schemas
            back = [(c.topic, t, plain_of_rosbags(reader.deserialize(raw, c.msgtype)), c.msgtype)
                    for c, t, raw in reader.messages()]
            qos = {c.topic: c.ext.offered_qos_profiles[0].durability.name for c in reader.connections}
        assert [(b[0], b[1], b[3]) for b in back] == [(o[0], o[1], o[3]) for o in original]
        for o, b in zip(original, back):
            close(o[2], b[2])
        assert qos == {"/tf": "VOLATILE", "/tf_static": "TRANSIENT_LOCAL", "/visual_markers": "VOLATILE"}

    with open(single, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        assert {s.encoding for s in reader.get_summary().schemas.values()} == {"ros2msg"}
        assert any(m.name == "rosbag2" for m in reader.iter_metadata())
        decoded = list(reader.iter_decoded_messages())
    assert len(decoded) == len(original)
    for (topic, t, plain, _), (_, channel, message, msg) in zip(original, decoded):
        assert (channel.topic, message.log_time) == (topic, t)
        if topic.endswith("tf") or topic.endswith("tf_static"):
            for want, got in zip(plain["transforms"], msg.transforms):
                assert (got.header.frame_id, got.child_frame_id) == (want["header"]["frame_id"],
                                                                    want["child_frame_id"])
                assert got.header.stamp.sec == want["header"]["stamp"]["sec"]
                assert got.header.stamp.nanosec == want["header"]["stamp"]["nanosec"]
                tr = want["transform"]
                assert [got.transform.translation.x, got.transform.translation.y, got.transform.translation.z,
                        got.transform.rotation.w] == pytest.approx(
                    [tr["translation"]["x"], tr["translation"]["y"], tr["translation"]["z"], tr["rotation"]["w"]],
                    abs=1e-12)
        else:
            assert [mk.text for mk in msg.markers] == [mk["text"] for mk in plain["markers"]]
            # flat lists: pytest.approx compares sequences of numbers, not nested ones
            assert [c for p in msg.markers[0].points for c in (p.x, p.y, p.z)] == pytest.approx(
                [p[k] for p in plain["markers"][0]["points"] for k in "xyz"], abs=1e-12)
    r = run("bag", "convert", str(DRONES), str(single), check=False)
    assert r.returncode == 2 and "exists already" in r.stderr


def test_a_type_that_cannot_be_carried_is_skipped_with_one_line(tmp_path):
    """A ROS 2 bag whose topic has a type with no usable definition: the rest converts, one line says so."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    bag = tmp_path / "odd"
    with Writer(bag, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        tf = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store)
        odd = w.add_connection("/odd", "my_pkg/msg/Odd", msgdef="this is ! not a msg definition",
                               rihs01="RIHS01_" + "0" * 64)
        msg = store.types["tf2_msgs/msg/TFMessage"](transforms=[])
        for i in range(3):
            w.write(tf, 10 + i, bytes(store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage")))
            w.write(odd, 11 + i, b"\x00\x01\x00\x00junk")
    out = tmp_path / "odd.mcap"
    r = run("bag", "convert", str(bag), str(out))
    assert re.search(r"^zentf: skipping /odd: type my_pkg/msg/Odd cannot be carried: .*\n$", r.stderr), r.stderr
    assert "wrote" in r.stdout and "3 msgs" in r.stdout


# ---------------------------------------------------------------- damaged files


def damaged_copies(tmp_path: Path, name: str) -> dict[str, Path]:
    """A truncated and a corrupted copy of a fixture (a folder's storage file is damaged in place)."""
    out = {}
    for kind in ("truncated", "corrupt"):
        src = FIXTURES[name]
        if src.is_dir():
            dst = tmp_path / f"{kind}_{name}"
            shutil.copytree(src, dst)
            target = dst / "tf_example.db3"
        else:
            dst = tmp_path / f"{kind}_{src.name}"
            shutil.copy(src, dst)
            target = dst
        target.chmod(0o644)
        data = bytearray(target.read_bytes())
        if kind == "truncated":
            data = data[: len(data) * 2 // 3]
        else:
            mid = len(data) // 2
            data[mid: mid + 200] = b"\xa5" * 200
        target.write_bytes(bytes(data))
        out[kind] = dst
    return out


@pytest.mark.parametrize("name", list(FIXTURES))
def test_damaged_copies_of_every_fixture_say_where_they_stopped(tmp_path, name):
    from zentf.tools.bag import load_buffer

    full = json.loads(run("bag", "info", str(FIXTURES[name]), "--json").stdout)["messages"]
    for kind, path in damaged_copies(tmp_path, name).items():
        r = run("bag", "info", str(path), check=False)
        assert "Traceback" not in r.stderr, r.stderr
        lines = r.stderr.splitlines()
        assert len(lines) == 1, r.stderr
        if r.returncode == 0:
            assert re.match(r"zentf: warning: .*(truncated|damaged|stopped|no index|malformed)", lines[0]), lines[0]
            info = json.loads(run("bag", "info", str(path), "--json", check=False).stdout)
            assert not info["complete"] and info["messages"] < full
        else:  # a database whose header itself is gone: nothing readable, one error line
            assert r.returncode == 1 and lines[0].startswith("zentf: error: ") and name.startswith("ros2_")
            continue
        problems = []
        buf = load_buffer(path, on_problem=problems.append)
        assert len(problems) == 1 and "readable part" in problems[0]
        e = run("tf", "echo", "--bag", str(path), *pairs_for(FIXTURES[name])[0], check=False)
        assert "Traceback" not in e.stderr and e.stderr.count("\n") in (1, 2), e.stderr
        if buf.get_frames():
            assert e.returncode == 0 and e.stdout.startswith("At time ")
            # what was read is the bag's own data: the readable part answers like the whole bag there
            from zentf.core.time import Time

            target, source = pairs_for(FIXTURES[name])[0]
            at = buf.get_latest_common_time(target, source)
            same_ts(buf.lookup_transform(target, source, at), reference_core(FIXTURES[name]).lookup_transform(
                target, source, Time(nanoseconds=at.nanoseconds)))


def test_ros1_bag_without_its_index_is_read_linearly(tmp_path):
    """A killed ROS 1 recorder leaves no index: rosbags refuses it, zentf's linear scan reads it."""
    from rosbags.rosbag1 import Reader

    from zentf.core.time import Time
    from zentf.tools.bag import load_buffer

    data = ROS1.read_bytes()
    ref = reference_core(ROS1)
    ref_newest = max(f["most_recent_transform"].nanoseconds for f in ref.frame_info() if not f["static"])
    for cut_at, all_there in ((len(data) - 3000, True), (len(data) * 2 // 3, False)):  # index gone / data too
        cut = tmp_path / f"cut{cut_at}.bag"
        cut.write_bytes(data[:cut_at])
        with pytest.raises(Exception):
            with Reader(cut):
                pass
        problems = []
        buf = load_buffer(cut, on_problem=problems.append)
        assert len(problems) == 1 and re.search(r"stopped at byte \d+ .*truncated at byte \d+", problems[0])
        if not all_there:  # the bag's one lz4 chunk is cut: its single block cannot be decoded
            assert buf.get_frames() == []
            continue
        newest = max(f["most_recent_transform"].nanoseconds for f in buf.frame_info() if not f["static"])
        assert newest == ref_newest
        for t in (newest, newest - 250_000_000):
            at = Time(nanoseconds=t)
            same_ts(buf.lookup_transform("odom", "base_link", at), ref.lookup_transform("odom", "base_link", at))


def test_tf_echo_bag_prints_the_pose_at_a_time(tmp_path):
    ref = reference_core(NAV2)
    from zentf.core.time import Time

    want = ref.lookup_transform("map", "oakd_rgb_camera_optical_frame", Time(nanoseconds=1000_250_000_000))
    r = run("tf", "echo", "map", "oakd_rgb_camera_optical_frame", "--bag", str(NAV2), "--time", "1000.25",
            "-p", "6")
    assert r.stdout.startswith("At time 1000.250000000")
    tr = want.transform.translation
    assert f"- Translation: [{tr.x:.6f}, {tr.y:.6f}, {tr.z:.6f}]" in r.stdout
    r = run("tf", "echo", "map", "base_link", "--bag", str(ROS1), check=False)
    assert r.returncode == 1 and r.stderr.startswith("zentf: error: no transform map -> base_link in ")


def test_without_rosbags_a_ros_bag_is_one_line_and_zentf_bags_still_work():
    """rosbags is the 'ros' extra: without it ROS bags say how to install it, zentf's own bags work."""
    block = "import sys; sys.modules['rosbags'] = None; from zentf.cli import main; "
    for path, code, text in ((NAV2, 1, "needs the 'rosbags' package: pip install 'zentf[ros]'"),
                             (ROS1, 1, "needs the 'rosbags' package"), (DRONES, 0, "zentf MCAP")):
        r = subprocess.run([sys.executable, "-c", block + f"sys.exit(main(['bag', 'info', {str(path)!r}]))"],
                           capture_output=True, text=True, timeout=60, cwd=REPO)
        assert r.returncode == code and text in (r.stderr if code else r.stdout), r.stderr
        assert "Traceback" not in r.stderr and r.stderr.count("\n") <= 1


def test_topics_filter_takes_ros_and_zentf_names(tmp_path):
    from zentf.tools.bag import BagWriter, open_bag

    ros = [m.key for m in open_bag(NAV2).zentf(["tf_static", "/amcl_pose"])]
    assert set(ros) == {"tf_static", "amcl_pose"} and len(ros) == 136
    path = tmp_path / "ns.mcap"
    with BagWriter(path, namespace="r1") as w:  # a zentf bag recorded under a namespace
        for key in ("r1/tf", "r1/odom"):
            w.write(key, b"\x80", "application/msgpack;tf2_msgs/msg/TFMessage")
    assert [m.key for m in open_bag(path).zentf(["/tf"])] == ["r1/tf"]
    assert [m.key for m in open_bag(path).zentf(["r1/odom"])] == ["r1/odom"]
