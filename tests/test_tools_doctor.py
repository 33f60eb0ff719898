"""The tf doctor's library (zentf.tools.doctor) on evidence made by hand: every check, explain_lookup, bags,
and the tf tools' topic options. No network: the live graphs are tests/test_cli_tf_doctor.py's."""
from __future__ import annotations

import json

import click
import pytest

from cli_helpers import zentf
from zentf.core.buffer_core import BufferCore
from zentf.tools.doctor import Evidence, explain_lookup, run_checks
from zentf.tools.doctor.evidence import MAX_EDGES

NS = 1_000_000_000
T0 = 1_700_000_000 * NS
ID = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def _row(parent: str, child: str, stamp: int, x: float = 0.0) -> tuple:
    return (parent, child, stamp, x, *ID[1:])


def _feed(ev: Evidence, parent: str, child: str, sender: str, *, rate: float = 20.0, seconds: float = 3.0,
          offset: float = 0.0, start: float = 0.0, latency: float = 0.002, static: bool = False) -> None:
    n = int(seconds * rate)
    for i in range(n):
        arrival = T0 + round((start + i / rate) * NS)
        ev.add([_row(parent, child, arrival - round(latency * NS) + round(offset * NS), 0.1 * i)], sender, static,
               arrival_ns=arrival)


def _report(ev: Evidence, at: float = 3.0) -> dict:
    now = T0 + round(at * NS)
    return run_checks(ev, now=now, clock_now=now).to_dict()


def _codes(report: dict) -> dict:
    out: dict = {}
    for f in report["findings"]:
        out.setdefault(f["code"], []).append(f)
    return out


def test_healthy_tree_has_no_finding_and_figures():
    ev = Evidence()
    _feed(ev, "world", "base", "/a")
    _feed(ev, "base", "arm", "/b", rate=50)
    ev.add([_row("base", "cam", T0)], "/c", True, arrival_ns=T0)
    r = _report(ev)
    assert r["findings"] == [] and r["healthy"], r["findings"]
    edges = {e["frame"]: e for e in r["edges"]}
    assert abs(edges["arm"]["rate"] - 50) < 0.5 and abs(edges["base"]["delay"] - 0.002) < 1e-6
    assert r["trees"] == [{"root": "world", "frames": 4, "leaves": ["arm", "cam"], "lct_lag": pytest.approx(
        0.022, abs=0.002)}]
    assert "no problems found" in r["summary"]


def test_each_problem_named_with_its_publisher():
    ev = Evidence()
    _feed(ev, "world", "base", "/robot")
    _feed(ev, "world", "payload", "/dup_a")
    _feed(ev, "world", "payload", "/dup_b", start=0.01)
    _feed(ev, "base", "gimbal", "/laggard", offset=-2.5)
    _feed(ev, "base", "ahead", "/hasty", offset=+1.8)
    _feed(ev, "world", "beacon", "/doomed", seconds=1.0)
    ev.add([_row("base", "camera", T0)], "/cam_static", True, arrival_ns=T0)
    _feed(ev, "base", "camera", "/cam_on_tf", rate=10)
    for i in range(3):  # moving on tf_static
        ev.add([_row("base", "lidar", T0 + i, x=float(i))], "/mover", True, arrival_ns=T0 + i * NS)
    _feed(ev, "odom2", "base2", "/odom_pub")
    _feed(ev, "loop_x", "loop_y", "/loop_a", rate=10)
    _feed(ev, "loop_y", "loop_x", "/loop_b", rate=10)
    _feed(ev, "base", "arm", "/flip", seconds=1.0)
    _feed(ev, "world", "arm", "/flip", seconds=1.0, start=1.0)  # the same sender changes arm's parent
    _feed(ev, "world", "arm", "/flip", seconds=1.0, start=2.0)
    found = _codes(_report(ev))
    dup = found["multiple_publishers"]
    assert [(f["frames"], f["publishers"]) for f in dup] == [(["payload"], ["/dup_a", "/dup_b"])]
    clock = {f["publishers"][0]: f for f in found["clock_offset"]}
    assert set(clock) == {"/laggard", "/hasty"}
    assert "2.50 s behind" in clock["/laggard"]["title"] and "1.80 s ahead of" in clock["/hasty"]["title"]
    dead = found["dead_frame"]
    assert [(f["frames"], f["publishers"]) for f in dead] == [(["beacon"], ["/doomed"])]
    assert "left the graph" not in dead[0]["title"]  # no graph watched: it cannot know
    cam = found["static_on_tf"]
    assert cam[0]["frames"] == ["camera"] and "/cam_on_tf" in cam[0]["title"]
    assert found["dynamic_on_tf_static"][0]["publishers"] == ["/mover"]
    roots = found["multiple_roots"][0]
    assert roots["frames"][:2] == ["world", "odom2"] and "/odom_pub" in roots["publishers"]
    loop = found["loop"][0]
    assert set(loop["frames"]) == {"loop_x", "loop_y"} and loop["publishers"] == ["/loop_a", "/loop_b"]
    assert found["reparenting"][0]["frames"] == ["arm"] and found["reparenting"][0]["publishers"] == ["/flip"]
    assert all(f["severity"] in ("error", "warning") for fs in found.values() for f in fs)
    named = {p for fs in found.values() for f in fs for p in f["publishers"]}
    assert "/robot" not in named - set(roots["publishers"])


