"""`zentf tf doctor` and `zentf tf why` against real graphs: each staged problem named with its publisher.

One graph holds every staged problem at once (they do not mask each other: each has frames of its own)
beside a healthy drones publisher; the same graph is recorded and the doctor run on the bag.
"""
from __future__ import annotations

import json
import re
import signal
import sys
import time

import pytest

from cli_helpers import zentf, zentf_together
from conftest import REPO, Proc

STAGER = str(REPO / "tests" / "tf_stager.py")


def _send(parent: str, child: str, rate: float = 20.0, **kw: object) -> dict:
    return {"parent": parent, "child": child, "rate": rate, **kw}


def _stager(spawn, nodes: list[dict], env: dict | None = None) -> Proc:
    p = spawn.python(STAGER, json.dumps({"nodes": nodes}), env=env)
    p.wait_for_line(r"^staged$", timeout=60)
    return p


def _codes(report: dict) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for f in report["findings"]:
        out.setdefault(f["code"], []).append(f)
    return out


def _one(findings: dict, code: str, frame: str) -> dict:
    hits = [f for f in findings.get(code, []) if frame in f["frames"]]
    assert len(hits) == 1, (code, frame, findings)
    return hits[0]


def test_doctor_on_a_healthy_drones_graph_reports_nothing(spawn, zenoh_env):
    """30 s of the drones demo: not one finding, only the summary line (and exit code 0)."""
    spawn([sys.executable, "-m", "zentf.cli", "launch", "drones"]).wait_for_line(r"publishing av1 and av2", 60)
    # the 30 s JSON report and a 1 s text one, at once (two independent doctors of the same graph)
    proc, text = zentf_together([["tf", "doctor", "--duration", "30", "--json"], ["tf", "doctor", "--duration", "1"]],
                                zenoh_env, timeout=120)
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    report = json.loads(proc.stdout)
    assert report["healthy"] and report["findings"] == [], report["findings"]
    rates = {e["frame"]: e["rate"] for e in report["edges"]}
    assert set(rates) == {"av1", "av2"} and all(5 < r < 55 for r in rates.values()), rates  # (50 Hz unloaded)
    assert report["trees"][0]["root"] == "world" and report["trees"][0]["lct_lag"] < 1.0
    assert text.returncode == 0 and text.stdout.strip().splitlines() == [text.stdout.strip()], text.stdout
    assert "no problems found" in text.stdout


def test_doctor_names_each_staged_problem_live_and_in_a_bag(spawn, zenoh_env, zenoh_session, test_namespace,
                                                             tmp_path):
    ns = "/" + test_namespace
    spawn([sys.executable, "-m", "zentf.cli", "run", "frames_publisher"]).wait_for_line(r"publishing av1", 60)
    rec_path = tmp_path / "staged.mcap"
    recorder = spawn([sys.executable, "-m", "zentf.cli", "bag", "record", "tf", "tf_static", "-o", str(rec_path)])
    recorder.wait_for_line(r"recording", 60)
    _stager(spawn, [
        {"name": "dup_a", "sends": [_send("world", "payload")]},
        {"name": "dup_b", "sends": [_send("world", "payload")]},
        {"name": "laggard", "sends": [_send("av1", "gimbal", offset=-2.5)]},
        {"name": "cam_static", "sends": [_send("av2", "camera", static=True, translation=[0.1, 0, 0])]},
        {"name": "cam_on_tf", "sends": [_send("av2", "camera", 10.0, translation=[0.1, 0, 0])]},
        {"name": "odom_pub", "sends": [_send("odom2", "base2")]},
        {"name": "loop_a", "sends": [_send("loop_x", "loop_y", 10.0)]},
        {"name": "loop_b", "sends": [_send("loop_y", "loop_x", 10.0)]},
    ])
    doomed = _stager(spawn, [{"name": "doomed", "sends": [_send("world", "beacon")]}])
    doctor = Proc([sys.executable, "-m", "zentf.cli", "tf", "doctor", "--duration", "8", "--json"], env=zenoh_env)
    _wait_for_nodes(zenoh_session, test_namespace, [f"_zentf_tf_doctor_{doctor.pid}"])
    _wait_for_senders(zenoh_session, test_namespace, [f"{ns}/doomed", f"{ns}/dup_a", f"{ns}/loop_b"])
    time.sleep(1.0)
    doomed.kill()  # a crash: no goodbye, Zenoh drops its session and its tokens
    assert doctor.wait(60) == 1, doctor.output()
    report = json.loads(doctor.output()[doctor.output().index("{"):])
    found = _codes(report)

    dup = _one(found, "multiple_publishers", "payload")
    assert set(dup["publishers"]) == {f"{ns}/dup_a", f"{ns}/dup_b"}
    lag = _one(found, "clock_offset", "gimbal")
    assert lag["publishers"] == [f"{ns}/laggard"]
    behind = float(re.search(r"stamps (\d+\.\d+) s behind this machine's clock", lag["title"]).group(1))
    assert 2.4 <= behind < 3.5, lag["title"]  # 2.5 s plus the latency of a loaded machine
    dead = _one(found, "dead_frame", "beacon")
    assert dead["publishers"] == [f"{ns}/doomed"] and "left the graph" in dead["title"]
    cam = _one(found, "static_on_tf", "camera")
    assert f"{ns}/cam_on_tf" in cam["title"]
    roots = found["multiple_roots"][0]
    assert {"world", "odom2"} <= set(roots["frames"]) and f"{ns}/odom_pub" in roots["publishers"]
    loop = found["loop"][0]
    assert set(loop["frames"]) == {"loop_x", "loop_y"} and set(loop["publishers"]) == {f"{ns}/loop_a", f"{ns}/loop_b"}
    # no false positive on the healthy drones beside them
    for f in report["findings"]:
        assert not {"av1", "av2"} & set(f["frames"]) or f["code"] == "multiple_roots", f
        assert f"{ns}/frames_publisher" not in f["publishers"] or f["code"] == "multiple_roots", f

    time.sleep(1.5)  # the bag must outlive the beacon by more than the dead limit
    recorder.signal(signal.SIGINT)
    assert recorder.wait(30) == 0, recorder.output()
    proc = zentf(["tf", "doctor", "--bag", str(rec_path), "--json"], zenoh_env)
    assert proc.returncode == 1, (proc.stdout, proc.stderr)
    bag = _codes(json.loads(proc.stdout))
    assert set(_one(bag, "multiple_publishers", "payload")["publishers"]) == {f"{ns}/dup_a", f"{ns}/dup_b"}
    assert _one(bag, "clock_offset", "gimbal")["publishers"] == [f"{ns}/laggard"]
    assert _one(bag, "dead_frame", "beacon")["publishers"] == [f"{ns}/doomed"]
    assert f"{ns}/cam_on_tf" in _one(bag, "static_on_tf", "camera")["title"]
    assert {"world", "odom2"} <= set(bag["multiple_roots"][0]["frames"])
    assert set(bag["loop"][0]["publishers"]) == {f"{ns}/loop_a", f"{ns}/loop_b"}


