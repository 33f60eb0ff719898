"""Run one node under a child subreaper, so nothing it starts outlives it (stdlib only, run with -S -I).

The launcher starts `python -S -I reaper.py LAUNCHER_PID GRACE [--cgroup NODE_CGROUP] -- CMD...` as the
leader of the node's process group. With --cgroup (cgroup.py), this process joins the launch's cgroup
(NODE_CGROUP's parent) and the node its own NODE_CGROUP before exec, so whatever the node starts is
killed as a whole with cgroup.kill; without it (or if joining fails), the subreaper below is all there is. This process marks itself PR_SET_CHILD_SUBREAPER, so every descendant of the node that is
orphaned (a double-forked daemon, a `setsid()` child, the children of a dead `sh -c`) is re-parented
here, whatever session or process group it moved to; it forks and execs the node with PR_SET_PDEATHSIG
SIGKILL. Then:
- the stop signals the launcher sends the group (SIGINT, SIGTERM, SIGHUP) are passed on to the
  descendants that left the group; the same signals from anyone else also go to the node itself;
- when the node exits, every descendant left is SIGKILLed and reaped, and this process exits as the node
  did (same code, or killed by the same signal), so the launcher sees the node's own exit;
- when the launcher dies (even by SIGKILL: a parent-death signal says so), every descendant gets
  SIGTERM, SIGKILL after GRACE s, and this process exits. It needs neither the launcher nor its
  watchdog for that: a node's whole tree is stopped even when both are killed.
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # -I leaves our own directory out
import cgroup  # noqa: E402
import proctree  # noqa: E402

PR_SET_PDEATHSIG = 1
PR_SET_CHILD_SUBREAPER = 36
# a real-time signal nobody sends by accident (glibc reserves the two below its SIGRTMIN)
PARENT_DIED = getattr(signal, "SIGRTMIN", 34) + 2
STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
WATCHED = STOP_SIGNALS | {signal.SIGCHLD, PARENT_DIED}


class Reaper:
    """The node's process and whatever it leaves: reaped on SIGCHLD, signalled, killed."""

    def __init__(self, launcher: int, grace: float, node_cgroup: str = "") -> None:
        self.launcher = launcher
        self.grace = grace
        self.cgroup = node_cgroup  # the node's own cgroup ("" without one)
        self.me = os.getpid()
        self.group = os.getpgrp()
        self.node = 0
        self.status: int | None = None

    def reap(self) -> None:
        """Collect every dead child: the node, and the orphans adopted as subreaper."""
        while True:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if pid == 0:
                return
            if pid == self.node:
                self.status = status

    def below(self, outside_group_only: bool = False, table: "dict | None" = None) -> list[int]:
        """Live descendants and members of our process group, us excluded."""
        if table is None:
            table = proctree.snapshot()
        pids = set(proctree.descendants(self.me, table))
        pids.update(p for p, (_, g, _) in table.items() if g == self.group)
        pids.discard(self.me)
        return sorted(p for p in pids if p in table and table[p][2] != "Z"
                      and not (outside_group_only and table[p][1] == self.group))

    @staticmethod
    def send(pids: list[int], sig: int) -> None:
        for pid in pids:
            try:
                os.kill(pid, sig)
            except OSError:
                pass

    def wait_event(self, timeout: float) -> None:
        info = signal.sigtimedwait(WATCHED, max(0.0, timeout))
        if info is not None and info.si_signo == signal.SIGCHLD:
            self.reap()

    def kill_all(self) -> None:
        """SIGKILL every descendant until none is left: the node's cgroup at once when there is one, then
        (for what is outside it) the tree frozen first, so that nothing forking meanwhile is missed."""
        if self.cgroup:
            cgroup.kill(self.cgroup)
            cgroup.wait_empty(self.cgroup, 5.0)
        for _ in range(50):
            self.reap()
            pids = proctree.freeze(lambda table: self.below(table=table))
            if not pids:
                break
            self.send(pids, signal.SIGKILL)
            self.wait_event(0.05)
        self.reap()
        if self.cgroup:
            cgroup.remove(self.cgroup)

    def terminate_all(self) -> None:
        """The launcher is gone: SIGTERM to everything, SIGKILL to what is left after the grace period."""
        self.send(self.below(), signal.SIGTERM)
        deadline = time.monotonic() + self.grace
        while self.below() and time.monotonic() < deadline:
            self.wait_event(min(0.1, deadline - time.monotonic()))
        self.kill_all()

    def forward(self, info: signal.struct_siginfo) -> None:
        """A stop signal: descendants outside the group missed the launcher's killpg; pass it on."""
        self.send(self.below(outside_group_only=True), info.si_signo)
        if info.si_pid not in (self.launcher, self.me) and self.node and self.status is None:
            self.send([self.node], info.si_signo)  # sent to this pid by someone else: the node's too


