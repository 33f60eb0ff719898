"""A cgroup v2 per launch: the kernel's own containment, killed as a whole (stdlib only, loaded by path).

A launch's cgroup is `<the launcher's own cgroup>/zentf-launch-<launch id>`; each node's reaper joins it
before it forks the node, and the node joins a child cgroup of its own (`<index>.<spawn>`) between fork
and exec. Nothing a node starts can leave its cgroup without write access to the cgroup tree (re-forking,
setsid(), a cleared environment change nothing), so writing `1` to `cgroup.kill` (Linux 5.14) ends all of
it at once: no /proc walk to race with, no signal to ignore.

It needs a cgroup2 mount in which the launcher may create a child of its own cgroup and move processes
there: root outside a container, a delegated systemd subtree (a user's `user@UID.service`), a container
with a writable cgroup namespace. Elsewhere `usable()` says why not, and the launcher falls back to its
subreapers (reaper.py, watchdog.py). `ZENTF_LAUNCH_CGROUP=0` forces that fallback.
"""
from __future__ import annotations

import os
import select
import time

__all__ = ["DISABLE_VAR", "PREFIX", "own_dir", "create", "make_child", "join", "kill", "wait_empty", "remove",
           "remove_stale"]

#: Environment variable: "0" makes the launcher use its subreapers only.
DISABLE_VAR = "ZENTF_LAUNCH_CGROUP"
#: Name prefix of a launch's cgroup (then the launch id: `<launcher pid>-<hex>`).
PREFIX = "zentf-launch-"


def _mount_point() -> "str | None":
    """Where the cgroup2 hierarchy is mounted (/sys/fs/cgroup, or /sys/fs/cgroup/unified on hybrid systems)."""
    try:
        with open("/proc/self/mountinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                left, sep, right = line.partition(" - ")
                if sep and right.split(" ", 1)[0] == "cgroup2":
                    fields = left.split(" ")
                    if fields[3] == "/":  # the hierarchy's root is mounted there (not a bind of a subtree)
                        return fields[4].replace("\\040", " ")
    except (OSError, IndexError):
        pass
    return None


def own_dir() -> "tuple[str | None, str]":
    """This process's cgroup2 directory, or None and why there is none."""
    mount = _mount_point()
    if mount is None:
        return None, "no cgroup2 file system is mounted"
    try:
        with open("/proc/self/cgroup", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("0::"):
                    rel = line[3:].rstrip("\n")
                    break
            else:
                return None, "this process is in no cgroup2 hierarchy"
    except OSError as e:
        return None, f"cannot read /proc/self/cgroup: {e.strerror}"
    path = os.path.normpath(mount + "/" + rel.lstrip("/"))
    if not os.path.isdir(path):  # a cgroup namespace whose root is not the mount's root
        return None, f"{path} does not exist (a cgroup namespace?)"
    return path, ""


def create(launch_id: str) -> "tuple[str | None, str]":
    """Make this launch's cgroup below our own; its path, or None and why the kernel's containment is unusable."""
    if os.environ.get(DISABLE_VAR, "") == "0":
        return None, f"{DISABLE_VAR}=0"
    parent, why = own_dir()
    if parent is None:
        return None, why
    remove_stale(parent)
    path = os.path.join(parent, PREFIX + launch_id)
    try:
        os.mkdir(path)
    except OSError as e:
        return None, f"cannot create a cgroup in {parent}: {e.strerror}"
    if not os.path.exists(os.path.join(path, "cgroup.kill")):
        remove(path)
        return None, "the kernel has no cgroup.kill (Linux 5.14 or newer needed)"
    try:  # moving a process needs write access to the destination's and the common ancestor's cgroup.procs
        if not (os.access(os.path.join(path, "cgroup.procs"), os.W_OK)
                and os.access(os.path.join(parent, "cgroup.procs"), os.W_OK)):
            raise PermissionError(13, "Permission denied")
    except OSError as e:
        remove(path)
        return None, f"cannot move processes into {path}: {e.strerror}"
    return path, ""


def make_child(path: str, name: str) -> str:
    """A child cgroup of `path` (one per node spawn); its path. OSError if it cannot be made."""
    child = os.path.join(path, name)
    try:
        os.mkdir(child)
    except FileExistsError:
        pass
    return child


def join(path: str) -> None:
    """Move the calling process into the cgroup at `path` (its children started later are born there)."""
    fd = os.open(os.path.join(path, "cgroup.procs"), os.O_WRONLY)
    try:
        os.write(fd, b"0")
    finally:
        os.close(fd)


def kill(path: str) -> bool:
    """SIGKILL every process in the cgroup and its children at once; False if it is gone or cannot be."""
    try:
        fd = os.open(os.path.join(path, "cgroup.kill"), os.O_WRONLY)
    except OSError:
        return False
    try:
        os.write(fd, b"1")
        return True
    except OSError:
        return False
    finally:
        os.close(fd)


def _populated(fd: int) -> bool:
    data = os.pread(fd, 256, 0)
    return b"populated 1" in data


def wait_empty(path: str, timeout: float) -> bool:
    """Wait (on cgroup.events, no polling) until no live process is left in the cgroup; True if so."""
    try:
        fd = os.open(os.path.join(path, "cgroup.events"), os.O_RDONLY)
    except OSError:
        return True  # gone
    try:
        poller = select.poll()
        poller.register(fd, select.POLLPRI | select.POLLERR)
        deadline = time.monotonic() + timeout
        while _populated(fd):  # (the read arms the notification: a change after it wakes the poll)
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            poller.poll(max(1, int(left * 1000)))
        return True
    except OSError:
        return True
    finally:
        os.close(fd)


def remove(path: str) -> bool:
    """Remove the cgroup and its child cgroups (deepest first; each must be empty); True if it is gone."""
    for root, dirs, _ in os.walk(path, topdown=False):
        for d in dirs:
            try:
                os.rmdir(os.path.join(root, d))
            except OSError:
                pass
    try:
        os.rmdir(path)
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return True


def remove_stale(parent: str) -> None:
    """Remove empty launch cgroups left in `parent` by launchers that are gone (all of whose supervisors
    were killed at once)."""
    try:
        names = [n for n in os.listdir(parent) if n.startswith(PREFIX)]
    except OSError:
        return
    for name in names:
        pid = name[len(PREFIX):].split("-", 1)[0]
        if pid.isdigit() and not os.path.exists(f"/proc/{pid}"):
            remove(os.path.join(parent, name))
