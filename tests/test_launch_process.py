"""The launcher as a process: output prefixes, log files, env contract, respawn, required, clean stops."""
from __future__ import annotations

import io
import json
import logging
import os
import re
import signal
import sys
import textwrap
import time
import uuid
from pathlib import Path
from typing import Iterator

import pytest

from conftest import Proc
from zentf.launch.proctree import wait_gone
from zentf.launch import supervisor
from zentf.launch.description import NodeSpec
from zentf.launch.supervisor import RESPAWN_CAP, Supervisor, respawn_wait

PY = sys.executable
# a node that ignores SIGINT and SIGTERM: only SIGKILL stops it
STUBBORN = ("import signal, os, time; signal.signal(signal.SIGINT, signal.SIG_IGN); "
            "signal.signal(signal.SIGTERM, signal.SIG_IGN); print('ready', os.getpid(), flush=True); "
            "time.sleep(120)")
# a shell node with a grandchild in its process group
SHELL_TREE = "sleep 120 & echo ready $$ $!; wait"
# a shell ignoring SIGINT and SIGTERM, with two children that inherit that
STUBBORN_SHELL = 'trap "" INT TERM; sleep 120 & a=$!; sleep 120 & echo ready $$ $a $!; wait'
# a node that double-forks a setsid() daemon (stdio on /dev/null, as daemons do) and stays up
DAEMON = """
import os, time
r, w = os.pipe()
if os.fork() == 0:
    os.setsid()
    if os.fork() == 0:
        null = os.open(os.devnull, os.O_RDWR)
        for fd in (0, 1, 2):
            os.dup2(null, fd)
        os.write(w, b"%d\\n" % os.getpid())
        time.sleep(120)
    os._exit(0)
os.wait()
print("ready", os.getpid(), int(os.read(r, 64)), flush=True)
time.sleep(120)
"""
# a node that moves its child into a process group of its own
SETPGID = """
import os, subprocess, time
child = subprocess.Popen(["sleep", "120"], preexec_fn=lambda: os.setpgid(0, 0))
print("ready", os.getpid(), child.pid, flush=True)
time.sleep(120)
"""


def write(tmp_path: Path, text: str, name: str = "graph.yaml") -> str:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return str(path)


def base_env() -> dict[str, str]:
    env = dict(os.environ)
    for var in ("ZENTF_NAMESPACE", "ZENTF_PARAMS", "ZENTF_REMAP", "ZENTF_NODE_NAME", "ZENTF_PARAMS_FILE",
                "ZENTF_CONNECT", "ZENTF_LISTEN", "ZENTF_MODE", "NO_COLOR", "FORCE_COLOR"):
        env.pop(var, None)
    env["PYTHONUNBUFFERED"] = "1"
    return env


@pytest.fixture
def launch(tmp_path: Path) -> Iterator:
    """launch(file, *args) -> Proc of `python -m zentf.launch`; every launcher is stopped at teardown."""
    procs: list[Proc] = []

    def _launch(file: str, *args: str, env: dict[str, str] | None = None) -> Proc:
        p = Proc([PY, "-m", "zentf.launch", file, *args], env=env or base_env(), cwd=tmp_path)
        procs.append(p)
        return p

    try:
        yield _launch
    finally:
        for p in procs:
            p.stop(timeout=5)


def dead_within(pids: list[int], timeout: float) -> list[int]:
    """Wait (on pidfds, no polling) until every pid has exited; return those still alive at the deadline."""
    wait_gone(pids, timeout)
    return [pid for pid in pids if not _zombie(pid)]  # judged here, from /proc


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except (FileNotFoundError, IndexError):
        return True


def alive(pid: int) -> bool:
    return not _zombie(pid)


