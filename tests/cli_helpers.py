"""Helpers for the CLI tests: run `zentf` as a real subprocess and check the one-line error contract."""
from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor

from conftest import REPO

ZENTF = [sys.executable, "-m", "zentf.cli"]


def zentf(args: Sequence[str], env: Mapping[str, str] | None, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """Run `zentf ARGS` to completion (stdout and stderr kept apart)."""
    return subprocess.run([*ZENTF, *args], env=dict(env) if env is not None else None, cwd=str(REPO),
                          capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)


def zentf_together(runs: Sequence[Sequence[str]], env: Mapping[str, str] | None,
                   timeout: float = 60.0) -> list[subprocess.CompletedProcess]:
    """Run several `zentf` commands at once, each to completion: observers of one graph that each listen for
    their own --duration overlap their waits instead of adding them up."""
    with ThreadPoolExecutor(len(runs)) as pool:
        return list(pool.map(lambda args: zentf(args, env, timeout), runs))


def assert_one_line_error(proc: subprocess.CompletedProcess, *needles: str, code: int | None = None) -> str:
    """Non-zero exit, no traceback, and the last stderr line is the one `zentf: error:` line."""
    assert proc.returncode != 0, (proc.stdout, proc.stderr)
    if code is not None:
        assert proc.returncode == code, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout, proc.stderr
    assert "\x1b" not in proc.stderr, "no spinner/escape codes when stderr is not a TTY"
    errors = [ln for ln in proc.stderr.splitlines() if ln.startswith("zentf: error:")]
    assert len(errors) == 1, proc.stderr
    assert proc.stderr.rstrip().splitlines()[-1] == errors[0], proc.stderr
    for n in needles:
        assert n in errors[0], errors[0]
    return errors[0]
