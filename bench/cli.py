"""CLI start-up benchmark: `zentf --help` and `zentf tf echo` time to its first printed transform.

    python bench/cli.py [--runs 7] [--startup]

Measured in one run, as wall time of fresh processes (median and best of --runs):
  python -c pass       the interpreter's own floor on this machine (reference)
  python -c "import zenoh"  + the Zenoh extension (reference for anything that opens a session)
  python -c "import zentf"  the package itself (issue 15: no slower than before the compiled core)
  zentf --help         target < 0.3 s (issue 15: and no slower than before)
  zentf tf echo        Popen -> first "At time" line, camera <- laser from two static publishers
                       already running on a local router; target < 0.5 s
  ... (local)          the same with zero configuration (the local profile, a rendezvous port of
                       the bench's own), plus `zentf node list` there (a short-lived listing that
                       asks the rendezvous, docs/networking.md#security); target < 0.6 s
Child processes may write .pyc files (as any installed package has them); the last row shows the
same echo with zentf compiled from source at every start (PYTHONDONTWRITEBYTECODE=1, as in CI).
--startup runs only the first four rows (no router, no publishers): quick to repeat before and after.
Also prints the heaviest imports of `zentf tf echo` (python -X importtime), so a regression shows
where it came from. Numbers on the shared 2-core machine are noisy: compare against the references.
"""
from __future__ import annotations