def _exit_like(status: int) -> None:
    """Exit with the node's code, or die of the node's signal (without a core file)."""
    if not os.WIFSIGNALED(status):
        os._exit(os.waitstatus_to_exitcode(status) if os.WIFEXITED(status) else 1)
    sig = os.WTERMSIG(status)
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    except (ImportError, OSError, ValueError):
        pass
    for s in WATCHED:
        signal.signal(s, signal.SIG_IGN)  # drop whatever is pending
    if sig not in (signal.SIGKILL, signal.SIGSTOP):
        signal.signal(sig, signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {sig})
    os.kill(os.getpid(), sig)
    os._exit(128 + sig)


def main(argv: list[str]) -> int:
    node_cgroup = ""
    if len(argv) > 4 and argv[3] == "--cgroup":
        node_cgroup = argv[4]
        del argv[3:5]
    if len(argv) < 5 or argv[3] != "--":
        sys.stderr.write("usage: reaper.py LAUNCHER_PID GRACE [--cgroup NODE_CGROUP] -- CMD...\n")
        return 2
    launcher, grace, cmd = int(argv[1]), float(argv[2]), argv[4:]
    if os.getpgrp() != os.getpid():  # the launcher makes us a group leader; never kill a group not ours
        os.setpgid(0, 0)
    libc = ctypes.CDLL(None, use_errno=True)
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, WATCHED)
    libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    libc.prctl(PR_SET_PDEATHSIG, PARENT_DIED, 0, 0, 0)
    if os.getppid() != launcher:  # it died before the parent-death signal was armed
        return 1
    if node_cgroup:
        try:  # before the fork: nothing of the node can be born outside the launch's cgroup
            cgroup.join(os.path.dirname(node_cgroup))
        except OSError as e:
            sys.stderr.write(f"cannot join the launch's cgroup ({e.strerror}): only the subreaper contains this node\n")
            node_cgroup = ""
    r = Reaper(launcher, grace, node_cgroup)
    pid = os.fork()
    if pid == 0:  # the node: killed if we are, with the signal mask it would have had
        try:
            libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
            if os.getppid() != r.me:
                os._exit(1)
            if node_cgroup:
                try:
                    cgroup.join(node_cgroup)
                except OSError:  # still in the launch's cgroup: only the launcher's cgroup.kill reaches it
                    pass
            signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)
            os.execvp(cmd[0], cmd)
        except OSError as e:
            os.write(2, f"cannot start {cmd[0]}: {e.strerror}\n".encode())
        os._exit(127)
    r.node = pid
    while r.status is None:
        info = signal.sigwaitinfo(WATCHED)
        if info.si_signo == signal.SIGCHLD:
            r.reap()
        elif os.getppid() != launcher:  # PARENT_DIED, or a signal that came first: stop the tree once
            r.terminate_all()
            return 1
        elif info.si_signo in STOP_SIGNALS:
            r.forward(info)
    r.kill_all()
    _exit_like(r.status)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
