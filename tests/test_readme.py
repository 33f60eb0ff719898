"""The README's "Run things" blocks and docs/cli.md's examples with output, run as written, in order,
against the demos they need, so neither can drift from the program again.

README conventions (the README states them for its readers): in a bash block, `# terminal 1 (ready
when it prints "X"):` starts the following lines in the background and waits for X in their output;
`# terminal 2:` runs the following lines one after the other; a line whose comment says `until Ctrl-C`
gets Ctrl-C after a few seconds and must have printed something and exit 0; a line whose comment says
`q quits` runs on a terminal and gets `q` once it printed the quoted line; every other line must exit 0.
At the end of a block, the terminal-1 programs get Ctrl-C and must exit 0.

docs/cli.md: a ```text block starting with `$ ` holds commands and the output they print; `$ CMD &
# ready when it prints "X"` starts a demo first. Measured figures (rates, delays, times) may differ;
the rest of every line must be the same. Elided output (docs/cli.md states it for its readers): a line
that is exactly `...` stands for zero or more lines, and `...` inside a line for any text.

Every command runs in a folder of its own (configs/ and tests/ linked in) on a Zenoh graph of its own
(ZENTF_LOCAL_PORT), with no other ZENTF_* setting: what a user gets with zero configuration.
"""
from __future__ import annotations

import ctypes
import fcntl
import os
import re
import shlex
import signal
import subprocess
import sys
import termios
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from conftest import REPO, free_port

#: How long a program that runs until Ctrl-C runs before it gets it; how long a demo may take to be ready.
RUN_FOR = 1.5
READY_WITHIN = 90.0
FINISH_WITHIN = 60.0
pytest.importorskip("rosbags", reason="the README's recordings block reads ROS bags (zentf[ros])")


@dataclass
class Step:
    cmd: str
    comment: str = ""
    background: bool = False
    ready: str = ""  # a line the program prints once it is ready

    @property
    def until_ctrl_c(self) -> bool:
        return "until Ctrl-C" in self.comment

    @property
    def keys(self) -> bool:
        return "q quits" in self.comment


def _ready_marker(text: str) -> str:
    m = re.search(r'prints "([^"]+)"', text)
    return m.group(1) if m else ""


def readme_blocks() -> list[list[Step]]:
    """The bash blocks of the README's "Run things" section as steps."""
    text = (REPO / "README.md").read_text()
    section = text.split("## Run things", 1)[1].split("\n## ", 1)[0]
    blocks = []
    for body in re.findall(r"```bash\n(.*?)```", section, re.S):
        steps, background, ready = [], False, ""
        for line in body.splitlines():
            if not line.strip():
                continue
            if line.startswith("# terminal 1"):
                background, ready = True, _ready_marker(line)
                assert ready, f"a terminal 1 says when it is ready: {line!r}"
                continue
            if line.startswith("# terminal 2"):
                background, ready = False, ""
                continue
            m = re.match(r"(.*?\S)\s{2,}#\s?(.*)$", line)
            cmd, comment = (m.group(1), m.group(2)) if m else (line, "")
            step = Step(cmd.strip(), comment.strip(), background, ready)
            if step.keys:
                step.ready = _ready_marker(comment)
            steps.append(step)
        blocks.append(steps)
    return blocks


