"""static_transform_publisher as a process: bad arguments are one-line usage errors with exit 2 (docs/cli.md)."""
from __future__ import annotations

import pytest


@pytest.mark.parametrize("args, error", [
    (["--x", "abc", "--frame-id", "a", "--child-frame-id", "b"], "Failed to parse --x argument as float"),
    (["--roll", "1", "--qw", "1", "--frame-id", "a", "--child-frame-id", "b"],
     "Cannot specify both quaternion and Euler rotations"),
    (["1", "2", "3"], "Extra unparsed arguments on command-line"),
    (["--frame-id", "a"], "Child frame id must not be empty"),
])
def test_static_transform_publisher_bad_arguments(spawn, args, error):
    p = spawn.python("-m", "nodes.static_transform_publisher", *args)
    assert p.wait(20) == 2
    out = [line for line in p.lines if line.strip()]
    assert out == [f"static_transform_publisher: error parsing command line arguments: {error}"]


def test_static_transform_publisher_same_frames_and_help(spawn):
    p = spawn.python("-m", "nodes.static_transform_publisher", "0", "0", "0", "0", "0", "0", "a", "a")
    assert p.wait(20) == 2
    assert p.lines == ["static_transform_publisher: cannot publish static transform from 'a' to 'a', exiting"]
    h = spawn.python("-m", "nodes.static_transform_publisher", "--help")
    assert h.wait(20) == 0
    assert h.lines[0].startswith("usage: static_transform_publisher [--x X]")


@pytest.mark.parametrize("args, error", [
    (["nodes.frames_publisher", "-p", "rate:=-1"], "frames_publisher: error: parameter rate must be between 1e-06 and 1e+06 Hz, got -1.0"),
    (["nodes.turtle_teleop", "-p", "pattern:=zigzag"], "turtle_teleop: error: parameter pattern must be one of"),
    (["nodes.frame_listener", "--bogus"], "frame_listener: error: unrecognized arguments: --bogus"),
])
def test_bad_node_options_are_one_line_errors(spawn, args, error):
    p = spawn.python("-m", *args)
    assert p.wait(20) in (1, 2)
    out = [line for line in p.lines if line.strip()]
    assert len(out) == 1 and out[0].startswith(error), out