def test_graph_says_who_left():
    ev = Evidence()
    ev.graph.known = True
    ev.graph.node_seen("/doomed", T0)
    ev.graph.node_seen("/quiet", T0)
    ev.graph.node_seen("/static_pub", T0)
    _feed(ev, "world", "beacon", "/doomed", seconds=2.9)
    _feed(ev, "world", "stuck", "/quiet", seconds=1.0)
    ev.add([_row("world", "mast", T0)], "/static_pub", True, arrival_ns=T0)
    ev.graph.node_gone("/doomed", T0 + int(2.95 * NS))
    ev.graph.node_gone("/static_pub", T0 + 2 * NS)
    found = _codes(_report(ev))
    dead = {f["frames"][0]: f for f in found["dead_frame"]}
    assert "left the graph" in dead["beacon"]["title"]  # only 50 ms silent, but its node is gone
    assert "still in the graph" in " ".join(dead["stuck"]["evidence"])
    assert found["publisher_left"][0]["frames"] == ["mast"]


def test_ros2_gids_resolved_through_the_graph():
    ev = Evidence()
    ev.graph.known = True
    ev.graph.gids["ab" * 8] = ("/dup_a", "zid1")
    ev.graph.gids["cd" * 8] = ("/dup_b", "zid2")
    _feed(ev, "world", "payload", "ab" * 8)
    _feed(ev, "world", "payload", "cd" * 8)
    dup = _codes(_report(ev))["multiple_publishers"][0]
    assert dup["publishers"] == ["/dup_a", "/dup_b"]


def test_refusals_counted_per_sender():
    ev = Evidence()
    for i in range(5):
        ev.add([_row("w", "a", T0 + i * NS)], "/ok", False, arrival_ns=T0 + i * NS)
        ev.add([_row("w", "a", T0 + i * NS)], "/echo", False, arrival_ns=T0 + i * NS + 1)  # same stamps
    ev.add([_row("w", "a", T0 - 20 * NS)], "/old", False, arrival_ns=T0 + 5 * NS)
    ev.add([_row("w", "f", T0 + 60 * NS)], "/future", False, arrival_ns=T0 + 5 * NS)
    ev.add([("w", "n", T0, float("nan"), 0, 0, 0, 0, 0, 1)], "/nan", False, arrival_ns=T0)
    found = _codes(_report(ev, at=5.0))
    assert found["tf_repeated_data"][0]["publishers"] == ["/echo"] and "5 sample" in found["tf_repeated_data"][0][
        "evidence"][0]
    assert found["tf_old_data"][0]["publishers"] == ["/old"]
    assert found["tf_future_data"][0]["publishers"] == ["/future"]
    assert found["tf_nan_input"][0]["publishers"] == ["/nan"]


def test_evidence_tables_are_bounded():
    ev = Evidence()
    rows = [_row("w", f"f{i}", T0) for i in range(MAX_EDGES + 50)]
    ev.add(rows, "/flood", False, arrival_ns=T0)
    assert len(ev.edges) == MAX_EDGES and ev.overflow == 50


def _chain(core: BufferCore, stale: set[str], now: int) -> None:
    frames = ["a", "b", "c", "d", "e"]
    for p, c in zip(frames, frames[1:]):
        last = now - (3 * NS if c in stale else 20_000_000)
        for k in range(100):
            core.set_transform_raw(p, c, last - k * 50_000_000, *ID, f"/pub_{c}", False)


@pytest.mark.parametrize("stale", [{"c"}, {"c", "d"}])
def test_why_names_every_stale_edge(stale):
    core = BufferCore()
    now = T0
    _chain(core, stale, now)
    ex = explain_lookup(core, "a", "e", now=now)
    assert not ex.ok
    assert ex.stale_edges() == [f"{p} -> {c}" for p, c in (("c", "d"), ("b", "c")) if c in stale]
    at_now = ex.verdicts[0]
    kinds = {f["edge"]: f["kind"] for f in at_now.failing}
    assert kinds == {**{"d -> e": "not yet", "a -> b": "not yet"},
                     **{f"{chr(ord(c) - 1)} -> {c}": ("stale" if c in stale else "not yet") for c in "cd"}}
    assert any("Time(0)" in f for f in at_now.fixes)
    assert all(f"/pub_{c}" in " ".join(x["detail"] for x in at_now.failing) for c in stale)
    t0 = ex.verdicts[1]
    assert t0.label == "Time(0)" and t0.ok and t0.answered_at == now - 3 * NS
    assert "tf2" not in ex.text() and "b -> c" in ex.text()