def _chain(tag: str) -> list[tuple[str, str]]:
    f = [f"{c}{tag}" for c in "abcde"]
    return list(zip(f, f[1:]))


def _wait_for_nodes(session, namespace: str, names: list[str], timeout: float = 60.0) -> None:
    """Until these nodes are in the graph (their tf taps are declared right after their node)."""
    from zentf.transport.graph import GraphWatcher

    with GraphWatcher(session, namespace=namespace) as watcher:
        assert watcher.wait_for(lambda es: set(names) <= {e.name for e in es if e.kind == "node"}, timeout), names


def _wait_for_senders(session, namespace: str, senders: list[str], timeout: float = 60.0) -> None:
    """Until tf samples of each sender reach a subscriber declared now (so one declared before it, the tool's,
    is known to their sessions too: a publisher sends only where it knows a subscriber)."""
    import threading

    from zentf.transport.wire.codec import authority_of

    seen: set[str] = set()
    done = threading.Event()

    def on_sample(sample) -> None:
        seen.add(authority_of(sample.attachment, ""))
        if set(senders) <= seen:
            done.set()

    sub = session.declare_subscriber(f"{namespace}/tf", on_sample)
    try:
        assert done.wait(timeout), (senders, seen)
    finally:
        sub.undeclare()


def test_why_names_every_stale_edge_of_a_four_deep_chain(spawn, zenoh_env, zenoh_session, test_namespace):
    """a -> b -> c -> d -> e: chain 1 with b -> c stale, chain 2 with b -> c and c -> d stale."""
    ns = "/" + test_namespace
    one, two = _chain("1"), _chain("2")
    stager = _stager(spawn, [
        {"name": "healthy1", "sends": [_send(*one[0]), _send(*one[2]), _send(*one[3])]},
        {"name": "stale1", "sends": [_send(*one[1], stop_on="SIGUSR1")]},
        {"name": "healthy2", "sends": [_send(*two[0]), _send(*two[3])]},
        {"name": "stale2", "sends": [_send(*two[1], stop_on="SIGUSR1"), _send(*two[2], stop_on="SIGUSR1")]},
    ])
    why1 = Proc([sys.executable, "-m", "zentf.cli", "tf", "why", "a1", "e1", "--duration", "8", "--json"],
                env=zenoh_env)
    why2 = Proc([sys.executable, "-m", "zentf.cli", "tf", "why", "a2", "e2", "--duration", "8"], env=zenoh_env)
    _wait_for_nodes(zenoh_session, test_namespace, [f"_zentf_tf_why_{why1.pid}", f"_zentf_tf_why_{why2.pid}"])
    _wait_for_senders(zenoh_session, test_namespace, [f"{ns}/stale1", f"{ns}/stale2"])
    time.sleep(1.0)  # both hear every edge for a while, then two of them fall silent
    stager.signal(signal.SIGUSR1)
    assert why1.wait(60) == 1, why1.output()
    ex = json.loads(why1.output()[why1.output().index("{"):])
    assert ex["stale_edges"] == ["b1 -> c1"], json.dumps(ex, indent=1)
    now = next(v for v in ex["verdicts"] if v["label"] == "now")
    stale = [f for f in now["failing"] if f["kind"] == "stale"]
    assert [f["edge"] for f in stale] == ["b1 -> c1"] and f"{ns}/stale1" in stale[0]["detail"]
    assert [e["publisher"] for e in ex["chain"] if e["child"] == "c1"] == [f"{ns}/stale1"]
    assert not now["ok"] and any("Time(0)" in fix for fix in now["fixes"])
    assert why2.wait(60) == 1, why2.output()
    text = why2.output()
    assert "edge b2 -> c2: stale" in text and "edge c2 -> d2: stale" in text, text
    assert "edge a2 -> b2: stale" not in text and "edge d2 -> e2: stale" not in text, text
    assert f"{ns}/stale2" in text


