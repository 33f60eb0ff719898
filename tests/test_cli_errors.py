"""The CLI's contract for bad input: one `zentf: error:` line, non-zero exit, no traceback (unless --debug)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from cli_helpers import ZENTF, assert_one_line_error, zentf

from conftest import free_port

HELP_COMMANDS = [
    [], ["tf"], ["tf", "echo"], ["tf", "monitor"], ["tf", "frames"], ["topic"], ["topic", "list"],
    ["topic", "info"], ["topic", "echo"], ["topic", "hz"], ["topic", "pub"], ["node"], ["node", "list"],
    ["node", "info"], ["graph"], ["static-transform-publisher"], ["launch"], ["clock"], ["router"],
]


@pytest.fixture
def offline_env() -> dict[str, str]:
    """No ZENTF_* variables: only the flags a test passes apply."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env["PYTHONUNBUFFERED"] = "1"
    return env


def test_help_everywhere(offline_env):
    for cmd in HELP_COMMANDS:
        proc = zentf([*cmd, "--help"], offline_env, timeout=30)
        assert proc.returncode == 0, (cmd, proc.stderr)
        assert "usage" in proc.stdout.lower(), (cmd, proc.stdout)
        assert proc.stderr == "", (cmd, proc.stderr)
    proc = zentf(["tf", "echo", "--help"], offline_env)
    for flag in ("--rate", "--precision", "--time", "--namespace", "--connect", "--listen", "--mode",
                 "--no-multicast", "--zenoh-config", "--debug"):
        assert flag in proc.stdout, flag


@pytest.mark.parametrize("args,needle", [
    (["tf", "echo"], "Missing argument 'SOURCE'"),
    (["tf", "echo", "a", "b", "--rate", "-1"], "--rate"),
    (["tf", "echo", "a", "b", "--mode", "bogus"], "--mode"),
    (["tf", "monitor", "a"], "give both FRAME_A and FRAME_B"),
    (["tf", "nosuch"], "No such command 'nosuch'"),
    (["topic", "echo", "bad topic!"], "invalid topic name"),
    (["topic", "pub", "x", "NoSuchType", "{}"], "unknown message type 'NoSuchType'"),
    (["topic", "pub", "x", "geometry_msgs/msg/Point", "{x: [1"], "DATA is not valid YAML/JSON"),
    (["topic", "pub", "x", "geometry_msgs/msg/Point", "{q: 1}"], "bad DATA for geometry_msgs/msg/Point"),
    (["node", "list", "--connect", "nonsense"], "bad endpoint 'nonsense'"),
    (["tf", "frames", "--zenoh-config", "/nonexistent/z.json5"], "Zenoh config file not found"),
])
def test_bad_arguments_are_one_line(offline_env, args, needle):
    proc = zentf(args, offline_env, timeout=30)
    assert_one_line_error(proc, needle, code=2)


@pytest.mark.parametrize("args", [["tf", "echo", "a", "b"], ["node", "list"], ["topic", "echo", "x"],
                                  ["tf", "monitor"], ["graph"]])
def test_unreachable_endpoint_is_one_line(offline_env, args):
    ep = f"tcp/127.0.0.1:{free_port()}"  # nothing listens there
    proc = zentf([*args, "--connect", ep, "--mode", "client", "--no-multicast"], offline_env, timeout=30)
    assert_one_line_error(proc, "Unable to connect", ep, code=1)
    assert ".rs:" not in proc.stderr  # zenoh's Rust source location is not for users


def test_debug_shows_the_traceback(offline_env):
    ep = f"tcp/127.0.0.1:{free_port()}"
    proc = zentf(["--debug", "node", "list", "--connect", ep, "--mode", "client", "--no-multicast"], offline_env)
    assert proc.returncode != 0
    assert "Traceback" in proc.stderr


def test_unknown_frame_after_timeout(zenoh_env):
    proc = zentf(["tf", "echo", "map", "nowhere", "--timeout", "1"], zenoh_env)
    line = assert_one_line_error(proc, "no transform map -> nowhere after 1 s", "does not exist", code=1)
    assert proc.stdout == "", line
    assert "Waiting for transform map -> nowhere:" in proc.stderr  # it said why while waiting


