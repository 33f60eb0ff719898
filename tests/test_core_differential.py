"""Differential tests: random scenarios answered by the real tf2 (python3-tf2) and by zentf, op by op.

The oracle runs in a /usr/bin/python3 subprocess (tests/ref_runner.py) that expands the same
seeds with gen_scenario.py, while this process answers them with zentf. Agreement must be total:
same exception class and message, translations within 1e-9, rotations equal up to sign within
1e-9, identical stamps and frame ids, identical can_transform answers and reasons (the runner asks
tf2 for the reason string, which tf2_oracle.py itself drops).

One deliberate accommodation: tf2_py turns every time into float seconds (``rospy.Time.to_sec``)
and back (``ros::Time::fromSec``), which can move a stamp by 1 ns. That is the binding, not tf2's
semantics, so ``oracle_time_ns`` replays exactly that conversion on the inputs given to zentf
(verified against the oracle on 20k random stamps when this was written); outputs are then
compared exactly.
"""
from __future__ import annotations

import importlib.util
import json
import pickle
import threading
import logging
import math
import os
import subprocess
from functools import lru_cache
from pathlib import Path
from typing import Any

import pytest

from zentf.core import exceptions as zx
from zentf.core.buffer_core import BufferCore
from zentf.core.time import Time

REF_DIR = Path(os.environ.get("ZENTF_REF_DIR") or Path(__file__).resolve().parents[2] / "shared" / "ref")
RUNNER = Path(__file__).resolve().parent / "ref_runner.py"
SYSTEM_PYTHON = "/usr/bin/python3"

SEEDS_PER_CHUNK = 25
DEFAULT_CHUNKS = 8          # 200 seeds in the default run
SLOW_CHUNKS = 16            # 400 more seeds, other shapes, under -m slow


@lru_cache(maxsize=1)
def oracle_problem() -> str:
    """Why the oracle cannot run here ('' if it can)."""
    if not (REF_DIR / "tf2_oracle.py").exists() or not (REF_DIR / "gen_scenario.py").exists():
        return f"tf2 reference scripts not found in {REF_DIR} (set ZENTF_REF_DIR)"
    if not Path(SYSTEM_PYTHON).exists():
        return f"{SYSTEM_PYTHON} not found"
    r = subprocess.run([SYSTEM_PYTHON, "-c", "import tf2_py, rospy"], capture_output=True, timeout=60)
    if r.returncode != 0:
        return f"{SYSTEM_PYTHON} cannot import tf2_py (apt-get install python3-tf2)"
    return ""


def require_oracle() -> None:
    problem = oracle_problem()
    if problem:
        if os.environ.get("CI"):
            pytest.fail(f"differential tests need the tf2 oracle in CI: {problem}")
        pytest.skip(problem)


@lru_cache(maxsize=1)
def generator():
    spec = importlib.util.spec_from_file_location("zentf_ref_gen_scenario", REF_DIR / "gen_scenario.py")
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod.generate


def oracle_time_ns(pair: list[int]) -> int:
    """rospy.Time(sec, nsec).to_sec() then ros::Time::fromSec(), as tf2_py does to every time."""
    t = float(pair[0]) + float(pair[1]) / 1e9
    sec = math.floor(t)
    x = (t - sec) * 1e9
    nsec = int(math.floor(x + 0.5))  # boost::math::round: half away from zero (x >= 0 here)
    return sec * 1_000_000_000 + nsec


def zentf_answer(core: BufferCore, op: dict[str, Any]) -> dict[str, Any]:
    kind = op["op"]
    if kind == "set":
        core.set_transform_raw(op["parent"], op["child"], oracle_time_ns(op["stamp"]), *op["t"], *op["q"],
                               op.get("authority", "oracle"), bool(op.get("static")))
        return {"ok": True}
    if kind == "lookup":
        return _ts(core.lookup_transform(op["target"], op["source"], Time(nanoseconds=oracle_time_ns(op["time"]))))
    if kind == "lookup_full":
        return _ts(core.lookup_transform_full(
            op["target"], Time(nanoseconds=oracle_time_ns(op["target_time"])), op["source"],
            Time(nanoseconds=oracle_time_ns(op["source_time"])), op["fixed"]))
    if kind == "can":
        ok, msg = core.can_transform(op["target"], op["source"], Time(nanoseconds=oracle_time_ns(op["time"])),
                                     return_debug_tuple=True)
        return {"ok": True, "can": ok, "message": msg}
    if kind == "can_full":
        ok, msg = core.can_transform_full(
            op["target"], Time(nanoseconds=oracle_time_ns(op["target_time"])), op["source"],
            Time(nanoseconds=oracle_time_ns(op["source_time"])), op["fixed"], return_debug_tuple=True)
        return {"ok": True, "can": ok, "message": msg}
    if kind == "clear":
        core.clear()
        return {"ok": True}
    raise ValueError(f"unknown op {kind!r}")


