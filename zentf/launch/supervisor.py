"""Run a launch description's nodes as child processes: output, respawn, required, clean shutdown.

Everything happens on the calling (main) thread in one selector loop: child exits arrive as pidfd
events, output as pipe reads, signals through the wakeup fd. Spawning only from this one long-lived
thread matters: PR_SET_PDEATHSIG fires when the *thread* that forked the child exits.

No orphans: where the kernel allows it, the launch has a cgroup v2 of its own (cgroup.py), every node one
inside it, and stopping writes cgroup.kill: nothing a node starts can slip out of that. Everywhere (and
alone where there is no usable cgroup) every node runs under its own subreaper (reaper.py), which adopts
and kills whatever the node leaves, setsid() daemons included, freezing a tree with SIGSTOP before it
kills it, and stops the node's whole tree when the launcher dies; the launcher is a subreaper too (for
what a killed reaper leaves), and a watchdog process kills the launch's cgroup, or finds the rest by the
launch id every descendant inherits in its environment (ZENTF_LAUNCH_ID), when the launcher dies.
"""
from __future__ import annotations

import ctypes
import logging
import os
import selectors
import secrets
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO, Callable, Mapping

from . import cgroup, proctree
from .description import NodeSpec

__all__ = ["Supervisor", "StopTimes", "exit_code_of", "respawn_wait", "RESPAWN_FLOOR", "RESPAWN_CAP",
           "RESPAWN_RESET"]

log = logging.getLogger("zentf.launch")

PR_SET_CHILD_SUBREAPER = 36
_libc = ctypes.CDLL(None, use_errno=True)
_prctl = _libc.prctl
_COLORS = ("36", "33", "32", "35", "34", "31", "96", "93", "92", "95", "94", "91")
_RESET = "\033[0m"
_REAPER = str(Path(__file__).with_name("reaper.py"))

#: Respawn backoff (ROS 2 waits respawn_delay every time; we do not, so a node crashing at start cannot
#: spin): never sooner than RESPAWN_FLOOR s, doubled after every exit that came less than RESPAWN_RESET s
#: after the start, up to RESPAWN_CAP s (or respawn_delay when that is longer).
RESPAWN_FLOOR = 0.1
RESPAWN_CAP = 10.0
RESPAWN_RESET = 10.0


@dataclass
class StopTimes:
    """Shutdown escalation: SIGINT, then SIGTERM after `sigint` s, then SIGKILL after `sigterm` s more."""

    sigint: float = 1.0
    sigterm: float = 1.0
    sigkill: float = 0.8


def exit_code_of(returncode: int) -> int:
    """Shell convention: killed by signal N -> 128 + N."""
    return 128 - returncode if returncode < 0 else returncode


def respawn_wait(delay: float, quick_exits: int) -> float:
    """Seconds before a respawn: respawn_delay (at least the floor) doubled per earlier quick exit, capped."""
    base = max(delay, RESPAWN_FLOOR)
    return min(base * 2.0 ** min(quick_exits, 64), max(RESPAWN_CAP, base))


def _describe_exit(returncode: int) -> str:
    if returncode < 0:
        try:
            return f"was killed by {signal.Signals(-returncode).name}"
        except ValueError:
            return f"was killed by signal {-returncode}"
    return f"exited with code {returncode}"


@dataclass
class _Child:
    spec: NodeSpec
    index: int
    popen: subprocess.Popen | None = None
    pidfd: int | None = None
    out_fd: int | None = None
    out_buf: bytes = b""
    log_file: BinaryIO | None = None
    spawns: int = 0
    respawn_at: float | None = None
    started_at: float = 0.0
    quick_exits: int = 0  # exits in a row that came less than RESPAWN_RESET s after the start
    last_code: int | None = None
    prefix: bytes = b""
    cgroup: str = ""  # this spawn's own cgroup, when the launch has one

    @property
    def running(self) -> bool:
        return self.popen is not None


