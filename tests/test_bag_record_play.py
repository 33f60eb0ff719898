"""`zentf bag`: record the live drones demo, replay it with --clock into sim-time nodes, info, bad files."""
from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from conftest import REPO, child_env

NUM = r"(-?\d+\.\d+)"
TRIPLE = rf"\({NUM}, {NUM}, {NUM}\)"
ZENTF = [sys.executable, "-m", "zentf.cli"]


def on_ellipse(x: float, y: float, z: float) -> bool:
    """av2 seen from av1 lies on the ellipse of frames_publisher's docstring."""
    u = x + 1.0
    v = ((y + 0.5) + 2 * z) / math.sqrt(5)
    return abs(2 * y - z + 1) < 3e-3 and abs((u / 0.5) ** 2 + (v / (math.sqrt(5) / 2)) ** 2 - 1.0) < 1.5e-2


@pytest.fixture
def own_env(isolated_router: str, test_namespace: str) -> dict[str, str]:
    """Own router: /clock is absolute, so only a private router keeps it from other tests."""
    return child_env(isolated_router, test_namespace)


def info_json(path: Path, env: dict[str, str] | None = None) -> dict:
    r = subprocess.run([*ZENTF, "bag", "info", str(path), "--json"], capture_output=True, text=True, timeout=30,
                       env=env, cwd=REPO)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def counts(info: dict) -> dict[str, int]:
    return {t["key"].rsplit("/", 1)[-1]: t["count"] for t in info["topics"]}


def test_record_drones_then_play_with_clock_into_a_sim_time_listener(spawn, own_env, tmp_path, test_namespace):
    bag = tmp_path / "drones.mcap"
    frames = spawn.python("-m", "nodes.frames_publisher", env=own_env)
    static = spawn.python("-m", "nodes.static_transform_publisher", "0", "0", "-0.5", "0", "0", "0",
                          "world", "ground", env=own_env)
    frames.wait_for_line(r"publishing av1 and av2", 20)
    static.wait_for_line(r"Spinning until stopped", 20)
    rec = spawn([*ZENTF, "bag", "record", "tf", "tf_static", "-o", str(bag), "--duration", "2.5"], env=own_env)
    rec.wait_for_line(r"recording .* to ", 20)
    assert rec.wait(20) == 0, rec.output()
    recorded = int(rec.wait_for_line(r"recorded (\d+) msgs", 1, from_start=True).group(1))
    frames.stop()
    static.stop()

    info = info_json(bag)
    assert info["complete"] and info["messages"] == recorded
    c = counts(info)
    assert c["tf_static"] >= 1  # the latched set, fetched from the publisher's cache
    assert 30 <= c["tf"] <= 140, c  # 50 Hz for ~2.5 s (fewer on a loaded machine)
    assert c["tf"] + c["tf_static"] == recorded
    assert all(t["key"].startswith(test_namespace + "/") for t in info["topics"])

    # Sim-time trails node: its timer only runs if /clock comes from the player. Looping the bag
    # makes the test independent of how fast the node starts.
    plots = spawn.python("-m", "nodes.plots_publisher", "-p", "use_sim_time:=true", "-p", "rate:=20", env=own_env)
    play = spawn([*ZENTF, "bag", "play", str(bag), "--clock", "--loop", "--delay", "0.5"], env=own_env)
    pts = [tuple(float(g) for g in plots.wait_for_line(rf"av2 in av1: {TRIPLE}", 30).groups()) for _ in range(8)]
    play.signal(2)
    assert play.wait(20) == 0, play.output()
    assert all(on_ellipse(*p) for p in pts), pts
    assert len(set(pts)) > 4  # it moves along the ellipse with the bag's clock
    assert int(play.wait_for_line(r"played (\d+) msgs", 1, from_start=True).group(1)) > 0
    assert "warning" not in play.output()


def test_latched_tf_static_reaches_a_late_joiner_during_playback(spawn, zenoh_env, tmp_path):
    bag = tmp_path / "demo.mcap"
    r = subprocess.run([*ZENTF, "bag", "demo", "-o", str(bag), "--duration", "30"], capture_output=True,
                       text=True, timeout=30, cwd=REPO)
    assert r.returncode == 0, r.stderr
    play = spawn([*ZENTF, "bag", "play", str(bag)])
    play.wait_for_line(r"playing: t = [1-9]\.\d s", 20)  # tf_static (t = 0) went out a second ago
    listener = spawn.python("-m", "nodes.frame_listener", "-p", "target_frame:=world", "-p", "source_frame:=ground",
                            "-p", "period:=0.2")
    m = listener.wait_for_line(rf"ground in world: translation {TRIPLE}", 15)
    assert tuple(float(g) for g in m.groups()) == (0.0, 0.0, -0.5)
    play.signal(2)
    assert play.wait(10) == 0
    assert re.search(r"played \d+ msgs", play.output())


def test_demo_bag_info_counts(tmp_path):
    bag = tmp_path / "d.mcap"
    r = subprocess.run([*ZENTF, "bag", "demo", "-o", str(bag), "--duration", "2"], capture_output=True, text=True,
                       timeout=30, cwd=REPO)
    assert r.returncode == 0 and "wrote" in r.stdout, r.stderr
    info = info_json(bag)
    assert counts(info) == {"tf": 101, "tf_static": 1, "visual_markers": 11}
    assert info["messages"] == 113 and info["complete"]
    assert info["duration"] == pytest.approx(2.0, abs=0.01)
    text = subprocess.run([*ZENTF, "bag", "info", str(bag)], capture_output=True, text=True, timeout=30, cwd=REPO)
    assert re.search(r"tf\s+101 msgs\s+50\.00 Hz\s+tf2_msgs/msg/TFMessage", text.stdout), text.stdout
    assert "(latched)" in text.stdout
    shipped = info_json(REPO / "configs" / "recordings" / "drones.mcap")  # the newcomer's recording
    assert shipped["complete"] and counts(shipped) == {"tf": 501, "tf_static": 1, "visual_markers": 51}