def test_screen_output_is_prefixed_and_log_output_goes_to_a_file(tmp_path, launch):
    f = write(tmp_path, """
        nodes:
          - name: talker
            cmd: [sh, -c, 'echo first line; echo second line >&2; printf "no newline"']
          - name: quiet
            namespace: ns
            output: log
            cmd: [sh, -c, 'echo into the log']
        """)
    p = launch(f, "--log-dir", str(tmp_path / "logs"), "--no-color")
    assert p.wait(20) == 0, p.output()
    lines = p.lines
    assert "[talker] first line" in lines and "[talker] second line" in lines
    assert "[talker] no newline" in lines
    assert not any("into the log" in line for line in lines)
    assert (tmp_path / "logs" / "ns.quiet.log").read_text() == "into the log\n"
    p = launch(f, "--log-dir", str(tmp_path / "logs"), "--color")
    assert p.wait(20) == 0
    assert any(line.startswith("\033[") and "[talker]\033[0m first line" in line for line in p.lines)


def test_children_get_identity_and_zenoh_options_through_the_env(tmp_path, launch):
    dump = ("import json, os; print('ENV', json.dumps({k: v for k, v in os.environ.items() "
            "if k.startswith('ZENTF_')}), flush=True)")
    f = write(tmp_path, f"""
        nodes:
          - name: probe
            namespace: inner
            cmd: [{PY}, -c, "{dump}"]
            parameters: {{gain: 2.5, on: true, list: [1, 2]}}
            remappings: {{tf: /shared/tf}}
            env: {{ZENTF_EXTRA: x}}
        """)
    p = launch(f, "-n", "outer", "--connect", "tcp/127.0.0.1:9", "--mode", "client", "--no-multicast")
    env = json.loads(p.wait_for_line(r"ENV (.*)", 20).group(1))
    assert p.wait(20) == 0
    assert env["ZENTF_NODE_NAME"] == "probe" and env["ZENTF_NAMESPACE"] == "outer/inner"
    assert json.loads(env["ZENTF_PARAMS"]) == {"gain": 2.5, "on": True, "list": [1, 2]}
    assert json.loads(env["ZENTF_REMAP"]) == {"tf": "/shared/tf"}
    assert (env["ZENTF_CONNECT"], env["ZENTF_MODE"], env["ZENTF_NO_MULTICAST"]) == ("tcp/127.0.0.1:9", "client", "1")
    assert env["ZENTF_EXTRA"] == "x"


def test_a_crashed_node_with_respawn_comes_back_up_to_its_cap(tmp_path, launch):
    f = write(tmp_path, """
        nodes:
          - name: phoenix
            cmd: [sh, -c, 'echo alive $$; exec sleep 120']
            respawn: true
            respawn_delay: 0.1
            respawn_max: 2
        """)
    p = launch(f)
    first = int(p.wait_for_line(r"\[phoenix\] alive (\d+)", 20).group(1))
    os.kill(first, signal.SIGKILL)
    p.wait_for_line(r"phoenix was killed by SIGKILL; respawning in 0.1 s \(1/2\)", 10)
    second = int(p.wait_for_line(r"\[phoenix\] alive (\d+)", 10).group(1))
    assert second != first
    os.kill(second, signal.SIGKILL)
    third = int(p.wait_for_line(r"\[phoenix\] alive (\d+)", 10).group(1))
    os.kill(third, signal.SIGKILL)
    p.wait_for_line(r"not respawning: respawn_max 2 reached", 10)
    assert p.wait(10) == 128 + signal.SIGKILL  # nothing left to run: the launcher ends