def _ts(m) -> dict[str, Any]:
    tr, rot = m.transform.translation, m.transform.rotation
    return {"ok": True, "t": [tr.x, tr.y, tr.z], "q": [rot.x, rot.y, rot.z, rot.w],
            "stamp": [m.header.stamp.sec, m.header.stamp.nanosec],
            "frame_id": m.header.frame_id, "child_frame_id": m.child_frame_id}


def answer_all(scenario: dict[str, Any]) -> list[dict[str, Any]]:
    core = BufferCore(scenario.get("cache_time", 10.0))
    out = []
    log = logging.getLogger("zentf.core.buffer_core")
    level = log.level
    log.setLevel(logging.CRITICAL)  # thousands of TF_OLD_DATA warnings are expected here
    try:
        for op in scenario["ops"]:
            try:
                out.append(zentf_answer(core, op))
            except zx.TransformException as e:
                out.append({"ok": False, "error": type(e).__name__, "message": str(e)})
    finally:
        log.setLevel(level)
    return out


def mismatch(op: dict[str, Any], want: dict[str, Any], got: dict[str, Any]) -> str:
    """'' if the answers agree, else a description."""
    if want["ok"] != got["ok"]:
        return f"oracle {want} vs zentf {got}"
    if not want["ok"]:
        if want["error"] != got["error"] or want["message"] != got["message"]:
            return f"oracle {want['error']}: {want['message']!r}\n zentf {got['error']}: {got['message']!r}"
        return ""
    if "can" in want:
        if want["can"] != got["can"]:
            return f"can_transform oracle {want['can']} vs zentf {got['can']}"
        if "message" in want and want["message"] != got["message"]:
            return f"can_transform reason: oracle {want['message']!r}\n zentf {got['message']!r}"
        return ""
    if "t" not in want:
        return ""
    for k in ("stamp", "frame_id", "child_frame_id"):
        if want[k] != got[k]:
            return f"{k}: oracle {want[k]} vs zentf {got[k]}"
    if max(abs(a - b) for a, b in zip(want["t"], got["t"])) > 1e-9:
        return f"translation: oracle {want['t']} vs zentf {got['t']}"
    same = max(abs(a - b) for a, b in zip(want["q"], got["q"]))
    flipped = max(abs(a + b) for a, b in zip(want["q"], got["q"]))
    if min(same, flipped) > 1e-9:
        return f"rotation: oracle {want['q']} vs zentf {got['q']}"
    return ""


