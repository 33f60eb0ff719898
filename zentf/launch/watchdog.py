"""Orphan guard, run as a tiny separate process by the launcher (stdlib only, started with -S -I).

The launcher writes `+PGID` / `-PGID` lines on our stdin as it starts and reaps node process groups,
and `.` when it has stopped and swept everything itself. When stdin reaches EOF without that, the
launcher is gone (even by SIGKILL). Each node's reaper (reaper.py) then stops
its own tree; this process sends SIGTERM to whatever no live reaper covers: groups whose reaper is gone,
and every process whose environment carries this launch's id (`ZENTF_LAUNCH_ID`, inherited by all a
node starts, whatever its session, group or parent: e.g. re-parented to init after its reaper was
killed). After the grace period, the launch's cgroup (when it has one: argument 3) is killed as a whole
(cgroup.kill) and removed, and everything left of the groups and of the id's carriers is frozen
(SIGSTOP) and killed.
"""
from __future__ import annotations

import os
import signal
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # -I leaves our own directory out
import cgroup  # noqa: E402
import proctree  # noqa: E402


def _alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except (ProcessLookupError, PermissionError):
        return False


def _signal(groups: list[int], launch_id: str, sig: int, spare_reapers: bool = False) -> list[int]:
    """Send `sig` to the live groups and to every process carrying the launch id; the pids so found.

    With spare_reapers, a group whose leader (the node's reaper) is alive is left to it, with its
    whole tree: it stops that tree itself when the launcher dies, and one SIGTERM is enough."""
    covered: set[int] = set()
    if spare_reapers:
        table = proctree.snapshot()
        for g in groups:
            if g in table and table[g][2] != "Z":
                covered.add(g)
                covered.update(proctree.descendants(g, table))
                covered.update(p for p, (_, pg, _) in table.items() if pg == g)
    for g in groups:
        if g not in covered:
            try:
                os.killpg(g, sig)
            except OSError:
                pass
    pids = [p for p in proctree.carrying_launch_id(launch_id) if p not in covered] if launch_id else []
    for pid in pids:
        try:
            os.kill(pid, sig)
        except OSError:
            pass
    return pids


def main() -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a terminal Ctrl-C is the launcher's to handle
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    grace = float(sys.argv[1]) if len(sys.argv) > 1 else 1.0
    launch_id = sys.argv[2] if len(sys.argv) > 2 else ""
    launch_cgroup = sys.argv[3] if len(sys.argv) > 3 else ""
    groups: set[int] = set()
    clean = False
    buf = b""
    while True:
        try:
            data = os.read(0, 4096)
        except InterruptedError:
            continue
        except OSError:
            break
        if not data:
            break
        buf += data
        *lines, buf = buf.split(b"\n")
        for line in lines:
            try:
                if line[:1] == b"+":
                    groups.add(int(line[1:]))
                elif line[:1] == b"-":
                    groups.discard(int(line[1:]))
                elif line == b".":
                    clean = True
            except ValueError:
                pass
    if clean:
        return 0
    alive = [g for g in groups if _alive(g)]
    pids = _signal(alive, launch_id, signal.SIGTERM, spare_reapers=True)
    deadline = time.monotonic() + grace
    while time.monotonic() < deadline:
        alive = [g for g in alive if _alive(g)]
        pids = [p for p in pids if proctree.alive(p)]
        if not alive and not pids:
            break
        time.sleep(0.02)
    if launch_cgroup:
        cgroup.kill(launch_cgroup)
        cgroup.wait_empty(launch_cgroup, 5.0)
    proctree.kill_frozen(lambda table: _trees(alive, launch_id, table))
    for g in alive:  # whatever is left in the groups, should a tree walk have missed it
        try:
            os.killpg(g, signal.SIGKILL)
        except OSError:
            pass
    if launch_cgroup:
        cgroup.remove(launch_cgroup)
    return 0


def _trees(groups: list[int], launch_id: str, table: "dict[int, tuple[int, int, str]]") -> set[int]:
    """The groups' members and their leaders' descendants, and the launch id's carriers."""
    pids: set[int] = set()
    for g in groups:
        if g in table:
            pids.add(g)
            pids.update(proctree.descendants(g, table))
    pids.update(p for p, (_, pg, _) in table.items() if pg in groups)
    if launch_id:
        pids.update(proctree.carrying_launch_id(launch_id))
    return pids


if __name__ == "__main__":
    sys.exit(main())