def test_a_node_crashing_at_once_respawns_with_backoff_and_caps_still_hold(tmp_path, launch):
    """respawn_delay: 0 once meant ~570 restarts a second; now the waits run 0.1, 0.2, 0.4, ... s."""
    f = write(tmp_path, """
        nodes:
          - {name: crasher, cmd: [sh, -c, 'exit 3'], respawn: true, respawn_delay: 0}
          - {name: capped, cmd: [sh, -c, 'exit 4'], respawn: true, respawn_delay: 0, respawn_max: 2}
        """)
    t0 = time.monotonic()
    p = launch(f)
    p.wait_for_line(r"crasher exited with code 3; respawning in 1.6 s$", 30)
    took = time.monotonic() - t0
    p.wait_for_line(r"capped exited with code 4; not respawning: respawn_max 2 reached", 10, from_start=True)
    p.signal(signal.SIGINT)
    assert p.wait(10) == 0
    out = p.output()
    waits = [float(w) for w in re.findall(r"crasher exited with code 3; respawning in ([\d.]+) s", out)]
    assert len(waits) >= 5 and waits == [0.1, 0.2, 0.4, 0.8, 1.6, 3.2, 6.4, 10.0][:len(waits)], waits
    assert took >= 0.1 + 0.2 + 0.4 + 0.8, took  # the waits were kept, not only printed
    assert len(waits) - 1 <= out.count("crasher respawned") <= len(waits)  # SIGINT cancels a pending wait
    assert re.findall(r"capped exited with code 4; respawning in ([\d.]+) s \((\d)/2\)", out) == \
        [("0.1", "1"), ("0.2", "2")]
    assert out.count("capped respawned") == 2


def test_respawn_wait_doubles_from_the_floor_up_to_the_cap():
    assert [respawn_wait(0, n) for n in range(9)] == [0.1, 0.2, 0.4, 0.8, 1.6, 3.2, 6.4, 10.0, 10.0]
    assert [respawn_wait(3, n) for n in range(4)] == [3.0, 6.0, 10.0, 10.0]
    assert respawn_wait(30, 0) == respawn_wait(30, 5) == 30.0  # a long respawn_delay is its own cap
    assert respawn_wait(0, 10**6) == RESPAWN_CAP


def test_a_run_longer_than_the_reset_time_resets_the_backoff(monkeypatch, caplog):
    """In-process supervisor (real node processes) with the reset time cut from 10 s to 0.5 s."""
    monkeypatch.setattr(supervisor, "RESPAWN_RESET", 0.5)
    nodes = [NodeSpec("steady", "", ["sh", "-c", "sleep 0.7; exit 1"], respawn=True, respawn_delay=0, respawn_max=3),
             NodeSpec("flaky", "", ["sh", "-c", "exit 1"], respawn=True, respawn_delay=0, respawn_max=3)]
    caplog.set_level(logging.INFO, logger="zentf.launch")
    assert Supervisor(nodes, base_env=base_env(), out=io.BytesIO()).run() == 1
    lines = "\n".join(r.getMessage() for r in caplog.records)
    waits = {name: re.findall(rf"^{name} exited with code 1; respawning in ([\d.]+) s", lines, re.M)
             for name in ("steady", "flaky")}
    assert waits == {"steady": ["0.1", "0.1", "0.1"], "flaky": ["0.1", "0.2", "0.4"]}


def test_a_required_node_exiting_takes_the_graph_down_with_its_code(tmp_path, launch):
    fifo = tmp_path / "go"
    os.mkfifo(fifo)
    f = write(tmp_path, f"""
        nodes:
          - name: bystander
            cmd: [sh, -c, '{SHELL_TREE}']
          - name: boss
            required: true
            cmd: [sh, -c, 'echo boss up; read line < {fifo}; exit 7']
        """)
    p = launch(f)
    m = p.wait_for_line(r"\[bystander\] ready (\d+) (\d+)", 20)
    pids = [int(m.group(1)), int(m.group(2))]
    p.wait_for_line(r"\[boss\] boss up", 20, from_start=True)
    assert all(alive(pid) for pid in pids)
    with open(fifo, "w") as w:  # boss reads a line and exits 7
        w.write("go\n")
    assert p.wait(10) == 7, p.output()
    assert "boss exited with code 7; it is required, so stopping everything" in p.output()
    assert dead_within(pids, 5) == []


