"""Orphan guard, run as a tiny separate process by the launcher (stdlib only, started with -S).

The launcher writes `+PGID` / `-PGID` lines on our stdin as it starts and reaps node process
groups. When stdin reaches EOF the launcher is gone (even by SIGKILL): every group still alive gets
SIGTERM, then SIGKILL after a grace period. Direct children also carry PR_SET_PDEATHSIG; this
catches what that cannot (grandchildren such as the programs a `sh -c` node starts).
"""
import os
import signal
import sys
import time


def _alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except (ProcessLookupError, PermissionError):
        return False


def main() -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a terminal Ctrl-C is the launcher's to handle
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    grace = float(sys.argv[1]) if len(sys.argv) > 1 else 1.0
    groups: set[int] = set()
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
            except ValueError:
                pass
    alive = [g for g in groups if _alive(g)]
    for g in alive:
        try:
            os.killpg(g, signal.SIGTERM)
        except OSError:
            pass
    deadline = time.monotonic() + grace
    while alive and time.monotonic() < deadline:
        time.sleep(0.02)
        alive = [g for g in alive if _alive(g)]
    for g in alive:
        try:
            os.killpg(g, signal.SIGKILL)
        except OSError:
            pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
