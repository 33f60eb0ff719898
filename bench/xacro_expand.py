"""xacro expansion: zentf's confined xacro against the xacro package, on the real models in tests/data.

    python bench/xacro_expand.py [--runs 7]

Each row: the median wall time of turning a .xacro file into URDF text, called from a running Python
process (as robot_state_publisher does at start): zentf (``expand_file``: it starts a child
interpreter, which confines itself and expands) against the reference, the PyPI ``xacro`` package
(``xacro.process_file`` in this process, no isolation; its ``$(find)`` answered from the fixtures'
folders; needs the test extra). The two run interleaved, in the same conditions; note the machine's
load beside the numbers. Then the 2 KB macro bomb through ``zentf urdf check`` (the xacro package
never ends on it: not run).
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DATA = ROOT / "tests" / "data" / "urdf"
MODELS = {
    "urdf_tutorial 08": (DATA / "urdf_tutorial" / "urdf" / "08-macroed.urdf.xacro", {}, {}),
    "TurtleBot3 burger": (DATA / "turtlebot3_description" / "urdf" / "turtlebot3_burger.urdf.xacro",
                          {"turtlebot3_description": DATA / "turtlebot3_description"}, {}),
    "UR5e": (DATA / "ur_description" / "urdf" / "ur.urdf.xacro", {"ur_description": DATA / "ur_description"},
             {"ur_type": "ur5e", "name": "ur"}),
    "Franka FR3": (DATA / "franka_description" / "robots" / "fr3" / "fr3.urdf.xacro",
                   {"franka_description": DATA / "franka_description"}, {}),
}


def _reference(model: Path, packages: dict[str, Path], args: dict[str, str]) -> str:
    import xacro
    import xacro.substitution_args as subst

    subst._eval_find = lambda pkg: str(packages[pkg])
    return xacro.process_file(str(model), mappings=dict(args)).toprettyxml(indent="  ")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    a = ap.parse_args()
    print(f"load: {os.getloadavg()[0]:.2f} (1 min)")
    print(f"| model | zentf ms (p50) | xacro package ms (p50) | zentf / xacro |")
    print("|---|---|---|---|")
    from zentf.urdf.xacro.process import expand_file

    for name, (model, packages, args) in MODELS.items():
        ours, ref = [], []
        for _ in range(a.runs):  # interleaved: both see the same load
            t = time.perf_counter()
            expand_file(str(model), args=args)
            ours.append(time.perf_counter() - t)
            t = time.perf_counter()
            _reference(model, packages, args)
            ref.append(time.perf_counter() - t)
        o, r = statistics.median(ours), statistics.median(ref)
        print(f"| {name} | {o * 1000:.0f} | {r * 1000:.0f} | {o / r:.1f} |")
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"\nzentf's expanding child: peak RSS {peak:.0f} MB")
    with tempfile.TemporaryDirectory() as tmp:
        bomb = Path(tmp) / "bomb.urdf.xacro"
        body = '<xacro:macro name="m0"><link name="l"/></xacro:macro>\n' + "".join(
            f'<xacro:macro name="m{i}"><xacro:m{i - 1}/><xacro:m{i - 1}/></xacro:macro>\n' for i in range(1, 41))
        bomb.write_text(f'<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro">{body}<xacro:m40/></robot>')
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "zentf.cli", "urdf", "check", str(bomb)], capture_output=True,
                              text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
        print(f"\nmacro bomb ({bomb.stat().st_size} bytes, 40 doubling macros): refused in "
              f"{time.perf_counter() - t:.1f} s, exit {proc.returncode}: {proc.stderr.strip()[-160:]}")
    print(f"load: {os.getloadavg()[0]:.2f} (1 min)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
