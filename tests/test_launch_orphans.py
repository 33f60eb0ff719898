"""No orphan of `zentf launch`, whatever a node's descendant does: the launch's cgroup (cgroup.kill), the
subreapers where there is none; after Ctrl-C, SIGTERM and SIGKILL of the launcher."""
from __future__ import annotations

import os
import select
import signal
import sys
import textwrap
import time
from pathlib import Path

import pytest

from conftest import Proc
from zentf.launch import cgroup

PY = sys.executable
NODES = 7  # re-forking nodes per launch: 21 runs of that node for each containment
# A node whose child leaves the session, clears its environment (a fresh exec with an empty one), ignores
# SIGINT/TERM/HUP, puts its stdio on /dev/null and forks again every 20 ms, the parent exiting each time.
# Every generation holds the test's FIFO open for writing: the test sees EOF when the last one is gone. It
# writes its process group there first (forks keep it), so that a failed test can kill it as a whole.
REFORKER = textwrap.dedent('''
    import os, sys, time
    CODE = """
    import os, signal, sys, time
    for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(s, signal.SIG_IGN)
    os.setsid()
    null = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1, 2):
        os.dup2(null, fd)
    fifo = os.open(sys.argv[1], os.O_WRONLY)
    os.write(fifo, b"%d," % os.getpgrp())
    while True:
        time.sleep(0.02)
        if os.fork() != 0:
            os._exit(0)
    """
    if os.fork() == 0:
        os.execve(sys.executable, [sys.executable, "-S", "-c", CODE, sys.argv[1]], {})
    print("ready", flush=True)
    time.sleep(300)
''')


def _env(containment: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env["PYTHONUNBUFFERED"] = "1"
    if containment == "subreaper":
        env[cgroup.DISABLE_VAR] = "0"
    return env


def _cgroup_usable() -> str:
    path, why = cgroup.create(f"{os.getpid()}-probe{time.monotonic_ns()}")
    if path:
        cgroup.remove(path)
    return why


@pytest.fixture(params=["cgroup", "subreaper"])
def containment(request) -> str:
    if request.param == "cgroup":
        why = _cgroup_usable()
        if why:
            if os.environ.get("CI"):
                pytest.fail(f"no usable cgroup v2 here: {why}")
            pytest.skip(f"no usable cgroup v2 here: {why}")
    return request.param


def _wait_eof(fds: dict[int, str], timeout: float) -> list[str]:
    """Wait until every FIFO reads EOF (no writer left); the paths still held open at the deadline."""
    deadline = time.monotonic() + timeout
    left = dict(fds)
    while left:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            break
        ready, _, _ = select.select(list(left), [], [], remaining)
        for fd in ready:
            try:
                if os.read(fd, 64) == b"":
                    del left[fd]
            except BlockingIOError:
                pass
    return sorted(left.values())


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL], ids=["ctrl-c", "sigterm", "sigkill"])
def test_nothing_a_node_starts_outlives_the_launcher(tmp_path: Path, containment: str, sig: int) -> None:
    (tmp_path / "reforker.py").write_text(REFORKER)
    fifos = [str(tmp_path / f"fifo{i}") for i in range(NODES)]
    for path in fifos:
        os.mkfifo(path)
    fds = {os.open(path, os.O_RDONLY | os.O_NONBLOCK): path for path in fifos}
    nodes = "".join(f"  - {{name: refork{i}, cmd: [{PY}, reforker.py, {path}]}}\n" for i, path in enumerate(fifos))
    (tmp_path / "graph.yaml").write_text("nodes:\n" + nodes)
    p = Proc([PY, "-m", "zentf.launch", "graph.yaml", "--stop-timeout", "0.3"], env=_env(containment), cwd=tmp_path)
    groups: dict[int, int] = {}
    try:
        deadline = time.monotonic() + 30
        while len(groups) < NODES and time.monotonic() < deadline:  # every re-forker has said it is up
            ready, _, _ = select.select([fd for fd in fds if fd not in groups], [], [], 1.0)
            for fd in ready:
                data = os.read(fd, 64)
                if data:
                    groups[fd] = int(data.rstrip(b","))
        assert len(groups) == NODES, p.output()
        time.sleep(0.1)  # a few generations
        p.signal(sig)
        p.popen.wait(15)
        held = _wait_eof(fds, 8.0)
        assert held == [], f"{len(held)} of {NODES} re-forking descendants outlived the launcher:\n{p.output()}"
        if containment == "cgroup":
            own, _ = cgroup.own_dir()
            assert own is not None
            if sig != signal.SIGKILL:  # (after SIGKILL the watchdog removes it: it may still be at it)
                assert not [n for n in os.listdir(own) if n.startswith(cgroup.PREFIX + f"{p.pid}-")]
    finally:
        p.stop(timeout=5)
        for pgid in groups.values():  # a failed test leaves nothing behind: a group signal reaches every fork
            if pgid > 1 and pgid != os.getpgrp():
                try:
                    os.killpg(pgid, signal.SIGKILL)
                except OSError:
                    pass
        for fd in fds:
            os.close(fd)