class Counter:
    """Counts samples on one key with a raw Zenoh subscriber."""

    def __init__(self, session, key: str) -> None:
        self.n = 0
        self.lock = threading.Lock()
        self.sub = session.declare_subscriber(key, self._on)

    def _on(self, _s) -> None:
        with self.lock:
            self.n += 1


def test_truncated_and_corrupt_bags_are_reported_and_the_rest_plays(spawn, zenoh_session, test_namespace, tmp_path):
    from zentf.tools.bag import write_drones_demo

    full = tmp_path / "full.mcap"
    write_drones_demo(full, 4.0)
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 2 // 3])
    bad = tmp_path / "bad.mcap"
    b = bytearray(data)
    b[len(b) // 3: len(b) // 3 + 64] = b"\xff" * 64
    bad.write_bytes(bytes(b))

    full_n = info_json(full)["messages"]
    for path in (cut, bad):
        r = subprocess.run([*ZENTF, "bag", "info", str(path)], capture_output=True, text=True, timeout=30, cwd=REPO)
        assert r.returncode == 0 and "Traceback" not in r.stderr
        assert re.search(r"zentf: warning: .*(truncated|damaged)", r.stderr), r.stderr
        info = info_json(path)
        assert not info["complete"] and 0 < info["messages"] < full_n

    # Play the truncated bag fast: a subscriber gets exactly the readable tf messages.
    counter = Counter(zenoh_session, f"{test_namespace}/tf")
    cut_tf = counts(info_json(cut))["tf"]
    play = spawn([*ZENTF, "bag", "play", str(cut), "--rate", "20", "--delay", "0.3"])
    assert play.wait(20) == 0, play.output()
    assert re.search(r"zentf: warning: .*truncated at byte \d+\).*; read \d+ messages; played the readable part", play.output())
    assert counter.n == cut_tf
    counter.sub.undeclare()

    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not a bag at all")
    for cmd in (["info", str(junk)], ["play", str(junk)], ["info", str(tmp_path / "missing.mcap")]):
        r = subprocess.run([*ZENTF, "bag", *cmd], capture_output=True, text=True, timeout=30, cwd=REPO)
        assert r.returncode == 1 and r.stderr.startswith("zentf: error: ") and r.stderr.count("\n") == 1, r.stderr


def test_bad_arguments_are_one_line_errors(tmp_path):
    for args in (["record"], ["record", "--all", "tf"], ["record", "bad topic!"],
                 ["play", str(tmp_path / "x.mcap"), "--rate", "0"], ["play", "x.mcap", "--start", "-1"]):
        r = subprocess.run([*ZENTF, "bag", *args], capture_output=True, text=True, timeout=30, cwd=REPO)
        assert r.returncode == 2, (args, r.stderr)
        assert r.stderr.startswith("zentf: error: ") and "Traceback" not in r.stderr, r.stderr
    r = subprocess.run([*ZENTF, "bag", "record", "tf", "-o", str(tmp_path / "no" / "dir.mcap")], capture_output=True,
                       text=True, timeout=30, cwd=REPO)
    assert r.returncode == 1 and r.stderr.startswith("zentf: error: cannot write "), r.stderr


def test_killed_recorder_leaves_a_readable_bag(spawn, tmp_path, test_namespace):
    bag = tmp_path / "killed.mcap"
    frames = spawn.python("-m", "nodes.frames_publisher")
    frames.wait_for_line(r"publishing av1 and av2", 20)
    rec = spawn([*ZENTF, "bag", "record", "--all", "-o", str(bag)])  # --all = this test's namespace
    rec.wait_for_line(r"recording: [1-9]\d* msgs, .*, 1\.\d s", 20)
    rec.wait_for_line(r"recording: \d+ msgs, .*, 2\.\d s", 20)  # a flush happened after 1 s
    rec.kill()
    info = info_json(bag)
    assert not info["complete"] and ("no summary" in info["problem"] or "truncated" in info["problem"])
    assert counts(info)["tf"] >= 20
    assert {t["key"] for t in info["topics"]} == {f"{test_namespace}/tf"}


def test_play_start_offset_and_loop(spawn, zenoh_session, test_namespace, tmp_path):
    from zentf.tools.bag import write_drones_demo

    bag = tmp_path / "two.mcap"
    write_drones_demo(bag, 2.0)  # tf_static at t0, tf at t0 + 20 ms * i + 0.2 ms (i = 0..100)
    tf = Counter(zenoh_session, f"{test_namespace}/tf")
    static = Counter(zenoh_session, f"{test_namespace}/tf_static")
    play = spawn([*ZENTF, "bag", "play", str(bag), "--start", "1", "--rate", "10", "--delay", "0.3"])
    assert play.wait(20) == 0, play.output()
    assert (tf.n, static.n) == (51, 1)  # i = 50..100, and the latched set from before --start
    tf.n = 0
    play = spawn([*ZENTF, "bag", "play", str(bag), "--loop", "--rate", "20", "--delay", "0.3"])
    play.wait_for_line(r"playing: t = ", 20)
    deadline = __import__("time").monotonic() + 20
    while tf.n < 2 * 101 + 10 and __import__("time").monotonic() < deadline:
        play.wait_for_line(r"playing: t = ", 5)
    play.signal(2)
    assert play.wait(10) == 0
    assert tf.n > 2 * 101
