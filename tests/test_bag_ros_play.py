"""ROS bags over Zenoh: play nav2 with --clock into a use_sim_time listener process, ROS topics and payloads
as zentf's, latched /tf_static, record --format ros2 from a live graph, damaged bags play their readable part."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from bag_reference import NAV2, ROS1, ROS2_DIR, reference_core, rosbags_transforms
from conftest import REPO, child_env

pytest.importorskip("rosbags")

ZENTF = [sys.executable, "-m", "zentf.cli"]
LISTENER = str(Path(__file__).resolve().parent / "bag_sim_listener.py")


@pytest.fixture
def own_env(isolated_router: str, test_namespace: str) -> dict[str, str]:
    """Own router: /clock is absolute, so only a private router keeps it from other tests."""
    return child_env(isolated_router, test_namespace)


class Collector:
    """Keeps the payloads of one key (raw Zenoh subscriber)."""

    def __init__(self, session, key: str) -> None:
        self.payloads: list[bytes] = []
        self.encodings: set[str] = set()
        self.lock = threading.Lock()
        self.sub = session.declare_subscriber(key, self._on)

    def _on(self, s) -> None:
        with self.lock:
            self.payloads.append(s.payload.to_bytes())
            self.encodings.add(str(s.encoding))


def test_nav2_played_with_clock_into_a_sim_time_listener_gives_the_reference_lookups(spawn, own_env, tmp_path):
    from zentf.core.exceptions import TransformException
    from zentf.core.time import Time

    ref = reference_core(NAV2)
    stamps = sorted({s for topic, _, c, s, _, _ in rosbags_transforms(NAV2) if c == "base_link"})
    picked = stamps[len(stamps) // 8:: len(stamps) // 12][:10]  # well after the first messages
    queries = []
    for s in picked:
        for t in (s, s + 7_000_000):  # a sample's exact stamp and a time between two samples
            queries += [["odom", "base_link", t], ["map", "oakd_rgb_camera_optical_frame", t],
                        ["base_footprint", "odom", t]]
    qfile = tmp_path / "queries.json"
    qfile.write_text(json.dumps(queries))
    # nav2's tf is stamped in Gazebo time and was recorded with a wall clock: the played /clock follows
    # the stamps (see Player.clock_offset), so the listener waits for the last stamps' time
    end = stamps[-1]
    listener = spawn.python(LISTENER, "-p", "use_sim_time:=true", "--until", str(end - 10**9),
                            "--queries", str(qfile), "--timeout", "120", env=own_env)
    listener.wait_for_line(r'"ready": true', 30)
    play = spawn([*ZENTF, "bag", "play", str(NAV2), "--clock", "--rate", "10", "--delay", "0.5"], env=own_env)
    line = listener.wait_for_line(r"^\{\"(at|error)\".*", 120).group(0)
    assert listener.wait(20) == 0, listener.output()
    answers = json.loads(line)["answers"]
    assert play.wait(60) == 0, play.output()
    assert re.search(r"played 8197 msgs", play.output()) and "warning" not in play.output()
    matched = 0
    for (target, source, t), got in zip(queries, answers):
        try:
            want = ref.lookup_transform(target, source, Time(nanoseconds=t)).transform
        except TransformException as e:
            assert got == type(e).__name__, (target, source, t)
            continue
        assert got == pytest.approx([want.translation.x, want.translation.y, want.translation.z, want.rotation.x,
                                     want.rotation.y, want.rotation.z, want.rotation.w], abs=1e-12), (target, t)
        matched += 1
    assert matched >= 50, answers


def test_ros_topics_become_zentf_topics_with_zentf_payloads(spawn, zenoh_session, test_namespace):
    """nav2's /odom plays on <ns>/odom as msgpack Odometry equal to rosbags' decode; /amcl_pose is latched."""
    from rosbags.highlevel import AnyReader

    from zentf.tools.bag.plain import to_plain
    from zentf.transport.wire.codec import unpack

    odom = Collector(zenoh_session, f"{test_namespace}/odom")
    tf = Collector(zenoh_session, f"{test_namespace}/tf")
    play = spawn([*ZENTF, "bag", "play", str(NAV2), "--topics", "/odom,amcl_pose", "--rate", "25", "--start", "80",
                  "--delay", "0.5"])
    assert play.wait(60) == 0, play.output()
    assert "Traceback" not in play.output()
    with AnyReader([NAV2]) as r:
        conns = [c for c in r.connections if c.topic == "/odom"]
        want = [to_plain(r.deserialize(raw, c.msgtype)) for c, t, raw in r.messages(connections=conns)
                if t >= r.start_time + 80 * 10**9]
    got = [unpack(p) for p in odom.payloads]
    assert odom.encodings == {"application/msgpack;nav_msgs/msg/Odometry"} and not tf.payloads
    assert len(want) - 3 <= len(got) <= len(want)  # a fresh publisher's very first put may be lost
    by_stamp = {(w["header"]["stamp"]["sec"], w["header"]["stamp"]["nanosec"]): w for w in want}
    for g in got:
        w = by_stamp[(g["header"]["stamp"]["sec"], g["header"]["stamp"]["nanosec"])]
        assert g == w
    # /amcl_pose is transient local in the bag: a subscriber joining after the play still gets the last one
    import zenoh.ext as zx

    late: list[bytes] = []
    ev = threading.Event()
    sub = zx.declare_advanced_subscriber(zenoh_session, f"{test_namespace}/amcl_pose",
                                         lambda s: (late.append(s.payload.to_bytes()), ev.set()),
                                         history=zx.HistoryConfig(detect_late_publishers=True))
    play = spawn([*ZENTF, "bag", "play", str(NAV2), "--topics", "amcl_pose", "--start", "90", "--loop"])
    assert ev.wait(30), play.output()
    assert "pose" in unpack(late[0])
    sub.undeclare()
    play.signal(2)
    assert play.wait(20) == 0


@pytest.mark.parametrize("bag", [ROS1, ROS2_DIR], ids=["ros1_bag", "ros2_sqlite_folder"])
def test_ros1_and_sqlite_bags_play_tf_and_a_late_joiner_gets_tf_static(spawn, test_namespace, bag):
    play = spawn([*ZENTF, "bag", "play", str(bag), "--loop", "--rate", "5"])
    play.wait_for_line(r"playing: t = [1-9]", 30)
    listener = spawn.python("-m", "nodes.frame_listener", "-p", "target_frame:=odom", "-p", "source_frame:=base_link",
                            "-p", "period:=0.2")
    m = listener.wait_for_line(r"base_link in odom: translation \((-?[\d.]+), (-?[\d.]+), (-?[\d.]+)\)", 30)
    assert all(abs(float(v)) < 100 for v in m.groups())  # needs /tf and the latched base_footprint->base_link
    play.signal(2)
    assert play.wait(20) == 0, play.output()


def test_record_format_ros2_from_a_live_graph(spawn, tmp_path, test_namespace):
    """record --format ros2: a rosbag2 MCAP that rosbags and mcap-ros2-support read, with ROS names and QoS."""
    pytest.importorskip("mcap_ros2")
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader

    frames = spawn.python("-m", "nodes.frames_publisher")
    static = spawn.python("-m", "nodes.static_transform_publisher", "0", "0", "-0.5", "0", "0", "0", "world",
                          "ground")
    frames.wait_for_line(r"publishing av1 and av2", 20)
    static.wait_for_line(r"Spinning until stopped", 20)
    out = tmp_path / "live.mcap"
    rec = spawn([*ZENTF, "bag", "record", "tf", "tf_static", "--format", "ros2", "-o", str(out), "--duration", "2"])
    assert rec.wait(30) == 0, rec.output()
    n = int(rec.wait_for_line(r"recorded (\d+) msgs", 1, from_start=True).group(1))
    with AnyReader([out]) as r:
        topics = {c.topic: (c.msgtype, c.ext.offered_qos_profiles[0].durability.name) for c in r.connections}
        msgs = [(c.topic, r.deserialize(raw, c.msgtype)) for c, _, raw in r.messages()]
    assert topics == {f"/{test_namespace}/tf": ("tf2_msgs/msg/TFMessage", "VOLATILE"),
                      f"/{test_namespace}/tf_static": ("tf2_msgs/msg/TFMessage", "TRANSIENT_LOCAL")}
    assert len(msgs) == n and n >= 20
    static_msg = next(m for t, m in msgs if t.endswith("tf_static"))
    ts = static_msg.transforms[0]
    assert (ts.header.frame_id, ts.child_frame_id, ts.transform.translation.z) == ("world", "ground", -0.5)
    assert {t.child_frame_id for _, m in msgs for t in m.transforms} == {"ground", "av1", "av2"}
    with open(out, "rb") as f:
        decoded = list(make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    assert len(decoded) == n


def test_a_truncated_ros_bag_plays_its_readable_part(spawn, zenoh_session, test_namespace, tmp_path):
    data = NAV2.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    info = json.loads(subprocess.run([*ZENTF, "bag", "info", str(cut), "--json"], capture_output=True, text=True,
                                     timeout=60, cwd=REPO).stdout)
    readable = {t["key"]: t["count"] for t in info["topics"]}
    assert 0 < readable["/odom"] < 2639
    odom = Collector(zenoh_session, f"{test_namespace}/odom")
    play = spawn([*ZENTF, "bag", "play", str(cut), "--topics", "odom", "--rate", "50", "--delay", "0.5"])
    assert play.wait(60) == 0, play.output()
    out = play.output()
    assert re.search(r"zentf: warning: .*cut\.mcap: the chunk at byte \d+ is cut by the end of the file \(truncated at "
                     r"byte \d+\); kept its first \d+ messages; read \d+ messages; played the readable part", out), out
    assert "Traceback" not in out and out.count("warning") == 1
    assert readable["/odom"] - 3 <= len(odom.payloads) <= readable["/odom"]