def test_each_node_runs_in_its_own_cgroup_inside_the_launchs(tmp_path: Path) -> None:
    why = _cgroup_usable()
    if why:
        if os.environ.get("CI"):
            pytest.fail(f"no usable cgroup v2 here: {why}")
        pytest.skip(f"no usable cgroup v2 here: {why}")
    (tmp_path / "graph.yaml").write_text(
        f"nodes:\n  - {{name: a, cmd: [{PY}, -c, 'import os, time; print(\"ready\", os.getpid(), flush=True); time.sleep(60)']}}\n")
    p = Proc([PY, "-m", "zentf.launch", "graph.yaml"], env=_env("cgroup"), cwd=tmp_path)
    try:
        node = int(p.wait_for_line(r"\[a\] ready (\d+)", 20).group(1))
        reaper = int(p.wait_for_line(r"a started \(pid (\d+)\)", 20, from_start=True).group(1))
        rel_node = Path(f"/proc/{node}/cgroup").read_text().split("0::", 1)[1].strip()
        rel_reaper = Path(f"/proc/{reaper}/cgroup").read_text().split("0::", 1)[1].strip()
        launch = f"{cgroup.PREFIX}{p.pid}-"
        assert Path(rel_reaper).name.startswith(launch), rel_reaper
        assert Path(rel_node).parent == Path(rel_reaper) and Path(rel_node).name == "0.1", rel_node
        own, _ = cgroup.own_dir()
        p.signal(signal.SIGINT)
        assert p.wait(10) == 0
        assert not os.path.exists(own + "/" + Path(rel_reaper).name)  # removed on the way out
    finally:
        p.stop()


RACE = textwrap.dedent('''
    import ctypes, os, signal, sys, time
    from zentf.launch import proctree
    ctypes.CDLL(None).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER, as a node's reaper
    r, w = os.pipe()
    x = os.fork()
    if x == 0:
        null = os.open(os.devnull, os.O_RDWR)
        for fd in (0, 1, 2):
            os.dup2(null, fd)  # the test reads our output to its end: not held open by these two
        y = os.fork()
        if y == 0:
            time.sleep(30)
            os._exit(0)
        os.write(w, str(y).encode())
        time.sleep(30)
        os._exit(0)
    y = int(os.read(r, 32))
    real = proctree._stat

    def racing(pid):  # the parent exits (and is reaped) right after its child is read, before it is
        entry = real(pid)
        if pid == y and not raced:
            raced.append(x)
            os.kill(x, signal.SIGKILL)
            os.waitpid(x, 0)
        return entry

    raced = []

    proctree._stat = racing
    table = proctree.snapshot()
    print(y > x, y in proctree.descendants(os.getpid(), table), flush=True)
    os.kill(y, signal.SIGKILL)
''')


def test_a_process_whose_parent_vanished_while_proc_was_read_is_still_in_the_tree() -> None:
    """The race a re-forking descendant wins under load: /proc is read newest first, the child before its
    parent; the parent exits between the two reads. The child, re-parented to the subreaper meanwhile,
    must still be found below it (else it is neither stopped nor killed that round, and forks on)."""
    import subprocess

    out = subprocess.run([PY, "-c", RACE], capture_output=True, text=True, timeout=30,
                         cwd=Path(__file__).resolve().parent.parent)
    newer, found = out.stdout.split()
    if newer != "True":
        pytest.skip("the pids wrapped between the two forks: the child was not read first")
    assert found == "True", out.stderr