class Run:
    """A command in a shell of its own session (Ctrl-C = SIGINT to its process group, as a terminal
    sends it), output collected by a thread; stdin a fresh terminal with ``tty``."""

    def __init__(self, cmd: str, cwd: Path, env: dict[str, str], tty: bool = False) -> None:
        self.cmd = cmd
        self.lines: list[str] = []
        self.master = self.slave = None
        stdin: int = subprocess.DEVNULL
        if tty:
            self.master, self.slave = os.openpty()
            stdin = self.slave
        slave = self.slave

        def setup() -> None:  # pragma: no cover - in the child
            os.setsid()
            if slave is not None:
                fcntl.ioctl(slave, termios.TIOCSCTTY, 0)
            ctypes.CDLL("libc.so.6").prctl(1, signal.SIGTERM)  # dies with the test

        self.popen = subprocess.Popen(["bash", "-c", cmd], cwd=cwd, env=env, stdin=stdin, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True, bufsize=1, preexec_fn=setup)
        self._changed = threading.Condition()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            with self._changed:
                self.lines.append(line.rstrip("\n"))
                self._changed.notify_all()
        with self._changed:
            self._changed.notify_all()

    def output(self) -> str:
        return "\n".join(self.lines)

    def wait_for(self, text: str, timeout: float) -> None:
        with self._changed:
            ok = self._changed.wait_for(lambda: text in self.output() or self.popen.poll() is not None, timeout)
        assert ok and text in self.output(), f"`{self.cmd}` did not print {text!r} within {timeout} s:\n{self.output()}"

    def ctrl_c(self) -> int:
        if self.popen.poll() is None:
            os.killpg(self.popen.pid, signal.SIGINT)
        return self.finish()

    def finish(self, timeout: float = FINISH_WITHIN) -> int:
        try:
            rc = self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(f"`{self.cmd}` still running after {timeout} s:\n{self.output()}") from None
        self._reader.join(5)
        return rc

    def kill(self) -> None:
        if self.popen.poll() is None:
            os.killpg(self.popen.pid, signal.SIGKILL)
            self.popen.wait(10)
        for fd in (self.master, self.slave):
            if fd is not None:
                os.close(fd)
        self.master = self.slave = None


