"""Bad values on the command line are one clear line and exit 2, each in a real process; clients
configured by flags alone get data back within 3 s of a router restart."""
from __future__ import annotations

import os
import time

import pytest
from cli_helpers import ZENTF, assert_one_line_error, zentf

from conftest import start_router


@pytest.fixture
def offline_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env["PYTHONUNBUFFERED"] = "1"
    return env


@pytest.mark.parametrize("args,needles", [
    # an empty frame id fails at once (tf2 refuses it on every lookup) instead of warning every second
    (["tf", "echo", "", "laser"], ["Invalid value for 'SOURCE': a frame id cannot be empty"]),
    (["tf", "echo", "laser", " "], ["Invalid value for 'TARGET': a frame id cannot be empty"]),
    # a time no stamp can hold names its option, not Python's OverflowError
    (["tf", "echo", "a", "b", "--time", "1e300"], ["'--time'", "1e+300 is not a time stamp"]),
    (["tf", "echo", "a", "b", "--time=-1"], ["'--time'", "-1 is not a time stamp"]),
    (["topic", "pub", "/clock", "rosgraph_msgs/msg/Clock", "{clock: {sec: 99999999999999999999}}"],
     ["bad DATA for rosgraph_msgs/msg/Clock: clock.sec: 99999999999999999999 is out of range"]),
    # magnitudes that would overflow a wait or a sleep are refused before anything waits
    (["node", "list", "--wait", "1e300"], ["'--wait'", "1e+300 is too large (at most 1e+09)"]),
    (["topic", "hz", "x", "--period", "1e300"], ["'--period'", "1e+300 is too large"]),
    # a negative number is a number, not an unknown option
    (["clock", "rate", "-1"], ["rate FACTOR must be between 1e-06 and 1e+06, got -1.0"]),
    (["tf", "echo", "a", "b", "-2"], ["Invalid value for '[RATE]': -2.0 is not in the range"]),
    # counts: 0 is refused (ROS 2's "0 = forever" for --times surprised users); omit the option for that
    (["topic", "pub", "x", "geometry_msgs/msg/Point", "--times", "0"], ["'--times'", "0 is not in the range x>=1"]),
    (["tf", "echo", "a", "b", "--count", "0"], ["'--count'", "0 is not in the range x>=1"]),
    (["topic", "echo", "x", "--count", "0"], ["'--count'", "0 is not in the range x>=1"]),
    # an endpoint no socket can have is refused before anything is opened
    (["node", "list", "--connect", "tcp/127.0.0.1:99999"],
     ["--connect: bad endpoint 'tcp/127.0.0.1:99999' (port 99999 is not in 0-65535)"]),
    (["tf", "monitor", "--listen", "tcp/[::1]:70000"], ["bad endpoint 'tcp/[::1]:70000'"]),
    # the router: a directory is named as one; an unknown option is click's one line
    (["router", "--config", "/"], ["Zenoh config file is a directory: /"]),
    (["router", "--bogus"], ["No such option '--bogus'.", "(see 'zentf router --help')"]),
])
def test_bad_input_is_one_line_and_exit_2(offline_env, args, needles):
    started = time.monotonic()
    proc = zentf(args, offline_env, timeout=30)
    assert_one_line_error(proc, *needles, code=2)
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr  # no warnings, no usage block
    assert time.monotonic() - started < 15


@pytest.mark.parametrize("args,error", [
    (["--x", "abc", "--frame-id", "a", "--child-frame-id", "b"], "Failed to parse --x argument as float"),
    (["0", "0", "0", "0", "0", "0", "a", "a"], "cannot publish static transform from 'a' to 'a'"),
])
def test_static_transform_publisher_exits_2_on_bad_arguments(offline_env, args, error):
    proc = zentf(["static-transform-publisher", *args], offline_env, timeout=30)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()] and error in proc.stderr


def test_clients_by_flags_alone_get_data_back_within_3_s_of_a_router_restart(spawn, test_namespace):
    """docs/networking.md promises 3 s; Zenoh's default retry backs off to 4 s, zentf's to 1 s."""
    router, ep = start_router()
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env["PYTHONUNBUFFERED"] = "1"
    flags = ["--connect", ep, "--mode", "client", "--namespace", test_namespace]
    try:
        spawn([*ZENTF, "topic", "pub", "chatter", "geometry_msgs/msg/Point", "{x: 1}", "--rate", "20",
               "--wait-matching", "0", *flags], env=env)
        echo = spawn([*ZENTF, "topic", "echo", "chatter", "--json", *flags], env=env)
        echo.wait_for_line(r'^\{"x":1', 30)
        router.kill()  # SIGKILL: no goodbye to the clients
        # The outage itself (not a wait for an event): 4 s down lets a retry back-off grow to its
        # ceiling, Zenoh's default 4 s, which is what broke the promise.
        time.sleep(4.0)
        router, _ = start_router(ep)
        back_at = time.monotonic()
        echo._cursor = len(echo.lines)
        echo.wait_for_line(r'^\{"x":1', 15)
        # Retries at most 1 s apart: back within ~1 s. Zenoh's default back-off (up to 4 s between
        # tries) would come too close to the promised 3 s to hold under load.
        assert time.monotonic() - back_at < 1.5
    finally:
        router.stop()


def test_flag_only_clients_retry_at_most_1_s_apart():
    """The setting behind the test above (whose timing alone cannot always tell 1 s from 4 s)."""
    import json

    from zentf.transport.options import ZenohOptions

    cfg = ZenohOptions(connect=["tcp/127.0.0.1:7447"], mode="client").config()
    retry = json.loads(cfg.get_json("connect/retry"))
    assert retry["period_init_ms"] <= 250 and retry["period_max_ms"] <= 1000, retry
