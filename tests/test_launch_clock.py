"""The launcher's sim clock: /clock at a rate factor, and pause/resume/rate through `zentf clock`."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path
from typing import Iterator

import pytest

from conftest import REPO, Proc, child_env, free_port
from zentf.transport.wire import codec as wire
from zentf.transport.options import ZenohOptions


@pytest.fixture
def clock_env(isolated_router: str, test_namespace: str) -> dict[str, str]:
    """Own router per test: /clock is an absolute topic, so namespaces cannot keep tests apart."""
    return child_env(isolated_router, test_namespace)


class Av1Samples:
    """Every av1 transform on <ns>/tf and every /clock value, with the wall time it arrived."""

    def __init__(self, session, namespace: str) -> None:
        self.cond = threading.Condition()
        self.av1: list[tuple[float, int, float]] = []   # (wall s, stamp ns, angle)
        self.clock: list[int] = []
        self._subs = [session.declare_subscriber(f"{namespace}/tf", self._on_tf),
                      session.declare_subscriber("clock", self._on_clock)]

    def _on_tf(self, sample) -> None:
        now = time.monotonic()
        for t in wire.unpack(sample.payload.to_bytes())["transforms"]:
            if t["child_frame_id"] == "av1":
                st, tr = t["header"]["stamp"], t["transform"]["translation"]
                with self.cond:
                    self.av1.append((now, st["sec"] * 10**9 + st["nanosec"], math.atan2(tr["y"], tr["x"])))
                    self.cond.notify_all()

    def _on_clock(self, sample) -> None:
        st = wire.unpack(sample.payload.to_bytes())["clock"]
        with self.cond:
            self.clock.append(st["sec"] * 10**9 + st["nanosec"])
            self.cond.notify_all()

    def wait(self, predicate, timeout: float = 20.0) -> None:
        with self.cond:
            assert self.cond.wait_for(predicate, timeout), "timed out waiting for samples"

    def close(self) -> None:
        for s in self._subs:
            s.undeclare()


@pytest.fixture
def drones_with_clock(clock_env: dict[str, str], tmp_path: Path, test_namespace: str) -> Iterator:
    """start(clock_yaml) -> (launcher Proc, Av1Samples); a drones graph (no plots) under a sim clock."""
    state: dict = {}

    def start(clock: str) -> tuple[Proc, Av1Samples]:
        f = tmp_path / "clocked.yaml"
        f.write_text(textwrap.dedent(f"""
            clock: {clock}
            include:
              - file: {REPO}/configs/drones.yaml
                args: {{plots: false}}
            """))
        session = ZenohOptions(connect=[clock_env["ZENTF_CONNECT"]], mode="client", no_multicast=True).open_session()
        samples = Av1Samples(session, test_namespace)
        proc = Proc([sys.executable, "-m", "zentf.launch", str(f)], env=clock_env, cwd=tmp_path)
        state.update(session=session, samples=samples, proc=proc)
        return proc, samples

    try:
        yield start
    finally:
        if "proc" in state:
            state["proc"].stop(timeout=5)
            state["samples"].close()
            state["session"].close()


def zentf_clock(env: dict[str, str], *args: str) -> dict:
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "clock", *args, "--json"], env=env,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def test_rate_10_makes_av1_circle_in_about_0_63_s(drones_with_clock):
    proc, s = drones_with_clock("{rate: 10, frequency: 200}")
    proc.wait_for_line(r"sim clock: /clock from t=", 30)
    s.wait(lambda: len(s.av1) >= 2 and s.av1[-1][0] - s.av1[0][0] >= 1.2, 30)
    with s.cond:
        pts = list(s.av1)
    # unwrap the angle and fit angle = w * wall + c: one circle takes 2 pi / w wall seconds
    walls = [p[0] for p in pts]
    angles = [pts[0][2]]
    for _, _, a in pts[1:]:
        d = (a - angles[-1] + math.pi) % (2 * math.pi) - math.pi
        angles.append(angles[-1] + d)
    n = len(walls)
    mw, ma = sum(walls) / n, sum(angles) / n
    w = sum((x - mw) * (y - ma) for x, y in zip(walls, angles)) / sum((x - mw) ** 2 for x in walls)
    period = 2 * math.pi / w
    assert period == pytest.approx(0.628, rel=0.15), (period, n)
    sim_span = (pts[-1][1] - pts[0][1]) / 1e9
    assert sim_span / (walls[-1] - walls[0]) == pytest.approx(10.0, rel=0.15)


def test_paused_clock_freezes_av1_and_zentf_clock_controls_it(drones_with_clock, clock_env):
    proc, s = drones_with_clock("{rate: 10, paused: true, start: 1000}")
    proc.wait_for_line(r"sim clock: .*\(paused\)", 30)
    st = zentf_clock(clock_env, "status")
    assert st["paused"] is True and st["rate"] == 10 and st["time_ns"] == 1000 * 10**9
    # frozen: 20 more /clock messages all say t = 1000 s, and no av1 pose is newer than that
    s.wait(lambda: len(s.clock) >= 20)
    with s.cond:
        assert set(s.clock) == {1000 * 10**9}
        assert all(stamp <= 1000 * 10**9 for _, stamp, _ in s.av1)
    st = zentf_clock(clock_env, "resume")
    assert st["paused"] is False
    s.wait(lambda: any(stamp > 1000 * 10**9 for _, stamp, _ in s.av1))  # av1 flies again
    st = zentf_clock(clock_env, "pause")
    frozen = st["time_ns"]
    with s.cond:
        seen = len(s.clock)
    s.wait(lambda: len(s.clock) >= seen + 20)
    with s.cond:
        assert s.clock[-1] == frozen
        assert max(stamp for _, stamp, _ in s.av1) <= frozen
    assert zentf_clock(clock_env, "rate", "2.5")["rate"] == 2.5
    out = proc.output()
    assert "sim clock paused" in out and "sim clock resumed" in out and "rate set to 2.5x" in out


def test_zentf_clock_without_a_launcher_says_so(clock_env):
    # none in the graph: one line at once (the 30 s timeout is for a clock that is there but silent)
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "clock", "pause", "--timeout", "30"], env=clock_env,
                       capture_output=True, text=True, timeout=20)
    assert r.returncode == 1
    assert r.stderr == ("zentf: error: no sim clock to control: no `zentf launch` with a clock: section is "
                        "running (nothing publishes /clock)\n")
    r = subprocess.run([sys.executable, "-m", "zentf.cli", "clock", "rate", "0"], env=clock_env,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "rate FACTOR must be between 1e-06 and 1e+06, got 0.0" in r.stderr


def test_sim_time_pause_resume_and_rate_keep_time_continuous(monkeypatch):
    from zentf.launch import sim_clock

    wall = [0]
    monkeypatch.setattr(sim_clock.time, "monotonic_ns", lambda: wall[0])
    st = sim_clock.SimTime(start_ns=100, rate=10.0)
    wall[0] = 1_000
    assert st.now_ns() == 100 + 10_000
    st.pause()
    wall[0] = 5_000
    assert st.now_ns() == 10_100 and st.state()["paused"] is True
    st.resume()
    wall[0] = 6_000
    assert st.now_ns() == 10_100 + 10_000
    st.set_rate(0.5)
    wall[0] = 8_000
    assert st.now_ns() == 20_100 + 1_000
    for bad in (0, -1.0, float("nan"), float("inf"), 1e-300, 1e300):
        with pytest.raises(ValueError, match="rate must be between 1e-06 and 1e"):
            st.set_rate(bad)


def test_a_clock_only_launch_keeps_serving_until_ctrl_c(clock_env, tmp_path):
    import signal

    f = tmp_path / "clock_only.yaml"
    f.write_text("clock: {start: 5, rate: 0.5}\n")
    p = Proc([sys.executable, "-m", "zentf.launch", str(f)], env=clock_env, cwd=tmp_path)
    try:
        p.wait_for_line(r"sim clock: /clock from t=5\.000 s at 0\.5x", 30)
        st = zentf_clock(clock_env)
        assert st["paused"] is False and st["rate"] == 0.5 and st["time"] >= 5.0
        assert p.returncode is None
        p.signal(signal.SIGINT)
        assert p.wait(10) == 0
    finally:
        p.stop()


def test_zentf_clock_with_zero_configuration_reaches_a_launcher_that_is_not_the_rendezvous(spawn, tmp_path):
    """`zentf clock` asks as the graph listings do (a client of the machine's rendezvous), so it finds a
    launcher's clock in the local profile even when another process holds the rendezvous."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PYTHONUNBUFFERED="1", ZENTF_LOCAL_PORT=str(free_port()),
               PYTHONPATH=os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
    holder = spawn([sys.executable, "-m", "zentf.cli", "static-transform-publisher", "--frame-id", "a",
                    "--child-frame-id", "b"], env=env)
    holder.wait_for_line(r"Spinning until stopped", 30)
    f = tmp_path / "clock_only.yaml"
    f.write_text("clock: {start: 5, rate: 0.5}\n")
    launcher = spawn([sys.executable, "-m", "zentf.launch", str(f)], env=env, cwd=tmp_path)
    launcher.wait_for_line(r"sim clock: /clock from t=5\.000 s at 0\.5x", 30)
    st = zentf_clock(env)
    assert st["paused"] is False and st["rate"] == 0.5 and st["time"] >= 5.0
    assert zentf_clock(env, "pause")["paused"] is True