@pytest.fixture
def user(tmp_path: Path):
    """(cwd, env) of a user in a fresh folder of a checkout, with `zentf` on PATH, on a graph of its own."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    shim = bin_dir / "zentf"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m zentf.cli "$@"\n')
    shim.chmod(0o755)
    work = tmp_path / "work"
    work.mkdir()
    for name in ("configs", "tests"):
        (work / name).symlink_to(REPO / name)
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PATH=f"{bin_dir}{os.pathsep}{env.get('PATH', '')}", ZENTF_LOCAL_PORT=str(free_port()),
               PYTHONUNBUFFERED="1", PYTHONPATH=os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH", "")) if p))
    return work, env


def _run_block(steps: list[Step], cwd: Path, env: dict[str, str]) -> None:
    demos: list[Run] = []
    try:
        for step in steps:
            if step.background:
                run = Run(step.cmd, cwd, env)
                demos.append(run)
                run.wait_for(step.ready, READY_WITHIN)
                continue
            run = Run(step.cmd, cwd, env, tty=step.keys)
            try:
                if step.keys:
                    run.wait_for(step.ready, READY_WITHIN)
                    os.write(run.master, b"q")
                    rc = run.finish()
                elif step.until_ctrl_c:
                    deadline = time.monotonic() + READY_WITHIN  # something printed, then RUN_FOR more
                    while not run.lines and run.popen.poll() is None and time.monotonic() < deadline:
                        time.sleep(0.1)
                    time.sleep(RUN_FOR)
                    assert run.popen.poll() is None, f"`{step.cmd}` ended before Ctrl-C:\n{run.output()}"
                    rc = run.ctrl_c()
                    assert run.lines, f"`{step.cmd}` printed nothing"
                else:
                    rc = run.finish()
            finally:
                run.kill()
            assert rc == 0, f"`{step.cmd}` exited {rc}:\n{run.output()}"
            assert "Traceback" not in run.output() and "error:" not in run.output(), run.output()
        for demo in demos:
            assert demo.ctrl_c() == 0, f"`{demo.cmd}` did not stop cleanly on Ctrl-C:\n{demo.output()}"
    finally:
        for demo in demos:
            demo.kill()


BLOCKS = readme_blocks()


def test_the_readme_starts_with_the_two_set_up_commands():
    text = (REPO / "README.md").read_text()
    assert text.startswith("# zentf\n\n```bash\npip install -e . && zentf launch laser\n"
                           "pip install -e '.[test]' && pytest\n```\n")
    assert len(BLOCKS) >= 6 and all(BLOCKS)


@pytest.mark.parametrize("index", range(len(BLOCKS)), ids=[b[0].cmd.split("#")[0][:40] for b in BLOCKS])
def test_readme_run_things_block(index, user):
    cwd, env = user
    _run_block(BLOCKS[index], cwd, env)


# ------------------------------------------------------------------ docs/cli.md


@dataclass
class Example:
    """One ```text block: the demos it needs (command, ready line), then commands and what each prints."""

    demos: list[tuple[str, str]] = field(default_factory=list)
    runs: list[tuple[str, list[str]]] = field(default_factory=list)


def cli_examples() -> list[Example]:
    """The ```text blocks of docs/cli.md that show `$ zentf ...` commands and what they print."""
    out = []
    for body in re.findall(r"```text\n(.*?)```", (REPO / "docs" / "cli.md").read_text(), re.S):
        if not body.startswith("$ "):
            continue
        ex = Example()
        for line in body.rstrip("\n").split("\n"):
            if line.startswith("$ "):
                cmd = line[2:]
                if re.search(r"&\s*(#|$)", cmd):
                    ex.demos.append((cmd.split("&")[0].strip(), _ready_marker(cmd)))
                else:
                    ex.runs.append((cmd, []))
            else:
                ex.runs[-1][1].append(line)
        out.append(ex)
    return out


#: Commands whose numbers are measured (rates, delays, times): any number may differ, the rest may not.
MEASURED = ("tf monitor", "tf frames", "topic delay", "topic bw")
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


def _mask(line: str) -> str:
    return " ".join(_NUMBER.sub("#", line).split())


ELLIPSIS = "..."


def _line_pattern(want: str) -> re.Pattern:
    """A shown line as a pattern: each `...` in it matches any text, the rest matches itself."""
    return re.compile(".*".join(re.escape(part) for part in want.split(ELLIPSIS)), re.S)


def matches(got: list[str], want: list[str]) -> bool:
    """Whether printed lines match the shown ones: a shown line that is exactly `...` matches zero or more
    printed lines, `...` inside a shown line matches any text (the elisions docs/cli.md uses)."""
    patterns = [None if w == ELLIPSIS else _line_pattern(w) for w in want]
    # ok[i]: got[i:] matches want[j:], for j from the end down (a table, no recursion depth to run out of)
    ok = [False] * len(got) + [True]
    for pattern in reversed(patterns):
        nxt = [False] * (len(got) + 1)
        for i in range(len(got), -1, -1):
            if pattern is None:
                nxt[i] = ok[i] or (i < len(got) and nxt[i + 1])
            else:
                nxt[i] = i < len(got) and ok[i + 1] and pattern.fullmatch(got[i]) is not None
        ok = nxt
    return ok[0]


def test_the_ellipsis_convention():
    assert matches(["a", "b", "c"], ["a", "..."]) and matches(["a"], ["a", "..."])
    assert matches(["a", "b", "c", "d"], ["a", "...", "d"]) and matches(["x: 1 .. 2 ok"], ["x: ... ok"])
    assert not matches(["a", "b"], ["a"]) and not matches(["a", "b", "c"], ["a", "...", "d"])
    assert not matches(["x: 1 ok", "y"], ["x: ... ok"]) and not matches(["ab.c"], ["a..c"])
    assert matches(["a.b"], ["a.b"]) and not matches(["axb"], ["a.b"])  # only `...` is special


EXAMPLES = cli_examples()


def test_docs_cli_has_examples_to_check():
    assert len(EXAMPLES) >= 5 and all(ex.runs for ex in EXAMPLES)


@pytest.mark.parametrize("index", range(len(EXAMPLES)), ids=[ex.runs[0][0][:40] for ex in EXAMPLES])
def test_docs_cli_example(index, user):
    ex = EXAMPLES[index]
    cwd, env = user
    demos = []
    try:
        for cmd, _ready in ex.demos:  # background demos start together (as `&` lets them), then each is awaited
            demos.append(Run(cmd, cwd, env))
        for demo, (_cmd, ready) in zip(demos, ex.demos):
            demo.wait_for(ready, READY_WITHIN)
        for cmd, expected in ex.runs:
            run = Run(cmd, cwd, env)
            try:
                run.finish()
            finally:
                run.kill()
            shown_waiting = any(w.startswith("Waiting for transform") for w in expected)
            got = [ln.rstrip() for ln in run.lines if shown_waiting or not ln.startswith("Waiting for transform")]
            want = [ln.rstrip() for ln in expected]
            if any(m in cmd for m in MEASURED):
                got, want = [_mask(g) for g in got], [_mask(w) for w in want]
            assert matches(got, want), f"`{cmd}` printed:\n" + "\n".join(got) + "\n\ndocs/cli.md shows:\n" + "\n".join(want)
    finally:
        for demo in demos:
            demo.ctrl_c()
            demo.kill()
