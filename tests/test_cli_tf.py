"""`zentf tf echo | monitor | frames` as subprocesses against real node processes on loopback."""
from __future__ import annotations

import re
import shutil

import pytest
from cli_helpers import ZENTF, assert_one_line_error, zentf
from conftest import REPO, Proc, child_env

NUM = r"(-?\d+\.\d+)"


def _static(spawn, *args: str):
    p = spawn.python("-m", "nodes.static_transform_publisher", *args)
    p.wait_for_line(r"Spinning until stopped", 30)
    return p


def test_tf_echo_waits_says_why_then_prints_camera_from_laser(spawn):
    """Started before any frame exists: it reports the tf2 reason, then recovers by itself."""
    echo = spawn([*ZENTF, "tf", "echo", "camera", "laser", "5", "--count", "2"])  # tf2_echo positional rate
    echo.wait_for_line(r'Waiting for transform camera -> laser: .*does not exist', 30)
    _static(spawn, "--x", "0.4", "--z", "0.2", "--yaw", "0.5", "--frame-id", "base_link", "--child-frame-id", "laser")
    _static(spawn, "-0.5", "0", "0.4", "0", "0", "0", "base_link", "camera")
    echo.wait_for_line(r"^At time \d+\.\d{9}$", 30)
    m = echo.wait_for_line(rf"^- Translation: \[{NUM}, {NUM}, {NUM}\]$", 5)
    assert [float(g) for g in m.groups()] == pytest.approx([0.9, 0.0, -0.2], abs=1e-3)
    echo.wait_for_line(r"^- Rotation: in Quaternion \(xyzw\) \[0\.000, 0\.000, 0\.247, 0\.969\]$", 5)
    echo.wait_for_line(r"^- Rotation: in RPY \(radian\) \[0\.000, -?0\.000, 0\.500\]$", 5)
    echo.wait_for_line(r"^- Rotation: in RPY \(degree\) \[0\.000, -?0\.000, 28\.648\]$", 5)
    echo.wait_for_line(r"^- Matrix:$", 5)
    echo.wait_for_line(r"^\s+0\.878\s+-0\.479\s+0\.000\s+0\.900$", 5)
    assert echo.wait(30) == 0, echo.output()
    assert len([ln for ln in echo.lines if ln.startswith("At time")]) == 2


def test_tf_echo_says_why_it_waits_at_most_once_a_second(spawn, zenoh_env):
    """A lookup in the future fails with a new reason at every insert (the latest stamp moves): still one
    line a second at most."""
    frames = spawn.python("-m", "nodes.frames_publisher")
    frames.wait_for_line(r"publishing av1 and av2 in world", 30)
    proc = zentf(["tf", "echo", "world", "av1", "--time", "9000000000", "--timeout", "3"], zenoh_env)
    waiting = [ln for ln in proc.stderr.splitlines() if ln.startswith("Waiting for transform world -> av1:")]
    assert proc.returncode == 1 and "into the future" in proc.stderr, proc.stderr
    assert 1 <= len(waiting) <= 4, proc.stderr  # 3 s: at 0, 1, 2 (and 3) s


