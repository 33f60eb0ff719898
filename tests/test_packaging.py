"""What `pip install zentf` puts on a machine: one top-level package, the launch files inside it, and
programs that start by name outside the checkout (no `nodes` package)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel's tree without the compile step: setup.py's build_py copies exactly the packages and package
    data the wheel ships; the extensions the checkout already compiled are put beside their sources."""
    lib = tmp_path_factory.mktemp("site") / "lib"
    out = subprocess.run([sys.executable, "setup.py", "-q", "build_py", "--build-lib", str(lib)], cwd=REPO,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    for so in (REPO / "zentf").rglob("*.so"):
        shutil.copy2(so, lib / so.relative_to(REPO))
    return lib


def test_the_distribution_ships_zentf_and_its_configs_only(installed: Path) -> None:
    assert sorted(p.name for p in installed.iterdir()) == ["zentf"]
    shipped = {p.relative_to(installed / "zentf" / "configs").as_posix()
               for p in (installed / "zentf" / "configs").rglob("*") if p.is_file()}
    in_checkout = {p.relative_to(REPO / "configs").as_posix() for p in (REPO / "configs").rglob("*") if p.is_file()}
    assert shipped == in_checkout
    programs = {p.stem for p in (installed / "zentf" / "demos").glob("*.py")} | {
        p.stem for p in (installed / "zentf" / "tools").glob("*.py")}
    assert {"turtlesim", "frames_publisher", "static_transform_publisher", "buffer_server"} <= programs


def _env(installed: Path, base: dict[str, str]) -> dict[str, str]:
    env = dict(base)
    env["PYTHONPATH"] = str(installed)  # the installed tree first, never the checkout
    return env


def test_installed_programs_run_by_name_outside_the_checkout(installed: Path, tmp_path: Path, zenoh_env,
                                                             node_options, spawn) -> None:
    env = _env(installed, zenoh_env)
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()

    def zentf(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "zentf.cli", *args], cwd=cwd, env=env, capture_output=True,
                              text=True, timeout=60)

    where = subprocess.run([sys.executable, "-c", "import zentf; print(zentf.__file__)"], cwd=cwd, env=env,
                           capture_output=True, text=True, timeout=60)
    assert where.stdout.strip() == str(installed / "zentf" / "__init__.py")
    assert subprocess.run([sys.executable, "-c", "import nodes"], cwd=cwd, env=env, capture_output=True,
                          timeout=60).returncode == 1

    listed = zentf("run", "--list")
    assert listed.returncode == 0, listed.stderr
    names = [line.split()[0] for line in listed.stdout.splitlines()]
    assert {"turtlesim", "static_transform_publisher", "robot_state_publisher", "frames_publisher"} <= set(names)
    assert all(len(line.split(None, 1)) == 2 for line in listed.stdout.splitlines())  # a line of help each

    bad = zentf("run", "no_such_program")
    assert bad.returncode == 2 and "no program named 'no_such_program'" in bad.stderr

    model = installed / "zentf" / "configs" / "robots" / "my_robot.urdf"
    launch_args = {"robot": ["robot:=r1"], "urdf": [f"model:={model}"]}
    shipped = sorted(p.stem for p in (installed / "zentf" / "configs").glob("*.yaml"))
    assert shipped == ["drones", "laser", "multi_robot", "robot", "turtles", "urdf"]
    for name in shipped:
        shown = zentf("launch", name, *launch_args.get(name, []), "--print")
        assert shown.returncode == 0, (name, shown.stderr)
        assert "zentf.demos." in shown.stdout or "zentf.tools." in shown.stdout, (name, shown.stdout)

    pub = spawn([sys.executable, "-m", "zentf.cli", "run", "static_transform_publisher", "--x", "0.25",
                 "--frame-id", "base_link", "--child-frame-id", "laser"], env=env, cwd=cwd)
    drones = spawn([sys.executable, "-m", "zentf.cli", "launch", "drones", "plots:=false"], env=env, cwd=cwd)
    from zentf import Buffer, Node, Time, TransformListener

    with Node("packaging_probe", options=node_options) as node:
        buffer = Buffer()
        TransformListener(buffer, node)
        t = buffer.lookup_transform("base_link", "laser", Time(), timeout=20.0)
        assert buffer.can_transform("world", "av1", Time(), timeout=30.0), drones.output()[-2000:]
    assert t.transform.translation.x == 0.25
    assert pub.returncode is None and drones.returncode is None