def test_a_required_node_ending_cleanly_ends_the_launch_without_an_error(caplog):
    """teleop's 'q' exits 0: the launch stops, exit 0, and the line saying so is info, not ERROR."""
    nodes = [NodeSpec("teleop", "", ["sh", "-c", "exit 0"], required=True)]
    caplog.set_level(logging.INFO, logger="zentf.launch")
    assert Supervisor(nodes, base_env=base_env(), out=io.BytesIO()).run() == 0
    said = [(r.levelno, r.getMessage()) for r in caplog.records if "teleop exited" in r.getMessage()]
    assert said == [(logging.INFO, "teleop exited with code 0; it is required, so stopping everything")], said
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]


def launch_tree(tmp_path, launch) -> tuple[Proc, list[int], str]:
    """A graph of a shell with a grandchild, a node ignoring SIGINT/SIGTERM, a plain sleeper, a node with
    a setsid() daemon, one with a child in another process group and a shell ignoring SIGINT/SIGTERM
    with two children; returns the launcher, the pids below it once all are up, and a marker every one
    of them carries in its environment (to find survivors whatever their parent, group or session)."""
    marker = uuid.uuid4().hex
    (tmp_path / "daemon.py").write_text(DAEMON)
    (tmp_path / "setpgid.py").write_text(SETPGID)
    f = write(tmp_path, f"""
        env: {{ORPHAN_MARK: {marker}}}
        nodes:
          - {{name: shell, cmd: [sh, -c, '{SHELL_TREE}']}}
          - {{name: stubborn, cmd: [{PY}, -c, "{STUBBORN}"]}}
          - {{name: polite, cmd: [sleep, '120']}}
          - {{name: daemon, cmd: [{PY}, daemon.py]}}
          - {{name: grouper, cmd: [{PY}, setpgid.py]}}
          - {{name: trapper, cmd: [sh, -c, '{STUBBORN_SHELL}']}}
        """)
    p = launch(f)
    pids = []
    for name in ("shell", "stubborn", "daemon", "grouper", "trapper"):
        m = p.wait_for_line(rf"\[{name}\] ready ([\d ]+)$", 20, from_start=True)
        pids += [int(pid) for pid in m.group(1).split()]
    pids.append(int(p.wait_for_line(r"polite started \(pid (\d+)\)", 20, from_start=True).group(1)))
    assert len(pids) == 11 and all(alive(pid) for pid in pids)
    assert len(carrying(marker)) >= 11  # (and the reapers)
    return p, pids, marker


def carrying(marker: str) -> list[int]:
    """Live processes whose environment has ORPHAN_MARK=marker."""
    want = f"ORPHAN_MARK={marker}".encode()
    found = []
    for name in os.listdir("/proc"):
        if name.isdigit() and int(name) != os.getpid():
            try:
                if want in Path(f"/proc/{name}/environ").read_bytes().split(b"\0") and alive(int(name)):
                    found.append(int(name))
            except OSError:
                pass
    return found


def survivors(pids: list[int], marker: str, timeout: float) -> list[int]:
    """Wait until none of `pids` and no process carrying `marker` is left; those left at the deadline."""
    deadline = time.monotonic() + timeout
    while True:
        left = dead_within(sorted(set(pids) | set(carrying(marker))), max(0.0, deadline - time.monotonic()))
        if not left and not carrying(marker):
            return []
        if time.monotonic() >= deadline:
            found = sorted(set(left) | set(carrying(marker)))
            for pid in found:  # the test fails, but leaves nothing behind
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            return found


def test_sigint_stops_every_descendant_within_3_s_whatever_its_session_or_group(tmp_path, launch):
    p, pids, marker = launch_tree(tmp_path, launch)
    t0 = time.monotonic()
    p.signal(signal.SIGINT)
    assert p.wait(10) == 0
    took = time.monotonic() - t0
    assert survivors(pids, marker, 0.5) == []
    assert took < 3.0, took
    out = p.output()
    assert "still running after SIGINT: stubborn, trapper; sending SIGTERM" in out
    assert "still running after SIGTERM: stubborn, trapper; sending SIGKILL" in out
    assert "daemon was killed by SIGINT" in out and "grouper was killed by SIGINT" in out