def test_tf_monitor_reports_the_drones_at_about_50_hz(spawn, zenoh_env):
    frames = spawn.python("-m", "nodes.frames_publisher")
    frames.wait_for_line(r"publishing av1 and av2 in world", 30)
    proc = zentf(["tf", "monitor", "--duration", "3"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    rows = {}
    for line in proc.stdout.splitlines():
        m = re.match(rf"^(av[12])\s+(\S+)\s+(\S+)\s+{NUM}\s+{NUM}\s+{NUM}$", line)
        if m:
            rows[m.group(1)] = m.groups()
    assert set(rows) == {"av1", "av2"}, proc.stdout
    for frame, parent, broadcaster, rate, avg, mx in rows.values():
        assert parent == "world"
        assert broadcaster.endswith("/frames_publisher")
        assert 35.0 < float(rate) < 65.0, proc.stdout  # 50 Hz publisher; loose for a loaded CI box
        assert 0.0 <= float(avg) <= float(mx)
    assert re.search(r"^Node: \S+/frames_publisher \d+\.\d Hz", proc.stdout, re.M), proc.stdout


def test_tf_monitor_chain_between_two_frames(spawn, zenoh_env):
    frames = spawn.python("-m", "nodes.frames_publisher")
    frames.wait_for_line(r"publishing av1 and av2 in world", 30)
    proc = zentf(["tf", "monitor", "av1", "av2", "--duration", "2"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    assert "RESULTS: for av1 to av2" in proc.stdout
    assert re.search(r"^Chain is: av2 -> world -> av1$", proc.stdout, re.M), proc.stdout
    assert re.search(rf"^Net delay\s+avg = {NUM} ms: max = {NUM} ms$", proc.stdout, re.M), proc.stdout


def test_tf_frames_writes_dot_with_edges_and_an_image(spawn, zenoh_env, tmp_path):
    frames = spawn.python("-m", "nodes.frames_publisher")
    frames.wait_for_line(r"publishing av1 and av2 in world", 30)
    _static(spawn, "--x", "0.4", "--z", "0.2", "--frame-id", "base_link", "--child-frame-id", "laser")
    out = tmp_path / "frames"
    proc = zentf(["tf", "frames", "--wait", "1.5", "-o", str(out), "--print"], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    dot = (tmp_path / "frames.gv").read_text()
    edges = set(re.findall(r'^\s*"([^"]+)" -> "([^"]+)"', dot, re.M))
    assert edges == {("world", "av1"), ("world", "av2"), ("base_link", "laser")}
    assert re.search(r'"world" -> "av1" \[label="Broadcaster: /\S+/frames_publisher\\nAverage rate: \d+\.\d+ Hz'
                     r'\\nMost recent transform: \d+\.\d+ \( \d+\.\d+ sec old\)\\nOldest transform: \d+\.\d+'
                     r'\\nBuffer length: \d+\.\d+ sec', dot), dot
    assert "static_transform_publisher" in dot and "Most recent transform: 0.000 (static)" in dot
    assert dot.count("subgraph cluster_") == 3  # two disconnected trees + the legend
    assert "base_link\n└── laser  (static, " in proc.stdout
    assert re.search(r"^world\n├── av1  \(\d+\.\d Hz, \S+/frames_publisher\)\n└── av2", proc.stdout, re.M)
    if shutil.which("dot"):
        pdf = tmp_path / "frames.pdf"
        assert pdf.read_bytes()[:5] == b"%PDF-"
        assert f"Wrote {tmp_path / 'frames.gv'} and {pdf}" in proc.stdout


def test_tf_frames_with_nothing_on_tf_names_the_namespaced_tf_topics(spawn, zenoh_env, test_namespace):
    """tf under robot namespaces only: the error says where tf is and how to look there."""
    _static(spawn, "1", "2", "3", "0", "0", "0", "map", "odom", "--namespace", f"{test_namespace}/robot1")
    proc = zentf(["tf", "frames", "-w", "0.5"], zenoh_env)
    err = assert_one_line_error(proc, f"no tf data received in 0.5 s on /{test_namespace}/tf, "
                                      f"/{test_namespace}/tf_static; tf is published on "
                                      f"/{test_namespace}/robot1/tf_static")
    assert f"(e.g. zentf -n {test_namespace}/robot1 tf frames)" in err


@pytest.mark.skipif(shutil.which("dot") is None, reason="graphviz not installed")
def test_tf_frames_svg_output(spawn, zenoh_env, tmp_path):
    _static(spawn, "1", "2", "3", "0", "0", "0", "map", "odom")
    proc = zentf(["tf", "frames", "-w", "0.5", "-o", str(tmp_path / "tree.svg")], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    svg = (tmp_path / "tree.svg").read_text()
    assert "<svg" in svg and "odom" in svg
    assert '"map" -> "odom"' in (tmp_path / "tree.gv").read_text()


def test_tools_read_sim_time_while_a_bag_plays_with_its_clock(isolated_router, test_namespace, tmp_path):
    """nav2's run: tf stamped in Gazebo time (~930 s), recorded with a wall clock. Under `bag play --clock`
    the tools take /clock by themselves, as ROS tools do with use_sim_time: delays and ages in sim time
    (against the wall clock they read ~1.8e12 ms); `zentf clock` says the bag's clock takes no commands."""
    env = child_env(isolated_router, test_namespace)
    play = Proc([*ZENTF, "bag", "play", str(REPO / "tests" / "data" / "nav2_turtlebot.mcap"), "--clock"], env=env)
    try:
        play.wait_for_line(r"/clock follows the recording's tf stamps, -\d+ s from its log times", 30)
        play.wait_for_line(r"playing: t = ", 30)
        mon = zentf(["tf", "monitor", "--duration", "2"], env)
        assert mon.returncode == 0, mon.stderr
        assert "\nClock: sim time from /clock (published)\n" in mon.stdout, mon.stdout
        # the broadcaster of a recording without senders is the player (as rosbag play's caller id in ROS 1)
        rows = re.findall(rf"^(\S+)\s+(\S+)\s+\S+_zentf_bag_play_\d+\s+{NUM}\s+{NUM}\s+{NUM}$", mon.stdout, re.M)
        assert {r[0] for r in rows} >= {"base_link", "odom"}, mon.stdout
        for frame, _parent, _rate, avg, mx in rows:
            assert abs(float(avg)) < 5000 and abs(float(mx)) < 5000, mon.stdout  # ms: sim time, not 1e12
        frames = zentf(["tf", "frames", "-w", "1", "-o", str(tmp_path / "nav2")], env)
        assert frames.returncode == 0, frames.stderr
        dot = (tmp_path / "nav2.gv").read_text()
        assert re.search(r'"Recorded at time: 9\d\d\.\d+"', dot) and "Clock: sim time from /clock" in dot, dot
        ages = [float(a) for a in re.findall(r"\( (-?\d+\.\d+) sec old\)", dot)]
        assert ages and all(abs(a) < 5 for a in ages), dot
        clock = zentf(["clock", "--timeout", "30"], env, timeout=20)
        assert_one_line_error(clock, "no sim clock to control", f"/clock is published by /{test_namespace}/_zentf_bag_play_", code=1)
    finally:
        play.stop()
