"""bench/fleet.py runs: two robots through a zentf router to a per-robot and a fleet-wide listener, and
the same traffic as raw Zenoh puts, then one table with both and their ratio."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


def test_fleet_bench_quick_prints_its_table(tmp_path: Path) -> None:
    if shutil.which("ss") is None:  # the bench reads the listeners' received bytes from ss
        if os.environ.get("CI"):
            pytest.fail("ss (iproute2) is missing")
        pytest.skip("ss (iproute2) is missing: apt-get install iproute2")
    out = tmp_path / "fleet.json"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env["PYTHONPATH"] = str(REPO)
    proc = subprocess.run([sys.executable, str(REPO / "bench/fleet.py"), "--quick", "--robots", "2", "--procs", "1",
                           "--seconds", "1", "--warmup", "0.3", "--json", str(out)],
                          capture_output=True, text=True, timeout=90, env=env, cwd=str(REPO))
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    assert "processes (several robots per process" in lines[0] and "ratio = zentf / raw" in lines[0], lines
    assert lines[1].split()[:2] == ["R", "impl"], lines
    assert [ln.split()[:2] for ln in lines[2:5]] == [["2", "zentf"], ["2", "raw"], ["ratio", lines[4].split()[1]]]
    row = json.loads(out.read_text())["rows"][0]
    for impl in ("zentf", "raw"):
        r = row[impl]
        assert r["fleet_ktf_s"] > 0 and r["robot_kB_s"] > 0, (impl, r)  # both listeners got data
        assert r["lat_robot"]["n"] > 0 and r["lat_fleet"]["n"] > 0, (impl, r)
    # the per-robot listener reads one robot of two, the fleet listener both
    z = row["zentf"]
    assert z["fleet_ktf_s"] > 1.5 * z["robot_msgs_s"] * 50 / 1000, z