def test_why_waits_when_only_a_sample_is_due_and_names_missing_frames():
    core = BufferCore()
    _chain(core, set(), T0)
    ex = explain_lookup(core, "a", "e", now=T0)
    assert ex.ok and ex.stale_edges() == []
    assert "add a timeout of" in ex.verdicts[0].fixes[0]
    ex = explain_lookup(core, "a", "ee", now=T0)
    assert not ex.ok and "does not exist" in ex.problem and "e" in ex.fixes[0]
    core.set_transform_raw("x", "y", T0, *ID, "/other", False)
    ex = explain_lookup(core, "a", "y", now=T0)
    assert "not connected" in ex.problem and "'zentf tf doctor'" in ex.fixes[0]


def test_why_and_doctor_on_a_bag(tmp_path):
    from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
    from zentf.core.time import Time
    from zentf.tools.bag import BagWriter
    from zentf.transport.wire import codec as wire

    def ts(p: str, c: str, stamp: int) -> TransformStamped:
        return TransformStamped(header=Header(stamp=Time(nanoseconds=stamp), frame_id=p), child_frame_id=c,
                                transform=Transform(Vector3(0.0, 0.0, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0)))

    path = tmp_path / "chain.mcap"
    enc = str(wire.encoding_for("tf2_msgs/msg/TFMessage"))
    with BagWriter(path) as w:
        for i in range(100):  # 5 s at 20 Hz; b -> c stops after 1 s; dup_a and dup_b both send payload
            t = T0 + i * 50_000_000
            for p, c in (("a", "b"), ("b", "c"), ("c", "d"), ("d", "e")):
                if c != "c" or i < 20:
                    w.write("tf", wire.encode_tf([ts(p, c, t)]), enc, sender=f"/pub_{c}", log_time=t + 1_000_000)
            w.write("tf", wire.encode_tf([ts("a", "payload", t)]), enc, sender="/dup_a", log_time=t + 1_000_000)
            w.write("tf", wire.encode_tf([ts("a", "payload", t + 7)]), enc, sender="/dup_b", log_time=t + 2_000_000)
    why = zentf(["tf", "why", "a", "e", "--bag", str(path), "--json"], None)
    assert why.returncode == 1, why.stderr
    assert json.loads(why.stdout)["stale_edges"] == ["b -> c"]
    doc = zentf(["tf", "doctor", "--bag", str(path), "--json"], None)
    found = _codes(json.loads(doc.stdout))
    assert found["dead_frame"][0]["frames"] == ["c"] and found["dead_frame"][0]["publishers"] == ["/pub_c"]
    assert found["multiple_publishers"][0]["publishers"] == ["/dup_a", "/dup_b"]
    assert doc.returncode == 1


def test_tf_topic_options():
    from zentf.cli.tf_topics import _parse_ros_args, _topics, split_ros_args

    assert split_ros_args(["a", "--ros-args", "-r", "/tf:=x", "--", "b"]) == (["a", "b"], ["-r", "/tf:=x"])
    t = _topics((), (), False, _parse_ros_args(["-r", "/tf:=/r1/tf", "-p", "use_sim_time:=true"]))
    assert (t.dynamic, t.static, t.params) == (["/r1/tf"], ["/r1/tf_static"], {"use_sim_time": True})
    t = _topics(("r1/tf", "r2/tf"), ("r1/tf_static",), False, None)
    assert t.pairs() == [("r1/tf", "r1/tf_static"), ("r2/tf", None)]
    assert _topics((), (), True, None).dynamic == ["/**/tf"]
    assert _topics((), (), False, None).default
    for bad in (["-r", "/odom:=/x"], ["--log-level", "debug"], ["-r"], ["-r", "/tf:="]):
        with pytest.raises(click.UsageError):
            _parse_ros_args(bad)
    with pytest.raises(click.BadParameter):
        _topics(("ro*bot/tf",), (), False, None)
    with pytest.raises(click.UsageError):
        _topics(("r1/tf",), (), True, None)


def test_clock_offset_against_sim_time():
    ev = Evidence(sim_time=True)
    for i in range(40):
        arrival = T0 + i * 50_000_000
        sim = 100 * NS + i * 50_000_000   # /clock: 100 s into the simulation
        ev.add([_row("world", "base", sim)], "/sim_ok", False, arrival_ns=arrival, clock_ns=sim)
        ev.add([_row("world", "arm", sim - 5 * NS // 2)], "/sim_late", False, arrival_ns=arrival, clock_ns=sim)
        ev.add([_row("world", "leg", T0)], "/early", False, arrival_ns=arrival, clock_ns=0)  # before any /clock
    found = _codes(_report(ev, at=2.0))
    assert [f["publishers"] for f in found["clock_offset"]] == [["/sim_late"]]
    assert "behind /clock (sim time)" in found["clock_offset"][0]["title"]