@dataclass
class Supervisor:
    """Start, watch and stop a set of node processes; `run()` blocks until they are all gone."""

    nodes: list[NodeSpec]
    base_env: Mapping[str, str] = field(default_factory=lambda: dict(os.environ))
    log_dir: Path | None = None
    color: bool = False
    stop_times: StopTimes = field(default_factory=StopTimes)
    out: BinaryIO | None = None
    on_started: Callable[["Supervisor"], None] | None = None
    keep_alive: bool = False  # run until a signal even when no node is left (a clock-only launch)
    _children: list[_Child] = field(default_factory=list, init=False)
    _sel: selectors.BaseSelector = field(default=None, init=False)  # type: ignore[assignment]
    _stopping: int = field(default=0, init=False)  # 0 running, 1 SIGINT sent, 2 SIGTERM sent, 3 SIGKILL sent
    _stop_deadline: float = field(default=0.0, init=False)
    _exit_code: int = field(default=0, init=False)
    _watchdog: subprocess.Popen | None = field(default=None, init=False)
    _wakeup_r: int = field(default=-1, init=False)
    _launch_id: str = field(default="", init=False)
    _adopted: set[int] = field(default_factory=set, init=False)  # orphans re-parented to us, until reaped
    _subreaper: bool = field(default=False, init=False)
    _cgroup: str = field(default="", init=False)  # the launch's cgroup ("" when the subreapers are all there is)

    # ------------------------------------------------------------------ public
    def run(self) -> int:
        """Start every node, supervise until stopped (signal, required exit, all done); the exit code."""
        if self.out is None:
            self.out = sys.stdout.buffer
        self._sel = selectors.DefaultSelector()
        self._launch_id = f"{os.getpid()}-{secrets.token_hex(4)}"
        old_handlers, old_wakeup = self._install_signals()
        self._subreaper = _prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0  # what a killed reaper leaves comes here
        path, why = cgroup.create(self._launch_id)
        self._cgroup = path or ""
        if path:
            log.debug("nodes are contained in the cgroup %s", path)
        else:
            log.debug("no cgroup for this launch (%s): subreapers only", why)
        try:
            self._start_watchdog()
            self._children = [_Child(spec, i) for i, spec in enumerate(self.nodes)]
            for child in self._children:
                child.prefix = self._prefix(child.spec.full_name, child.index)
                if self._stopping:
                    break
                self._spawn(child)
            if self.on_started is not None and not self._stopping:
                self.on_started(self)
            self._loop()
            return self._exit_code
        finally:
            self._kill_everything()
            self._restore_signals(old_handlers, old_wakeup)
            self._close_watchdog()
            if self._cgroup:
                cgroup.remove(self._cgroup)
            if self._subreaper:
                _prctl(PR_SET_CHILD_SUBREAPER, 0, 0, 0, 0)
            for child in self._children:
                self._close_output(child)
            self._sel.close()

    def pids(self) -> dict[str, int]:
        return {c.spec.full_name: c.popen.pid for c in self._children if c.popen is not None}

    def request_stop(self, code: int = 0) -> None:
        """Begin the shutdown sequence (idempotent; a second call escalates)."""
        self._begin_stop(code)

    # ------------------------------------------------------------------ signals
    def _install_signals(self) -> tuple[dict[int, object], int]:
        r, w = os.pipe()
        os.set_blocking(r, False)
        os.set_blocking(w, False)
        self._wakeup_r = r
        self._wakeup_w = w
        old_wakeup = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
        old: dict[int, object] = {}
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            old[sig] = signal.signal(sig, lambda *_: None)  # the number arrives on the wakeup fd
        self._sel.register(r, selectors.EVENT_READ, ("signal", None))
        return old, old_wakeup

    def _restore_signals(self, old: dict[int, object], old_wakeup: int) -> None:
        signal.set_wakeup_fd(old_wakeup)
        for sig, handler in old.items():
            try:
                signal.signal(sig, handler)  # type: ignore[arg-type]
            except (TypeError, ValueError):
                pass
        for fd in (self._wakeup_r, self._wakeup_w):
            try:
                os.close(fd)
            except OSError:
                pass

    def _on_signal_fd(self) -> None:
        try:
            data = os.read(self._wakeup_r, 64)
        except BlockingIOError:
            return
        for signum in data:
            try:
                name = signal.Signals(signum).name
            except ValueError:
                name = f"signal {signum}"
            if self._stopping:
                log.info("%s again: escalating shutdown", name)
            else:
                log.info("%s: stopping %d node(s)", name, sum(c.running for c in self._children))
            self._begin_stop(0)

    # ------------------------------------------------------------------ watchdog
    def _start_watchdog(self) -> None:
        script = Path(__file__).with_name("watchdog.py")
        try:
            self._watchdog = subprocess.Popen(
                [sys.executable, "-S", "-I", str(script), str(self.stop_times.sigterm), self._launch_id,
                 self._cgroup],
                stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=None, start_new_session=True)
        except OSError as e:  # not fatal: the reapers still cover the nodes
            log.warning("cannot start the orphan watchdog: %s", e)
            self._watchdog = None

    def _tell_watchdog(self, line: str) -> None:
        if self._watchdog is None or self._watchdog.stdin is None:
            return
        try:
            self._watchdog.stdin.write(line.encode() + b"\n")
            self._watchdog.stdin.flush()
        except OSError:
            self._watchdog = None

    def _close_watchdog(self) -> None:
        wd = self._watchdog
        if wd is None:
            return
        try:
            if wd.stdin is not None:
                wd.stdin.close()
        except OSError:
            pass
        try:
            wd.wait(timeout=self.stop_times.sigterm + 1.0)
        except subprocess.TimeoutExpired:
            wd.kill()
            wd.wait()

    # ------------------------------------------------------------------ spawning
    def _prefix(self, name: str, index: int) -> bytes:
        if self.color:
            color = _COLORS[index % len(_COLORS)]
            return f"\033[{color}m[{name}]{_RESET} ".encode()
        return f"[{name}] ".encode()

    def _child_env(self, spec: NodeSpec) -> dict[str, str]:
        env = dict(self.base_env)
        for var in ("ZENTF_PARAMS_FILE", "ZENTF_PARAMS", "ZENTF_REMAP", "ZENTF_NODE_NAME"):
            env.pop(var, None)
        env.update(spec.child_env())
        env[proctree.LAUNCH_ID_VAR] = proctree.launch_id_value(self.base_env.get(proctree.LAUNCH_ID_VAR),
                                                              self._launch_id)
        if spec.python_path:
            parts = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]
            if spec.python_path not in parts:
                env["PYTHONPATH"] = os.pathsep.join([spec.python_path, *parts])
        return env

    def _open_log(self, child: _Child) -> BinaryIO:
        assert self.log_dir is not None
        self.log_dir.mkdir(parents=True, exist_ok=True)
        path = self.log_dir / (child.spec.full_name.replace("/", ".") + ".log")
        if child.log_file is None:
            log.info("%s: output goes to %s", child.spec.full_name, path)
        return open(path, "ab", buffering=0)

    def _spawn(self, child: _Child) -> None:
        spec = child.spec
        # The node's own reaper execs it (no Python between fork and exec here: the sim clock's Zenoh
        # threads may be running); it leads the node's process group.
        argv = [sys.executable, "-S", "-I", _REAPER, str(os.getpid()), str(self.stop_times.sigterm)]
        child.cgroup = ""
        if self._cgroup:
            try:
                child.cgroup = cgroup.make_child(self._cgroup, f"{child.index}.{child.spawns + 1}")
                argv += ["--cgroup", child.cgroup]
            except OSError as e:  # the launch's cgroup still holds it (the reaper joins that)
                log.warning("%s: cannot make its cgroup: %s", spec.full_name, e.strerror or e)
        argv += ["--", *spec.cmd]
        group: dict = {"process_group": 0} if sys.version_info >= (3, 11) else {"start_new_session": True}
        stdout: int | BinaryIO
        if spec.output == "log" and self.log_dir is not None:
            if child.log_file is not None:
                child.log_file.close()
            child.log_file = self._open_log(child)
            stdout = child.log_file
        else:
            stdout = subprocess.PIPE
        child.respawn_at = None
        child.spawns += 1
        child.started_at = time.monotonic()
        try:
            popen = subprocess.Popen(argv, env=self._child_env(spec), stdin=subprocess.DEVNULL,
                                     stdout=stdout, stderr=subprocess.STDOUT, close_fds=True, **group)
        except OSError as e:
            log.error("%s: cannot start %s: %s", spec.full_name, spec.cmd[0], e.strerror or e)
            self._after_exit(child, 127)
            return
        child.popen = popen
        self._tell_watchdog(f"+{popen.pid}")
        if popen.stdout is not None:
            fd = popen.stdout.fileno()
            os.set_blocking(fd, False)
            child.out_fd = fd
            child.out_buf = b""
            self._sel.register(fd, selectors.EVENT_READ, ("out", child))
        try:
            child.pidfd = os.pidfd_open(popen.pid)
            self._sel.register(child.pidfd, selectors.EVENT_READ, ("exit", child))
        except OSError:  # very old kernel: fall back to polling in the loop
            child.pidfd = None
        what = "respawned" if child.spawns > 1 else "started"
        log.info("%s %s (pid %d)", spec.full_name, what, popen.pid)

    # ------------------------------------------------------------------ the loop
    def _timeout(self) -> float | None:
        now = time.monotonic()
        deadlines = [c.respawn_at for c in self._children if c.respawn_at is not None and not self._stopping]
        if self._stopping:
            deadlines.append(self._stop_deadline)
        if any(c.running and c.pidfd is None for c in self._children):
            deadlines.append(now + 0.05)
        if not deadlines:
            return None
        return max(0.0, min(deadlines) - now)

    def _done(self) -> bool:
        if self._stopping == 4:
            return True
        if any(c.running for c in self._children):
            return False
        if self._stopping:
            return True
        return not self.keep_alive and not any(c.respawn_at is not None for c in self._children)

    def _loop(self) -> None:
        while not self._done():
            for key, _ in self._sel.select(self._timeout()):
                kind, child = key.data
                if kind == "signal":
                    self._on_signal_fd()
                elif kind == "out":
                    self._read_output(child)
                elif kind == "exit":
                    self._reap(child)
            for child in self._children:
                if child.running and child.pidfd is None and child.popen.poll() is not None:  # type: ignore[union-attr]
                    self._reap(child)
            now = time.monotonic()
            if self._stopping:
                if now >= self._stop_deadline and any(c.running for c in self._children):
                    self._escalate()
            else:
                for child in self._children:
                    if child.respawn_at is not None and now >= child.respawn_at and not self._stopping:
                        self._spawn(child)

    # ------------------------------------------------------------------ output
    def _emit(self, child: _Child, data: bytes) -> None:
        assert self.out is not None
        try:
            self.out.write(data)
            self.out.flush()
        except (BrokenPipeError, ValueError, OSError):
            pass

    def _read_output(self, child: _Child) -> bool:
        """Forward what the child's pipe holds now, line by line; False once nothing more is waiting."""
        fd = child.out_fd
        if fd is None:
            return False
        try:
            data = os.read(fd, 65536)
        except BlockingIOError:
            return False
        except OSError:
            data = b""
        if not data:
            self._close_output(child)
            return False
        buf = child.out_buf + data
        lines = buf.split(b"\n")
        child.out_buf = lines.pop()
        if len(child.out_buf) > 65536:
            lines.append(child.out_buf)
            child.out_buf = b""
        if lines:
            self._emit(child, b"".join(child.prefix + line + b"\n" for line in lines))
        return True

    def _close_output(self, child: _Child) -> None:
        if child.out_fd is not None:
            try:
                self._sel.unregister(child.out_fd)
            except (KeyError, ValueError):
                pass
            if child.popen is not None and child.popen.stdout is not None:
                child.popen.stdout.close()
            else:
                try:
                    os.close(child.out_fd)
                except OSError:
                    pass
            child.out_fd = None
        if child.out_buf:
            self._emit(child, child.prefix + child.out_buf + b"\n")
            child.out_buf = b""

    def _drain_output(self, child: _Child) -> None:
        """Read what a dead child left in its pipe (without waiting for grandchildren to close it)."""
        for _ in range(64):
            if not self._read_output(child):
                return

    # ------------------------------------------------------------------ exits
    def _reap(self, child: _Child) -> None:
        popen = child.popen
        if popen is None:
            return
        pgid = popen.pid
        try:  # leftovers of its group (still addressable: the zombie holds the pgid)
            os.killpg(pgid, signal.SIGKILL)
        except OSError:
            pass
        rc = popen.wait()
        if child.cgroup:  # its reaper kills it on the node's exit, unless the reaper itself was killed
            cgroup.kill(child.cgroup)
            cgroup.wait_empty(child.cgroup, 2.0)
            cgroup.remove(child.cgroup)
            child.cgroup = ""
        self._tell_watchdog(f"-{pgid}")
        if not self._stopping:  # (when stopping, the final sweep does it once for all)
            self._sweep()  # what the launcher adopted if the node's reaper was killed
        if child.pidfd is not None:
            try:
                self._sel.unregister(child.pidfd)
            except (KeyError, ValueError):
                pass
            os.close(child.pidfd)
            child.pidfd = None
        self._drain_output(child)
        self._close_output(child)  # a grandchild holding the pipe is gone (SIGKILL above)
        child.popen = None
        self._after_exit(child, rc)

    def _after_exit(self, child: _Child, rc: int) -> None:
        spec = child.spec
        child.last_code = rc
        if self._stopping:
            log.info("%s %s", spec.full_name, _describe_exit(rc))
            return
        if spec.required:  # a clean exit (teleop's 'q') is the user's way to end the launch, not an error
            (log.error if rc != 0 else log.info)("%s %s; it is required, so stopping everything",
                                                 spec.full_name, _describe_exit(rc))
            self._begin_stop(exit_code_of(rc))
            return
        if spec.respawn:
            done = child.spawns - 1
            if spec.respawn_max is None or done < spec.respawn_max:
                cap = "" if spec.respawn_max is None else f" ({done + 1}/{spec.respawn_max})"
                now = time.monotonic()
                if now - child.started_at >= RESPAWN_RESET:
                    child.quick_exits = 0  # it ran well for a while: back to respawn_delay
                wait = respawn_wait(spec.respawn_delay, child.quick_exits)
                child.quick_exits += 1
                log.warning("%s %s; respawning in %g s%s", spec.full_name, _describe_exit(rc), wait, cap)
                child.respawn_at = now + wait
                return
            log.error("%s %s; not respawning: respawn_max %d reached", spec.full_name, _describe_exit(rc),
                      spec.respawn_max)
        elif rc != 0:
            log.error("%s %s", spec.full_name, _describe_exit(rc))
        else:
            log.info("%s %s", spec.full_name, _describe_exit(rc))
        if rc != 0 and self._exit_code == 0:
            self._exit_code = exit_code_of(rc)

    # ------------------------------------------------------------------ stopping
    def _signal_all(self, sig: int) -> None:
        for child in self._children:
            if child.popen is not None:
                try:
                    os.killpg(child.popen.pid, sig)
                except ProcessLookupError:
                    pass
                except PermissionError as e:
                    log.error("%s: cannot send %s: %s", child.spec.full_name, signal.Signals(sig).name, e)

    def _begin_stop(self, code: int) -> None:
        if self._stopping:
            self._escalate()
            return
        self._exit_code = code
        for child in self._children:
            child.respawn_at = None
        self._stopping = 1
        self._stop_deadline = time.monotonic() + self.stop_times.sigint
        self._signal_all(signal.SIGINT)

    def _escalate(self) -> None:
        running = [c.spec.full_name for c in self._children if c.running]
        if self._stopping == 1:
            if running:
                log.warning("still running after SIGINT: %s; sending SIGTERM", ", ".join(running))
            self._stopping = 2
            self._stop_deadline = time.monotonic() + self.stop_times.sigterm
            self._signal_all(signal.SIGTERM)
        elif self._stopping == 2:
            if running:
                log.warning("still running after SIGTERM: %s; sending SIGKILL", ", ".join(running))
            self._stopping = 3
            self._stop_deadline = time.monotonic() + self.stop_times.sigkill
            if self._cgroup:
                cgroup.kill(self._cgroup)
            self._sweep(keep_nodes=False)  # each node's whole tree frozen, then killed
            self._signal_all(signal.SIGKILL)
        else:
            for name in running:
                log.error("%s does not die even from SIGKILL (stuck in the kernel?); giving up on it", name)
            self._stopping = 4

    def _sweep(self, keep_nodes: bool = True) -> None:
        """Kill and reap the orphans adopted as subreaper (what a node whose reaper was killed left)."""
        # Ours carry this launch's id (other children of this process, if any, are not ours to kill).
        # With keep_nodes=False the running nodes' trees go too (the SIGKILL step).
        # Frozen (SIGSTOP) before killed, so that a tree re-forking faster than /proc is read is caught whole.
        me = os.getpid()
        nodes = {c.popen.pid for c in self._children if c.popen is not None}

        def targets(table: dict[int, tuple[int, int, str]]) -> list[int]:
            roots = [pid for pid, (ppid, _, _) in table.items() if ppid == me and pid not in self._adopted
                     and pid not in nodes and proctree.has_launch_id(pid, self._launch_id)]
            self._adopted.update(roots)
            doomed = [pid for pid in self._adopted if pid in table]
            if not keep_nodes:
                doomed += [pid for pid in nodes if pid in table]
            for pid in list(doomed):
                doomed += proctree.descendants(pid, table)
            return doomed

        proctree.kill_frozen(targets, rounds=50, wait=1.0)
        for pid in list(self._adopted):  # never a node's reaper: its Popen reaps it
            try:
                if os.waitpid(pid, os.WNOHANG)[0] == pid:
                    self._adopted.discard(pid)
            except ChildProcessError:
                self._adopted.discard(pid)

    def _kill_everything(self) -> None:
        """Last resort on the way out (e.g. an exception in the loop): nothing may outlive us."""
        left = [c for c in self._children if c.popen is not None]
        if self._cgroup:
            cgroup.kill(self._cgroup)
        for child in left:
            try:
                os.killpg(child.popen.pid, signal.SIGKILL)  # type: ignore[union-attr]
            except OSError:
                pass
        for child in left:
            try:
                child.popen.wait(timeout=2)  # type: ignore[union-attr]
            except subprocess.TimeoutExpired:
                pass
            self._tell_watchdog(f"-{child.popen.pid}")  # type: ignore[union-attr]
            if child.pidfd is not None:
                try:
                    os.close(child.pidfd)
                except OSError:
                    pass
                child.pidfd = None
            child.popen = None
        self._sweep(keep_nodes=False)
        clean = self._subreaper  # every descendant came back to us and is gone: the watchdog may just exit
        if self._cgroup:  # (or the kernel says none is left)
            clean = cgroup.wait_empty(self._cgroup, 5.0)
            if not clean:
                log.error("processes are left in the cgroup %s", self._cgroup)
            cgroup.remove(self._cgroup)
        if clean:
            self._tell_watchdog(".")
        for child in self._children:
            if child.log_file is not None:
                child.log_file.close()
                child.log_file = None