def run_jobs(jobs: list[dict[str, Any]]) -> None:
    """Answer jobs with the oracle (subprocess, in parallel) and zentf; assert total agreement."""
    require_oracle()
    generate = generator()
    # generated here only: gen_scenario iterates a set of str, so another process (other
    # PYTHONHASHSEED) would build a different scenario from the same seed
    scenarios = [generate(j["seed"], j["frames"], j["lookups"], j["cache_time"]) for j in jobs]
    payload = pickle.dumps({"scenarios": scenarios}, protocol=4)
    proc = subprocess.Popen([SYSTEM_PYTHON, str(RUNNER), str(REF_DIR), "--pickle"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    try:
        assert proc.stdin is not None and proc.stdout is not None
        writer = threading.Thread(target=_feed, args=(proc.stdin, payload), daemon=True)
        writer.start()
        ours = [answer_all(s) for s in scenarios]   # meanwhile the oracle works on its copy
        theirs = pickle.loads(proc.stdout.read())
        writer.join()
        assert proc.wait(timeout=600) == 0, "oracle runner failed"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    failures = []
    checked = 0
    for job, scenario, want_all, got_all in zip(jobs, scenarios, theirs, ours):
        assert len(want_all) == len(got_all) == len(scenario["ops"])
        for i, (op, want, got) in enumerate(zip(scenario["ops"], want_all, got_all)):
            checked += op["op"] != "set"
            problem = mismatch(op, want, got)
            if problem:
                failures.append(f"seed {job['seed']} op #{i} {op}:\n {problem}")
    assert not failures, f"{len(failures)} disagreements, first ones:\n" + "\n".join(failures[:5])
    assert checked > 0


def _feed(pipe, data: bytes) -> None:
    try:
        pipe.write(data)
    finally:
        pipe.close()


def _jobs(chunk: int, base: int, frames: int = 30, lookups: int = 200, cache_time: float = 10.0) -> list[dict]:
    first = base + chunk * SEEDS_PER_CHUNK
    return [{"seed": s, "frames": frames, "lookups": lookups, "cache_time": cache_time}
            for s in range(first, first + SEEDS_PER_CHUNK)]


@pytest.mark.parametrize("chunk", range(DEFAULT_CHUNKS))
def test_default_scenarios_agree_with_tf2(chunk: int) -> None:
    run_jobs(_jobs(chunk, 0))


@pytest.mark.slow
@pytest.mark.parametrize("chunk", range(SLOW_CHUNKS))
def test_more_scenarios_agree_with_tf2(chunk: int) -> None:
    shapes = [dict(frames=30, lookups=200, cache_time=10.0), dict(frames=60, lookups=400, cache_time=10.0),
              dict(frames=12, lookups=300, cache_time=2.0), dict(frames=40, lookups=300, cache_time=30.0)]
    run_jobs(_jobs(chunk, 10_000, **shapes[chunk % len(shapes)]))


def test_hand_made_edge_cases_agree_with_tf2() -> None:
    """Corners the generator rarely hits: loops, type switches, repeated stamps, clear, NO_DATA."""
    def s(parent, child, sec, x=1.0, static=False, q=(0.0, 0.0, 0.0, 1.0)):
        return {"op": "set", "parent": parent, "child": child, "stamp": [sec, 0], "t": [x, 0.0, 0.0],
                "q": list(q), "static": static, "authority": "hand"}

    def lk(target, source, sec, nsec=0):
        return {"op": "lookup", "target": target, "source": source, "time": [sec, nsec]}

    def can(target, source, sec, nsec=0):
        return {"op": "can", "target": target, "source": source, "time": [sec, nsec]}

    ops = [
        lk("a", "b", 1), can("a", "b", 1),
        s("a", "b", 1), s("a", "b", 2, 2.0), s("a", "b", 2, 9.0),           # repeated: first wins
        lk("a", "b", 2), lk("a", "b", 1, 500_000_000), lk("a", "b", 3), lk("a", "b", 0),
        s("x", "y", 5), lk("a", "y", 1), lk("a", "y", 0), can("a", "y", 0),  # NO_DATA, two trees
        s("a", "b", 20, 5.0), lk("a", "b", 1), lk("a", "b", 15),            # pruned, old data gone
        s("a", "b", 9, 7.0),                                                 # TF_OLD_DATA
        s("s", "t", 5, 3.0, static=True), s("s", "t", 6, 4.0), lk("s", "t", 100), lk("s", "t", 0),
        s("a", "b", 30, 3.0, static=True), lk("a", "b", 30), lk("a", "b", 31),  # dynamic first: kept
        s("b", "c", 30), s("c", "b", 30), lk("a", "c", 30), lk("c", "zz", 30),  # a loop b<->c
        s("u", "v", 30), s("v", "w", 30), lk("w", "a", 30), lk("u", "w", 30), can("w", "a", 30),
        {"op": "clear"}, lk("a", "b", 0), lk("a", "b", 30), lk("s", "t", 7), can("a", "b", 0),
        s("a", "b", 40, 1.0), s("a", "b", 41, 2.0, q=(0.0, 0.0, 1.0, 0.0)), lk("a", "b", 40, 250_000_000),
        s("b", "e", 40), s("e", "b", 41), lk("a", "e", 40, 500_000_000),     # parent switch in between
        s("/a", "/f", 40), s("a", "a", 40), s("", "g", 40), s("a", "/", 40), lk("a", "f", 40),
        {"op": "lookup_full", "target": "a", "target_time": [40, 0], "source": "f", "source_time": [40, 0],
         "fixed": "a"},
        {"op": "lookup_full", "target": "a", "target_time": [40, 0], "source": "f", "source_time": [40, 0],
         "fixed": "nope"},
        {"op": "can_full", "target": "a", "target_time": [40, 0], "source": "f", "source_time": [99, 0],
         "fixed": "a"},
    ]
    scenario = {"cache_time": 10.0, "ops": ops}
    require_oracle()
    r = subprocess.run([SYSTEM_PYTHON, str(RUNNER), str(REF_DIR)], input=json.dumps({"scenarios": [scenario]}).encode(),
                       capture_output=True, timeout=120)
    assert r.returncode == 0, r.stderr.decode()[-2000:]
    (theirs,) = json.loads(r.stdout)
    ours = answer_all(scenario)
    problems = [f"op #{i} {op}: {mismatch(op, w, g)}" for i, (op, w, g) in enumerate(zip(ops, theirs, ours))
                if mismatch(op, w, g)]
    assert not problems, "\n".join(problems)


def chaos_scenario(seed: int, n_ops: int = 400) -> dict[str, Any]:
    """Small, dense scenarios the reference generator never makes: few frames and a coarse stamp
    grid (so repeated stamps, exact-sample lookups and re-parenting are frequent), static/dynamic
    switches, loops, clear(), leading slashes, NaN and denormalized input, a short cache."""
    import random

    rng = random.Random(seed)
    frames = ["a", "b", "c", "d", "e", "f"]
    grid = [1000 + k * 0.25 for k in range(24)]

    def when() -> list[int]:
        r = rng.random()
        if r < 0.15:
            return [0, 0]
        t = rng.choice(grid) + (rng.choice([0.0, 0.0, 0.125, 0.0625, 1e-9]) if r < 0.9 else rng.uniform(-3, 9))
        sec = int(t)
        return [sec, int(round((t - sec) * 1e9)) % 1_000_000_000]

    ops: list[dict[str, Any]] = []
    for _ in range(n_ops):
        kind = rng.random()
        if kind < 0.5:
            parent, child = rng.sample(frames, 2)
            q = [rng.uniform(-1, 1) for _ in range(4)]
            norm = math.sqrt(sum(x * x for x in q)) or 1.0
            q = [x / norm for x in q]
            t = [rng.uniform(-2, 2) for _ in range(3)]
            bad = rng.random()
            if bad < 0.03:
                t[0] = float("nan")
            elif bad < 0.06:
                q = [0.0, 0.0, 0.3, 0.3]
            elif bad < 0.09:
                parent = "/" + parent
            elif bad < 0.11:
                child = parent
            stamp = when()
            if stamp == [0, 0]:
                stamp = [1000, 0]
            ops.append({"op": "set", "parent": parent, "child": child, "stamp": stamp, "t": t, "q": q,
                        "static": rng.random() < 0.15, "authority": "chaos"})
        elif kind < 0.52:
            ops.append({"op": "clear"})
        else:
            a, b = rng.choice(frames + ["zz", "", "/a"]), rng.choice(frames)
            r = rng.random()
            if r < 0.45:
                ops.append({"op": "lookup", "target": a, "source": b, "time": when()})
            elif r < 0.7:
                ops.append({"op": "can", "target": a, "source": b, "time": when()})
            elif r < 0.9:
                ops.append({"op": "lookup_full", "target": a, "target_time": when(), "source": b,
                            "source_time": when(), "fixed": rng.choice(frames)})
            else:
                ops.append({"op": "can_full", "target": a, "target_time": when(), "source": b,
                            "source_time": when(), "fixed": rng.choice(frames)})
    return {"seed": seed, "cache_time": rng.choice([1.0, 2.0, 10.0]), "ops": ops}


def test_chaos_scenarios_agree_with_tf2() -> None:
    require_oracle()
    scenarios = [chaos_scenario(seed) for seed in range(60)]
    r = subprocess.run([SYSTEM_PYTHON, str(RUNNER), str(REF_DIR), "--pickle"],
                       input=pickle.dumps({"scenarios": scenarios}, protocol=4), capture_output=True, timeout=300)
    assert r.returncode == 0, r.stderr.decode()[-2000:]
    theirs = pickle.loads(r.stdout)
    failures = []
    for scenario, want_all in zip(scenarios, theirs):
        got_all = answer_all(scenario)
        for i, (op, want, got) in enumerate(zip(scenario["ops"], want_all, got_all)):
            problem = mismatch(op, want, got)
            if problem:
                failures.append(f"chaos seed {scenario['seed']} op #{i} {op}:\n {problem}")
    assert not failures, f"{len(failures)} disagreements, first ones:\n" + "\n".join(failures[:5])
