"""Unit tests of the CLI's pure renderers: tf echo block, frame tree text, view_frames DOT, graph DOT."""
from __future__ import annotations

import math
import shutil
import subprocess
import sys

import pytest

from zentf.cli.format import (FrameStat, NodeDesc, format_echo, format_frame_tree, format_hz,
                              format_node_graph, format_stamp, frame_trees, frames_dot,
                              node_graph_dot)
from zentf.core.rotation import quaternion_from_rpy


def _yaw_q(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def test_echo_block_camera_laser_with_yaw() -> None:
    text = format_echo(1_700_000_000_000_000_005, (0.9, 0.0, -0.2), _yaw_q(0.5))
    lines = text.splitlines()
    assert lines[0] == "At time 1700000000.000000005"
    assert lines[1] == "- Translation: [0.900, 0.000, -0.200]"
    assert lines[2] == "- Rotation: in Quaternion (xyzw) [0.000, 0.000, 0.247, 0.969]"
    assert lines[3] == "- Rotation: in RPY (radian) [0.000, -0.000, 0.500]"
    assert lines[4] == "- Rotation: in RPY (degree) [0.000, -0.000, 28.648]"
    assert lines[5] == "- Matrix:"
    assert lines[6].split() == ["0.878", "-0.479", "0.000", "0.900"]
    assert lines[9].split() == ["0.000", "0.000", "0.000", "1.000"]
    assert len(lines) == 10


def test_echo_precision() -> None:
    text = format_echo(0, (1.0, 2.0, 3.0), (0, 0, 0, 1), precision=5)
    assert "- Translation: [1.00000, 2.00000, 3.00000]" in text
    assert text.startswith("At time 0.000000000\n")


def test_echo_rpy_at_gimbal_lock_is_the_rotations_roll() -> None:
    """tf2_echo prints rounding noise as the roll here (0.245 for this rotation); zentf the true 0.300."""
    lines = format_echo(0, (0.0, 0.0, 0.0), quaternion_from_rpy(0.3, math.pi / 2, 0.0)).splitlines()
    assert lines[3] == "- Rotation: in RPY (radian) [0.300, 1.571, 0.000]"
    assert lines[4] == "- Rotation: in RPY (degree) [17.189, 90.000, 0.000]"
    lines = format_echo(0, (0.0, 0.0, 0.0), quaternion_from_rpy(-0.3, -math.pi / 2, 0.0)).splitlines()
    assert lines[3] == "- Rotation: in RPY (radian) [-0.300, -1.571, 0.000]"


def test_echo_rendering_loads_no_numpy() -> None:
    """tf echo's start-up: the rotation helpers it prints through are numpy-free."""
    code = ("import sys, zentf.cli.tf, zentf.cli.format as f; f.format_echo(0, (1, 2, 3), (0, 0, 0, 1)); "
            "print('numpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_stamp_zero_padded() -> None:
    assert format_stamp(5) == "0.000000005"
    assert format_stamp(12_500_000_000) == "12.500000000"


#: view_frames' figures of the drones and a static laser (what BufferCore.frame_info gives, as FrameStats)
_STATS = [FrameStat("av1", "world", "/frames_publisher", 50.0, 101.0, 91.0, 10.0, static=False),
          FrameStat("av2", "world", "/frames_publisher", 50.0, 101.0, 91.0, 10.0, static=False),
          FrameStat("laser", "base_link", "/static_laser", 10000.0, 0.0, 0.0, 0.0, static=True)]


def test_frame_trees_and_text_tree_show_disconnected_trees() -> None:
    stats = _STATS + [FrameStat("camera", "base_link", "/static_cam", 10000.0),
                                        FrameStat("lens", "camera", "/static_cam", 10000.0)]
    trees = frame_trees(stats)
    assert [root for root, _ in trees] == ["base_link", "world"]
    assert [e.child for e in trees[0][1]] == ["camera", "lens", "laser"]
    text = format_frame_tree(stats)
    assert text.splitlines() == [
        "base_link",
        "├── camera  (static, /static_cam)",
        "│   └── lens  (static, /static_cam)",
        "└── laser  (static, /static_laser)",
        "",
        "world",
        "├── av1  (50.0 Hz, /frames_publisher)",
        "└── av2  (50.0 Hz, /frames_publisher)",
    ]


def test_frame_trees_survive_a_loop() -> None:
    stats = [FrameStat("b", "a"), FrameStat("a", "b"), FrameStat("c", "x")]
    trees = frame_trees(stats)
    covered = {e.child for _, edges in trees for e in edges}
    assert covered == {"a", "b", "c"}
    assert "c" in format_frame_tree(stats)


def test_frames_dot_edges_labels_and_clusters() -> None:
    dot = frames_dot(_STATS, recorded_at=101.5)
    assert '"world" -> "av1"' in dot and '"world" -> "av2"' in dot and '"base_link" -> "laser"' in dot
    assert dot.count("subgraph cluster_") == 3  # two trees + legend
    assert "Broadcaster: /frames_publisher\\nAverage rate: 50.000 Hz" in dot
    assert "Most recent transform: 101.000 ( 0.500 sec old)" in dot
    assert "Oldest transform: 91.000" in dot and "Buffer length: 10.000 sec" in dot
    assert "Recorded at time: 101.500" in dot


def test_frames_dot_empty_and_quoting() -> None:
    assert "No tf data received" in frames_dot([])
    dot = frames_dot([FrameStat('we"ird', "a", 'b"c')])
    assert '"a" -> "we\\"ird"' in dot and 'Broadcaster: b\\"c' in dot


@pytest.mark.skipif(shutil.which("dot") is None, reason="graphviz not installed")
def test_frames_dot_is_valid_graphviz() -> None:
    for dot in (frames_dot(_STATS, 1.0), frames_dot([]),
                node_graph_dot([NodeDesc("/a", {"/tf": "tf2_msgs/msg/TFMessage"}, {})])):
        proc = subprocess.run(["dot", "-Tsvg"], input=dot, capture_output=True, text=True, timeout=30)
        assert proc.returncode == 0, proc.stderr
        assert "<svg" in proc.stdout


def test_node_graph_dot_and_text() -> None:
    nodes = [NodeDesc("/talker", {"/chatter": "std_msgs/msg/String"}, {}),
             NodeDesc("/listener", {}, {"/chatter": "std_msgs/msg/String"})]
    dot = node_graph_dot(nodes)
    assert '"n:/talker" -> "t:/chatter"' in dot and '"t:/chatter" -> "n:/listener"' in dot
    assert dot.count("shape=box") == 1
    text = format_node_graph(nodes)
    assert text.splitlines() == ["/listener", "  <- /chatter [std_msgs/msg/String]",
                                 "/talker", "  -> /chatter [std_msgs/msg/String]"]
    assert format_node_graph([]) == "No nodes found"


def test_format_hz() -> None:
    assert format_hz([1.0]) is None
    text = format_hz([0.0, 0.02, 0.04, 0.06])
    assert text is not None
    first, second = text.splitlines()
    assert first == "average rate: 50.000"
    assert "min: 0.020s max: 0.020s" in second and "window: 4" in second


def test_stats_from_frame_info() -> None:
    from zentf.cli.format import stats_from_frame_info
    from zentf.core.time import Time

    stats = stats_from_frame_info([
        {"frame": "av1", "parent": "world", "broadcaster": "/fp", "static": False, "samples": 3,
         "most_recent_transform": Time.from_sec(12.0), "oldest_transform": Time.from_sec(10.0), "rate": 1.5},
        {"frame": "laser", "parent": "base_link", "broadcaster": "/s", "static": True, "samples": 1,
         "most_recent_transform": Time(), "oldest_transform": Time(), "rate": 10000.0}])
    assert stats[0].buffer_length == pytest.approx(2.0) and not stats[0].is_static
    assert stats[1].is_static and stats[1].broadcaster == "/s"


def test_monitor_stats_rates_delays_and_report() -> None:
    import time as _time

    from zentf.cli.tf import MonitorStats, format_monitor_text

    class Sink:
        def __init__(self) -> None:
            self.got: list = []

        def set_transforms_raw(self, samples, authority, is_static):  # noqa: ANN001
            self.got.append((len(samples), authority, is_static))
            return len(samples)

    sink = Sink()
    stats = MonitorStats(forward=sink)
    now = _time.time_ns()
    sample = lambda parent, child, age_s: (parent, child, now - int(age_s * 1e9), 0.0, 0.0, 0.0,  # noqa: E731
                                           0.0, 0.0, 0.0, 1.0)
    assert stats.set_transforms_raw([sample("world", "av1", 0.010), sample("world", "av2", 0.030)], "/fp", False) == 2
    stats.set_transform_raw(*sample("base_link", "laser", 100.0), "/static", True)
    # fake 50 Hz arrivals for av1
    f = stats.frames["av1"]
    f.arrivals.clear()
    t0 = _time.monotonic() - 1.0
    f.arrivals.extend(t0 + k * 0.02 for k in range(51))
    rows = {r[0]: r for r in stats.rows()}
    assert rows["av1"][1:3] == ("world", "/fp") and rows["av1"][3] == pytest.approx(50.0)
    assert rows["av1"][4] == pytest.approx(0.010, abs=0.005) and rows["av2"][5] == pytest.approx(0.030, abs=0.005)
    assert rows["laser"][6] and rows["laser"][4] == 0.0  # static: no delay, no rate
    assert sink.got == [(2, "/fp", False), (1, "/static", True)]
    text = format_monitor_text(stats, "for all Frames")
    assert text.startswith("RESULTS: for all Frames")
    assert any(ln.split()[:4] == ["av1", "world", "/fp", "50.0"] for ln in text.splitlines()), text
    assert any(ln.split()[:4] == ["laser", "base_link", "/static", "static"] for ln in text.splitlines()), text
    assert "Node: /static static, Average Delay: 0.000 ms" in text
    chain_text = format_monitor_text(stats, "for world to av1", chain=["av1", "world"], net=(0.002, 0.004))
    assert "Chain is: av1 -> world\nNet delay     avg = 2.000 ms: max = 4.000 ms" in chain_text
    assert "av2" not in chain_text.split("All Broadcasters:")[0]  # only chain frames listed


def test_monitor_stats_take_delays_on_the_clock_they_are_given() -> None:
    """Sim time: delays against /clock, none while the clock has not ticked, and the wall delays
    gathered before /clock appeared are dropped when it does."""
    from zentf.cli.tf import MonitorStats, format_monitor_text

    now: list = [None]
    stats = MonitorStats(clock=lambda: now[0])
    sample = lambda stamp_s: ("odom", "base_link", int(stamp_s * 1e9), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)  # noqa: E731
    stats.set_transforms_raw([sample(930.0)], "/gazebo", False)  # sim time, no /clock yet: no delay
    assert stats.rows()[0][4:6] == (0.0, 0.0) and not stats.frames["base_link"].delays
    now[0] = 1_800_000_000 * 10**9  # a wall reading: a delay of decades ...
    stats.set_transforms_raw([sample(930.0)], "/gazebo", False)
    stats.reset_delays()  # ... dropped when the clock switches
    now[0] = 930_050_000_000
    stats.set_transforms_raw([sample(930.0)], "/gazebo", False)
    assert stats.rows()[0][4] == pytest.approx(0.050) and stats.node_rows()[0][2] == pytest.approx(0.050)
    text = format_monitor_text(stats, "for all Frames", clock="sim time from /clock (published)")
    assert text.startswith("RESULTS: for all Frames\nClock: sim time from /clock (published)\n")