def test_nothing_published(zenoh_env):
    proc = zentf(["topic", "echo", "silence", "--once", "--timeout", "0.5"], zenoh_env)
    assert_one_line_error(proc, "nothing published on /", "/silence within 0.5 s", code=1)
    proc = zentf(["topic", "hz", "silence", "--duration", "0.5"], zenoh_env)
    assert_one_line_error(proc, "nothing published on", code=1)
    proc = zentf(["tf", "frames", "--wait", "0.5"], zenoh_env)
    assert_one_line_error(proc, "no tf data received in 0.5 s", code=1)
    proc = zentf(["tf", "monitor", "--duration", "0.5"], zenoh_env)
    assert_one_line_error(proc, "no tf data received in 0.5 s", code=1)
    proc = zentf(["node", "info", "ghost"], zenoh_env)
    assert_one_line_error(proc, "unknown node /", "/ghost", code=1)


def test_missing_optional_command_breaks_only_itself(offline_env):
    """If a lazily registered command's module is missing, only that command fails, in one line."""
    code = (
        "import sys; import zentf.cli as c;"
        "c._COMMANDS['launch'] = ('zentf.no_such_module:launch', 'x'); c.cli.lazy.update(c._COMMANDS);"
        "sys.exit(c.main(sys.argv[1:]))"
    )
    proc = subprocess.run([sys.executable, "-c", code, "launch", "x.yaml"], capture_output=True, text=True,
                          env=offline_env, timeout=30)
    assert_one_line_error(proc, "'zentf launch' is not available", code=1)
    proc = subprocess.run([sys.executable, "-c", code, "tf", "--help"], capture_output=True, text=True,
                          env=offline_env, timeout=30)
    assert proc.returncode == 0 and "echo" in proc.stdout


@pytest.mark.parametrize("args", [["tf", "echo", "a", "b"], ["tf", "monitor"], ["topic", "echo", "x"],
                                  ["topic", "pub", "x", "geometry_msgs/msg/Point", "{x: 1}"]])
def test_ctrl_c_stops_cleanly(spawn, zenoh_env, args):
    """SIGINT ends a long-running tool promptly, exit 0, no traceback (its node owns SIGINT)."""
    proc = spawn([*ZENTF, *args])
    # the tool's hidden node shows up in the graph once its session is up: wait for that
    deadline = time.monotonic() + 30
    while "_zentf_" not in zentf(["node", "list", "--all"], zenoh_env).stdout:
        assert time.monotonic() < deadline, proc.output()
    proc.signal(signal.SIGINT)
    assert proc.wait(10) == 0, proc.output()
    assert "Traceback" not in proc.output()


R2D2 = "tests/data/urdf/urdf_tutorial/urdf/06-flexible.urdf"


@pytest.mark.parametrize("args,needle", [
    (["robot-state-publisher", R2D2, "--publish-frequency", "1e-300"], "--publish-frequency"),
    (["robot-state-publisher", R2D2, "--publish-frequency", "inf"], "--publish-frequency"),
    (["run", "robot_state_publisher", R2D2, "-p", "publish_frequency:=1e-300"], "parameter publish_frequency"),
])
def test_a_frequency_the_timer_cannot_serve_is_one_line_naming_it(offline_env, args, needle):
    env = {**offline_env, "ZENTF_LOCAL_PORT": str(free_port())}
    proc = zentf(args, env, timeout=60)
    assert proc.returncode != 0 and "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("robot_state_publisher: error: ") and needle in lines[0], lines
    assert "OverflowError" not in lines[0] and "must be between 1e-06 and 1e+06 Hz" in lines[0], lines


def test_bag_play_of_a_log_time_at_the_end_of_time_is_one_line_naming_the_message(offline_env, tmp_path):
    from bag_generate import write_zentf

    bag = write_zentf(tmp_path / "end_of_time.mcap", [
        ("tf", "/p", 10**18, [("a", "b", 1, 0, (1, 0, 0), (0, 0, 0, 1))]),
        ("tf", "/p", 2**64 - 1, [("a", "b", 2, 0, (1, 0, 0), (0, 0, 0, 1))])])
    proc = zentf(["bag", "play", str(bag)], {**offline_env, "ZENTF_LOCAL_PORT": str(free_port())}, timeout=60)
    assert_one_line_error(proc, str(bag), "message 2 ", "(/tf, logged at 18446744073709551615 ns)",
                          "damaged or forged log time")