def test_doctor_and_monitor_name_ros2_publishers_by_node(spawn, ros2_env):
    """--wire ros2: the sender is the GID in rmw_zenoh's attachment, resolved through the graph's tokens."""
    _stager(spawn, [{"name": "dup_a", "sends": [_send("world", "payload")]},
                    {"name": "dup_b", "sends": [_send("world", "payload")]}], env=ros2_env)
    proc, mon = zentf_together([["tf", "doctor", "--duration", "2.5", "--json"], ["tf", "monitor", "--duration", "2"]],
                               ros2_env)  # at once: two independent observers
    assert proc.returncode == 1, (proc.stdout, proc.stderr)
    dup = _one(_codes(json.loads(proc.stdout)), "multiple_publishers", "payload")
    assert set(dup["publishers"]) == {"/dup_a", "/dup_b"}, dup
    assert mon.returncode == 0, mon.stderr
    assert "/dup_a" in mon.stdout or "/dup_b" in mon.stdout, mon.stdout
    assert "Authority undetectable" not in mon.stdout and "gid" not in mon.stdout, mon.stdout


def test_tf_tools_read_a_fleet(spawn, zenoh_env, test_namespace, tmp_path):
    """--tf-topic, --ros-args -r /tf:=..., --all-namespaces on echo, monitor, doctor and why (frames and view
    share echo's listeners)."""
    env = dict(zenoh_env)
    _stager(spawn, [{"name": "r1", "namespace": f"{test_namespace}/robot1",
                     "sends": [_send("world", "r1/base")]},
                    {"name": "r2", "namespace": f"{test_namespace}/robot2",
                     "sends": [_send("world", "r2/base")]}], env=env)
    # five independent observers of the staged fleet, at once (their listening windows overlap)
    echo1, echo2, mon, doc, why = zentf_together([
        ["tf", "echo", "world", "r1/base", "-c", "1", "--timeout", "20", "--tf-topic", "robot1/tf"],
        ["tf", "echo", "world", "r2/base", "-c", "1", "--timeout", "20",
         "--ros-args", "-r", f"/tf:=/{test_namespace}/robot2/tf"],
        ["tf", "monitor", "--duration", "1.5", "--all-namespaces"],
        ["tf", "doctor", "--duration", "1.5", "--tf-topic", "robot2/tf", "--json"],
        ["tf", "why", "r1/base", "r2/base", "-d", "1.5", "-A"]], env)
    for echo in (echo1, echo2):
        assert echo.returncode == 0 and "Translation" in echo.stdout, echo.stderr
    assert "r1/base" in mon.stdout and "r2/base" in mon.stdout, mon.stdout
    assert {e["frame"] for e in json.loads(doc.stdout)["edges"]} == {"r2/base"}, doc.stdout
    assert "world -> r2/base" in why.stdout and "world -> r1/base" in why.stdout, why.stdout
    try:
        import rerun  # noqa: F401  (zentf[view])
    except ImportError:
        pass
    else:  # zentf view: one listener per topic pair, the frames of that robot only
        view = zentf(["view", "--save", str(tmp_path / "r1.rrd"), "--duration", "2", "--robot-description", "",
                      "--tf-topic", "robot1/tf"], env, timeout=90)
        assert view.returncode == 0, view.stderr
        assert re.search(r"\b2 frames shown", view.stderr), view.stderr  # world and r1/base, not r2/base
    bad = zentf(["tf", "doctor", "-d", "1", "--ros-args", "-r", "/odom:=/x"], env)
    assert bad.returncode == 2 and "only /tf and /tf_static" in bad.stderr, bad.stderr
