"""`zentf view` against the live drones demo, checked through the Rerun recording it saves."""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import urllib.request
from collections import defaultdict
from pathlib import Path

import pytest

from conftest import REPO, free_port

rerun_chunk = pytest.importorskip("rerun.chunk", reason="rerun-sdk (zentf[view]) not installed")

ZENTF = [sys.executable, "-m", "zentf.cli"]


def read_rrd(path: Path) -> dict[str, list]:
    """entity path -> list of (column name -> first-row value) dicts, one per chunk row."""
    out: dict[str, list] = defaultdict(list)
    for ch in rerun_chunk.RrdReader(str(path)).stream():
        rb = ch.to_record_batch()
        cols = {n: rb.column(n).to_pylist() for n in rb.schema.names if ":" in n}  # components, not time columns
        for i in range(rb.num_rows):
            out[ch.entity_path].append({n: v[i] for n, v in cols.items()})
    return out


def test_view_saves_frames_trails_and_points_of_the_drones_demo(spawn, tmp_path, zenoh_session, test_namespace):
    frames = spawn.python("-m", "nodes.frames_publisher")
    spawn.python("-m", "nodes.plots_publisher", "-p", "rate:=10")
    spawn.python("-m", "nodes.static_transform_publisher", "0.2", "0", "0", "0", "0", "0", "av1", "laser")
    spawn.python("-m", "nodes.point_publisher")
    frames.wait_for_line(r"publishing av1 and av2", 20)
    rrd = tmp_path / "drones.rrd"
    view = spawn([*ZENTF, "view", "--save", str(rrd), "--duration", "3", "--rate", "10"])
    view.wait_for_line(r"viewing /t_\w+ in fixed frame world, map or odom", 20)
    # Bad input on visual topics is dropped without stopping the view.
    from zentf.transport.wire import codec as wire
    from zentf.core.messages import Marker, MarkerArray

    enc = wire.encoding_for(MarkerArray.TYPE_NAME)
    for junk in (b"\xc1garbage", wire.pack({"markers": "nope"}), wire.pack([1, 2, 3]),
                 wire.encode(MarkerArray(markers=[Marker(type=99, ns="junk")]))):
        zenoh_session.put(f"{test_namespace}/junk_markers", junk, encoding=enc)
    zenoh_session.put(f"{test_namespace}/junk_point", b"\x00", encoding=wire.encoding_for("geometry_msgs/msg/PointStamped"))
    assert view.wait(30) == 0, view.output()
    assert "Traceback" not in view.output()
    assert int(view.wait_for_line(r"view: \d+ refreshes, \d+ frames shown, (\d+) bad messages dropped", 1,
                                  from_start=True).group(1)) >= 3

    data = read_rrd(rrd)
    for entity in ("/tf/world", "/tf/av1", "/tf/av2", "/tf/laser", "/tf_links",
                   "/tf/world/markers/trails/0", "/tf/world/markers/trails/1", "/tf/av1/markers/trails/2"):
        assert entity in data, sorted(data)
    # av1 flies on the unit circle in world; its axes and name label are there.
    poses = [r["Transform3D:translation"][0] for r in data["/tf/av1"] if r.get("Transform3D:translation")]
    assert len(poses) >= 10
    for x, y, z in poses:
        assert math.hypot(x, y) == pytest.approx(1.0, abs=1e-3) and z == pytest.approx(0.0, abs=1e-6)
    assert any(r.get("TransformAxes3D:axis_length") for r in data["/tf/av1"])
    labels = {lab for e in ("/tf/av1", "/tf/av2", "/tf/world") for r in data[e] for lab in (r.get("Points3D:labels") or [])}
    assert labels == {"av1", "av2", "world"}
    # The av2-in-av1 trail (drawn in av1) lies on the ellipse plane 2y - z + 1 = 0.
    strips = [r["LineStrips3D:strips"] for r in data["/tf/av1/markers/trails/2"] if r.get("LineStrips3D:strips")]
    last = strips[-1][0]
    assert len(last) >= 5
    assert all(abs(2 * y - z + 1) < 3e-3 for _, y, z in last)
    # The laser point (PointStamped in 'laser') hangs under its frame.
    assert any(e.startswith("/tf/laser/points/") for e in data), sorted(data)


def test_view_web_serves_the_viewer(spawn):
    web, grpc = free_port(), free_port()
    view = spawn([*ZENTF, "view", "--web", "--web-port", str(web), "--grpc-port", str(grpc), "--duration", "20"])
    url = view.wait_for_line(r"web viewer: (http://\S+)", 20).group(1)
    html = urllib.request.urlopen(url.replace("localhost", "127.0.0.1"), timeout=10).read().decode()
    assert "rerun" in html.lower()
    view.signal(2)
    assert view.wait(15) == 0, view.output()


def test_view_errors_are_one_line(zenoh_env, tmp_path):
    env = {k: v for k, v in zenoh_env.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = subprocess.run([*ZENTF, "view"], env=env, capture_output=True, text=True, timeout=30, cwd=REPO)
    assert r.returncode == 2 and re.fullmatch(r"zentf: error: no display .*--web.*--save.*\n", r.stderr), r.stderr
    # Without the [view] extra: a stub 'rerun' that fails to import stands in for a missing package.
    stub = tmp_path / "stub"
    stub.mkdir()
    (stub / "rerun.py").write_text("raise ImportError('No module named rerun')\n")
    env["PYTHONPATH"] = os.pathsep.join([str(stub), env.get("PYTHONPATH", "")])
    r = subprocess.run([*ZENTF, "view", "--save", str(tmp_path / "x.rrd")], env=env, capture_output=True, text=True,
                       timeout=30, cwd=REPO)
    assert r.returncode == 1 and r.stderr == "zentf: error: zentf view needs Rerun: pip install 'zentf[view]' " \
                                             "(or: pip install rerun-sdk)\n", r.stderr


def test_view_follows_a_bag_played_with_clock(spawn, isolated_router, test_namespace, tmp_path):
    """Sim time end to end: `bag play --clock` drives the view's time line (the bag's 2023 stamps)."""
    import pyarrow as pa

    env = dict(os.environ)
    for var in ("ZENTF_PARAMS", "ZENTF_REMAP", "ZENTF_NODE_NAME", "ZENTF_PARAMS_FILE", "ZENTF_LISTEN"):
        env.pop(var, None)
    env.update({"ZENTF_CONNECT": isolated_router, "ZENTF_MODE": "client", "ZENTF_NO_MULTICAST": "1",
                "ZENTF_NAMESPACE": test_namespace, "PYTHONUNBUFFERED": "1"})
    bag, rrd = tmp_path / "d.mcap", tmp_path / "sim.rrd"
    from zentf.tools.bag import write_drones_demo

    write_drones_demo(bag, 30.0, start=1_700_000_000.0)
    view = spawn([*ZENTF, "view", "--use-sim-time", "--save", str(rrd), "--duration", "3", "--rate", "10"], env=env)
    view.wait_for_line(r"viewing ", 20)
    play = spawn([*ZENTF, "bag", "play", str(bag), "--clock"], env=env)
    assert view.wait(30) == 0, view.output()
    play.signal(2)
    assert play.wait(10) == 0, play.output()
    times = []
    for ch in rerun_chunk.RrdReader(str(rrd)).stream():
        if ch.entity_path == "/tf/av1":
            rb = ch.to_record_batch()
            times += rb.column("ros_time").cast(pa.int64()).to_pylist()
    assert len(times) >= 5
    assert all(1_700_000_000 * 10**9 <= t <= 1_700_000_030 * 10**9 for t in times), times[:5]
