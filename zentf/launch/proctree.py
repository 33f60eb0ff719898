"""Process-tree facts read from /proc (stdlib only: the watchdog and the node reaper load it by path).

Linux keeps no children list we can rely on (/proc/PID/task/TID/children needs CONFIG_PROC_CHILDREN),
so a snapshot of every process's parent, process group and state is taken from /proc/PID/stat.
"""
from __future__ import annotations

import os
import select
import signal
import time
from typing import Callable, Iterable

__all__ = ["LAUNCH_ID_VAR", "snapshot", "alive", "descendants", "has_launch_id", "carrying_launch_id",
           "launch_id_value", "wait_gone", "freeze", "kill_frozen"]

#: Environment variable every launched process inherits: `:`-joined ids of the launches above it.
LAUNCH_ID_VAR = "ZENTF_LAUNCH_ID"


def _stat(pid: int) -> "tuple[int, int, str] | None":
    """(parent pid, process group, state) of one process; None if it is gone."""
    try:  # os.open/os.read: this runs on every stop, in several processes at once
        fd = os.open(f"/proc/{pid}/stat", os.O_RDONLY)
        try:
            data = os.read(fd, 4096)
        finally:
            os.close(fd)
        fields = data[data.rindex(b")") + 2:].split(None, 3)
        return int(fields[1]), int(fields[2]), fields[0].decode()
    except (OSError, ValueError, IndexError):
        return None  # gone meanwhile


def snapshot() -> "dict[int, tuple[int, int, str]]":
    """pid -> (parent pid, process group, state) for every process visible now."""
    table: dict[int, tuple[int, int, str]] = {}
    # newest first: what was just forked is read before it can fork again (pids grow until they wrap)
    for name in sorted((n for n in os.listdir("/proc") if n.isdigit()), key=int, reverse=True):
        entry = _stat(int(name))
        if entry is not None:
            table[int(name)] = entry
    # A process read before its parent, whose parent then exited and was gone when read, names a parent
    # not in the table: it was re-parented (to a subreaper, or init) before that parent vanished, so a
    # second read gives its parent now. Without it a re-forking process read between its parent's fork and
    # exit belongs to nobody's tree in this snapshot.
    for pid, (ppid, _, _) in list(table.items()):
        if ppid > 0 and ppid not in table:
            entry = _stat(pid)
            if entry is None:
                del table[pid]
            else:
                table[pid] = entry
    return table


def alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            data = f.read()
        return data[data.rindex(b")") + 2:data.rindex(b")") + 3] != b"Z"
    except (OSError, ValueError):
        return False


def descendants(root: int, table: "dict[int, tuple[int, int, str]]") -> "list[int]":
    """Every process below `root` in `table` (children first), zombies included."""
    children: dict[int, list[int]] = {}
    for pid, (ppid, _, _) in table.items():
        children.setdefault(ppid, []).append(pid)
    out: list[int] = []
    stack = [root]
    while stack:
        for child in children.get(stack.pop(), ()):
            if child != root:
                out.append(child)
                stack.append(child)
    return out


def launch_id_value(inherited: "str | None", own: str) -> str:
    """The value of LAUNCH_ID_VAR for the children of a launch nested (or not) in others."""
    return f"{inherited}:{own}" if inherited else own


def has_launch_id(pid: int, launch_id: str) -> bool:
    """The process's environment names `launch_id` in LAUNCH_ID_VAR (False for zombies and the unreadable)."""
    try:
        with open(f"/proc/{pid}/environ", "rb") as f:
            env = f.read()
    except OSError:
        return False
    needle = LAUNCH_ID_VAR.encode() + b"="
    for entry in env.split(b"\0"):
        if entry.startswith(needle):
            return launch_id.encode() in entry[len(needle):].split(b":")
    return False


def carrying_launch_id(launch_id: str) -> "list[int]":
    """Live processes whose environment names `launch_id`, whatever their parent, group or session."""
    me = os.getpid()
    return [pid for pid in (int(n) for n in os.listdir("/proc") if n.isdigit())
            if pid != me and has_launch_id(pid, launch_id)]


def wait_gone(pids: "list[int]", timeout: float) -> None:
    """Wait (on pidfds) until every pid has exited or `timeout` s have passed."""
    fds = []
    for pid in pids:
        try:
            fds.append(os.pidfd_open(pid))
        except OSError:
            pass
    deadline = time.monotonic() + timeout
    try:
        while fds:
            left = deadline - time.monotonic()
            if left <= 0:
                return
            ready, _, _ = select.select(fds, [], [], left)
            for fd in ready:
                os.close(fd)
                fds.remove(fd)
    finally:
        for fd in fds:
            os.close(fd)


def freeze(targets: "Callable[[dict[int, tuple[int, int, str]]], Iterable[int]]", rounds: int = 200) -> "list[int]":
    """SIGSTOP the live processes `targets(snapshot)` names until two snapshots in a row find the same set,
    all stopped; that set. A stopped process cannot fork, so a SIGKILL to the set leaves nothing behind.

    A process that forks again faster than /proc can be read is out of reach one pid at a time; its process
    group is not (forks inherit it), and a group signal reaches every member at once, forks in flight
    included: a group all of whose members are targets is stopped as a whole."""
    prev: "set[int] | None" = None
    found: set[int] = set()
    for _ in range(rounds):
        table = snapshot()
        found = {p for p in targets(table) if p in table and table[p][2] != "Z"}
        running = [p for p in found if table[p][2] not in ("T", "t")]
        for pid in running:
            try:
                os.kill(pid, signal.SIGSTOP)
            except OSError:
                pass
        groups = {table[p][1] for p in found}
        for pid, (_, pgid, state) in table.items():  # a group with a member that is not a target is not ours
            if pgid in groups and pid not in found and state != "Z":
                groups.discard(pgid)
        for pgid in groups:
            try:
                os.killpg(pgid, signal.SIGSTOP)
            except OSError:
                pass
        if not running and found == prev:
            break
        prev = found
        if running:
            time.sleep(0.001)  # let the stops land before the next look
    return sorted(found)


def kill_frozen(targets: "Callable[[dict[int, tuple[int, int, str]]], Iterable[int]]", rounds: int = 20,
                wait: float = 0.2) -> None:
    """Freeze the processes `targets` names, SIGKILL them, until none is left."""
    for _ in range(rounds):
        pids = freeze(targets)
        if not pids:
            return
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        wait_gone(pids, wait)
