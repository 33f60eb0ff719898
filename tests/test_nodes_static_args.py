"""static_transform_publisher argument parsing: both forms and ROS 2's error texts."""
from __future__ import annotations

import math

import pytest

from zentf.tools.static_transform_publisher import UsageError, parse_args, parse_float


def q_close(a, b, tol=1e-12):
    return all(abs(x - y) < tol for x, y in zip(a, b))


def test_flags_translation_and_identity_rotation():
    a = parse_args(["--x", "0.4", "--z", "0.2", "--frame-id", "base_link", "--child-frame-id", "laser"])
    assert a.translation == (0.4, 0.0, 0.2)
    assert a.rotation == (0.0, 0.0, 0.0, 1.0)
    assert (a.frame_id, a.child_frame_id, a.old_style) == ("base_link", "laser", False)


def test_flags_rpy_uses_setrpy():
    a = parse_args(["--yaw", str(math.pi / 2), "--frame-id", "a", "--child-frame-id", "b"])
    s = math.sqrt(0.5)
    assert q_close(a.rotation, (0.0, 0.0, s, s))
    a = parse_args(["--roll", "0.1", "--pitch", "0.2", "--yaw", "0.3", "--frame-id", "a",
                    "--child-frame-id", "b"])
    # R = Rz(yaw) Ry(pitch) Rx(roll), composed by hand
    def axis(ax, ang):
        h = ang / 2
        v = [0.0, 0.0, 0.0]
        v[ax] = math.sin(h)
        return (*v, math.cos(h))

    def mul(p, q):
        x1, y1, z1, w1 = p
        x2, y2, z2, w2 = q
        return (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)
    expected = mul(mul(axis(2, 0.3), axis(1, 0.2)), axis(0, 0.1))
    assert q_close(a.rotation, expected)


def test_flags_quaternion():
    a = parse_args(["--qz", "1", "--qw", "0", "--frame-id", "a", "--child-frame-id", "b"])
    assert a.rotation == (0.0, 0.0, 1.0, 0.0)


def test_positional_eight_is_yaw_pitch_roll():
    a = parse_args(["1", "2", "3", str(math.pi / 2), "0", "0", "p", "c"])
    s = math.sqrt(0.5)
    assert a.translation == (1.0, 2.0, 3.0)
    assert q_close(a.rotation, (0.0, 0.0, s, s))
    assert (a.frame_id, a.child_frame_id, a.old_style) == ("p", "c", True)
    # roll is the sixth argument
    b = parse_args(["0", "0", "0", "0", "0", str(math.pi / 2), "p", "c"])
    assert q_close(b.rotation, (s, 0.0, 0.0, s))


def test_positional_nine_is_quaternion_and_negative_numbers():
    a = parse_args(["-0.5", "0", "0.4", "0", "0", "0", "1", "base_link", "camera"])
    assert a.translation == (-0.5, 0.0, 0.4)
    assert a.rotation == (0.0, 0.0, 0.0, 1.0)
    assert (a.frame_id, a.child_frame_id) == ("base_link", "camera")


def test_help_returns_none():
    assert parse_args(["--help"]) is None
    assert parse_args(["--x", "1", "-h"]) is None
    with pytest.raises(UsageError):  # like ROS 2, every flag is read before help is honoured
        parse_args(["-h", "--x", "bad"])


@pytest.mark.parametrize("args, message", [
    ([], "Not enough arguments to parse"),
    (["--x"], "Not enough arguments for --x"),
    (["--frame-id", "a", "--child-frame-id"], "Not enough arguments for --child-frame-id"),
    (["--x", "abc", "--frame-id", "a", "--child-frame-id", "b"], "Failed to parse --x argument as float"),
    (["--x", "1.5m", "--frame-id", "a", "--child-frame-id", "b"], "Failed to parse --x argument as float"),
    (["--roll", "1", "--qw", "1", "--frame-id", "a", "--child-frame-id", "b"],
     "Cannot specify both quaternion and Euler rotations"),
    (["--x", "1", "1", "2", "3", "0", "0", "0", "a", "b"],
     "Cannot specify both new-style (flags) and old-style (arguments)"),
    (["1", "2", "3", "a", "b"], "Extra unparsed arguments on command-line"),
    (["--frame-id", "a", "--child-frame-id", "b", "--bogus"], "Extra unparsed arguments on command-line"),
    (["--child-frame-id", "b"], "Frame id must not be empty"),
    (["--frame-id", "a"], "Child frame id must not be empty"),
    (["1", "2", "x", "0", "0", "0", "a", "b"], "Failed to parse z argument as float"),
    (["0", "0", "0", "0", "0", "0", "q", "a", "b"], "Failed to parse qw argument as float"),
    (["--x", "nan", "--frame-id", "a", "--child-frame-id", "b"], "--x argument must be a finite number"),
    (["--x", "1e999", "--frame-id", "a", "--child-frame-id", "b"], "Failed to parse --x argument as float"),
    (["--qz", "1", "--frame-id", "a", "--child-frame-id", "b"], "is not normalized"),
])
def test_errors(args, message):
    with pytest.raises(UsageError) as e:
        parse_args(args)
    assert message in str(e.value)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("text, value", [
    ("1", 1.0), (" -2.5 ", -2.5), ("1e-3", 1e-3), (".5", 0.5), ("5.", 5.0), ("0x1p-1", 0.5), ("+3", 3.0),
])
def test_parse_float_accepts_stod_syntax(text, value):
    assert parse_float("x", text) == value