def test_sigkill_of_the_launcher_leaves_no_orphans(tmp_path, launch):
    p, pids, marker = launch_tree(tmp_path, launch)
    p.kill()
    assert survivors(pids, marker, 10) == []


def test_sigkill_of_the_launcher_and_its_watchdog_leaves_no_orphans(tmp_path, launch):
    """Each node's reaper stops its tree on its own: SIGTERM, then SIGKILL after the grace period."""
    p, pids, marker = launch_tree(tmp_path, launch)
    watchdogs = [pid for pid in map(int, filter(str.isdigit, os.listdir("/proc")))
                 if _ppid(pid) == p.pid and b"watchdog.py" in _cmdline(pid)]
    assert len(watchdogs) == 1
    os.kill(watchdogs[0], signal.SIGKILL)  # first, so that it can do nothing
    p.kill()
    assert survivors(pids, marker, 10) == []


def test_what_a_killed_reaper_leaves_is_killed_by_the_launcher_or_else_by_the_watchdog(tmp_path, launch):
    marker = uuid.uuid4().hex
    (tmp_path / "daemon.py").write_text(DAEMON)
    f = write(tmp_path, f"""
        env: {{ORPHAN_MARK: {marker}}}
        nodes:
          - {{name: one, cmd: [{PY}, daemon.py]}}
          - {{name: two, cmd: [{PY}, daemon.py]}}
        """)
    p = launch(f)
    (node1, daemon1), (node2, daemon2) = [
        map(int, p.wait_for_line(rf"\[{name}\] ready (\d+) (\d+)", 20, from_start=True).groups())
        for name in ("one", "two")]
    reaper1, reaper2 = [int(p.wait_for_line(rf"{name} started \(pid (\d+)\)", 20, from_start=True).group(1))
                        for name in ("one", "two")]
    os.kill(reaper1, signal.SIGKILL)  # the node dies of its parent-death signal, its daemon goes to the launcher
    p.wait_for_line(r"one was killed by SIGKILL", 10)
    assert dead_within([node1, daemon1], 5) == [] and alive(daemon2)
    p.signal(signal.SIGSTOP)  # a launcher that can do nothing: the daemon it adopts must wait for the watchdog
    os.kill(reaper2, signal.SIGKILL)
    assert dead_within([node2], 5) == [] and alive(daemon2)
    p.kill()
    assert survivors([daemon2], marker, 10) == []


def _ppid(pid: int) -> int:
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError):
        return 0


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def test_all_nodes_ending_ends_the_launcher_with_the_first_failure(tmp_path, launch):
    f = write(tmp_path, """
        nodes:
          - {name: ok, cmd: [sh, -c, 'exit 0']}
          - {name: bad, cmd: [sh, -c, 'exit 5']}
        """)
    p = launch(f)
    assert p.wait(20) == 5
    assert "bad exited with code 5" in p.output()


def test_repeated_ctrl_c_escalates_at_once(tmp_path, launch):
    f = write(tmp_path, f"""
        nodes:
          - {{name: stubborn, cmd: [{PY}, -c, "{STUBBORN}"]}}
        """)
    p = launch(f, "--stop-timeout", "8")
    pid = int(p.wait_for_line(r"\[stubborn\] ready (\d+)", 20).group(1))
    t0 = time.monotonic()
    p.signal(signal.SIGINT)
    p.wait_for_line(r"SIGINT: stopping 1 node", 10)
    p.signal(signal.SIGINT)
    p.wait_for_line(r"sending SIGTERM", 10)
    p.signal(signal.SIGINT)
    assert p.wait(10) == 0
    assert time.monotonic() - t0 < 4.0  # not 16 s of --stop-timeout
    assert "sending SIGKILL" in p.output()
    assert dead_within([pid], 1) == []