import argparse
import os
import re
import socket
import statistics
import subprocess
import sys
import time
import uuid
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PY = sys.executable


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wall(cmd: list[str], env: dict[str, str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    return time.perf_counter() - t0


def listing(cmd: list[str], env: dict[str, str], lines: int) -> float:
    """Wall time of a one-shot listing, which must print ``lines`` lines (a fast but partial answer fails)."""
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    took = time.perf_counter() - t0
    if len(out) != lines:
        raise RuntimeError(f"{cmd} listed {out}, expected {lines} lines")
    return took


def first_line(cmd: list[str], env: dict[str, str], pattern: str, timeout: float = 30.0) -> float:
    """Seconds from Popen to the first stdout line matching pattern (the process is then stopped)."""
    rx = re.compile(pattern)
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                         bufsize=1)
    try:
        assert p.stdout is not None
        for line in p.stdout:
            if rx.search(line):
                return time.perf_counter() - t0
            if time.perf_counter() - t0 > timeout:
                break
        raise RuntimeError(f"no line matching {pattern!r} from {cmd}")
    finally:
        p.kill()
        p.wait()


def wait_line(p: subprocess.Popen, pattern: str, timeout: float = 30.0) -> None:
    rx = re.compile(pattern)
    deadline = time.monotonic() + timeout
    assert p.stdout is not None
    for line in p.stdout:
        if rx.search(line):
            return
        if time.monotonic() > deadline:
            break
    raise RuntimeError(f"no line matching {pattern!r} from {p.args}")


def top_imports(cmd: list[str], env: dict[str, str], n: int = 8) -> list[tuple[int, str]]:
    """(cumulative µs, module) of the heaviest top-level imports of a command."""
    proc = subprocess.run([PY, "-X", "importtime", *cmd], env=env, cwd=REPO, capture_output=True, text=True,
                          timeout=60)
    rows = []
    for line in proc.stderr.splitlines():
        m = re.match(r"import time:\s+\d+ \|\s+(\d+) \| ( *)(\S+)", line)
        if m and len(m.group(2)) <= 2:  # top-level and first-level imports only
            rows.append((int(m.group(1)), m.group(2) + m.group(3)))
    return sorted(rows, reverse=True)[:n]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--startup", action="store_true",
                    help="only the start-up rows: python, import zenoh, import zentf, zentf --help")
    args = ap.parse_args()

    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_") and k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH", "")) if p)
    # zentf compiled from source at every start (CI sets PYTHONDONTWRITEBYTECODE=1): a copy of the
    # package without __pycache__, first on the path; the stdlib and dependencies keep their .pyc.
    import shutil
    import tempfile

    fresh = Path(tempfile.mkdtemp(prefix="zentf_nopyc_"))
    for pkg in ("zentf", "nodes"):
        shutil.copytree(REPO / pkg, fresh / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    nopyc = {"PYTHONDONTWRITEBYTECODE": "1", "PYTHONPATH": os.pathsep.join((str(fresh), env["PYTHONPATH"]))}
    ep = f"tcp/127.0.0.1:{free_port()}"
    ns = f"bench_{uuid.uuid4().hex[:8]}"
    zenv = {**env, "ZENTF_CONNECT": ep, "ZENTF_NO_MULTICAST": "1", "ZENTF_NAMESPACE": ns, "PYTHONUNBUFFERED": "1"}
    lenv = {**env, "ZENTF_LOCAL_PORT": str(free_port()), "PYTHONUNBUFFERED": "1"}  # zero configuration

    procs: list[subprocess.Popen] = []
    try:
        if not args.startup:  # the echo and listing rows need a router and two static publishers
            router = subprocess.Popen([PY, "-m", "zentf.transport.router", "--listen", ep, "--no-multicast"], env=env, cwd=REPO,
                                      stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            procs.append(router)
            wait_line(router, r"listening on")
            for a in (["0.4", "0", "0.2", "0.5", "0", "0", "base_link", "laser"],
                      ["-0.5", "0", "0.4", "0", "0", "0", "base_link", "camera"]):
                for penv in (zenv, lenv):
                    p = subprocess.Popen([PY, "-m", "nodes.static_transform_publisher", *a], env=penv, cwd=REPO,
                                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
                    procs.append(p)
                    wait_line(p, r"Spinning until stopped")

        cases = [
            ("python -c pass", "reference", None, lambda: wall([PY, "-c", "pass"], env)),
            ("python -c 'import zenoh'", "reference", None, lambda: wall([PY, "-c", "import zenoh"], env)),
            ("python -c 'import zentf'", "import", None, lambda: wall([PY, "-c", "import zentf"], env)),
            ("zentf --help", "start-up", 0.3, lambda: wall([PY, "-m", "zentf.cli", "--help"], env)),
            ("zentf tf echo camera laser", "first transform", 0.5,
             lambda: first_line([PY, "-m", "zentf.cli", "tf", "echo", "camera", "laser"], zenv, r"^At time ")),
            ("  same, zentf without .pyc", "first transform", 0.5,
             lambda: first_line([PY, "-m", "zentf.cli", "tf", "echo", "camera", "laser"],
                                {**zenv, **nopyc}, r"^At time ")),
            ("zentf tf echo (local)", "first transform", 0.5,
             lambda: first_line([PY, "-m", "zentf.cli", "tf", "echo", "camera", "laser"], lenv, r"^At time ")),
            ("zentf node list (local)", "complete list", 0.6,
             lambda: listing([PY, "-m", "zentf.cli", "node", "list"], lenv, 2)),
        ]
        if args.startup:
            cases = cases[:4]
        zenv_imports = dict(zenv)
        results = []
        for name, what, target, fn in cases:
            fn()  # warm the page cache
            times = [fn() for _ in range(args.runs)]
            results.append((name, what, target, statistics.median(times), min(times)))
        imports = [] if args.startup else top_imports(["-m", "zentf.cli", "tf", "echo", "camera", "laser",
                                                           "--count", "1"], zenv_imports)
    finally:
        shutil.rmtree(fresh, ignore_errors=True)
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                p.kill()

    floor = results[0][3]
    print(f"zentf CLI start-up, {args.runs} runs each (wall time of a fresh process)\n")
    print(f"{'command':<30} {'measures':<16} {'median s':>9} {'best s':>8} {'target s':>9} "
          f"{'median/target':>14} {'over python':>12}")
    for name, what, target, med, best in results:
        tgt = f"{target:.2f}" if target else "-"
        ratio = f"{med / target:.2f}x" if target else "-"
        verdict = ("  OK" if med < target else "  MISS") if target else ""
        print(f"{name:<30} {what:<16} {med:>9.3f} {best:>8.3f} {tgt:>9} {ratio:>14} {med - floor:>+11.3f}s{verdict}")
    if imports:
        print("\nheaviest imports of `zentf tf echo camera laser` (cumulative ms, .pyc cached):")
    for us, mod in imports:
        print(f"  {us / 1000:7.1f}  {mod}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
