"""topic echo's message view (zentf.cli.msgview) on messages of known types: the shapes rosidl_runtime_py's
message_to_yaml / message_to_csv give ros2 topic echo's --no-arr, --no-str, --truncate-length and --csv."""
from __future__ import annotations

import pytest

from zentf.cli.msgview import FieldError, View, field_type, parse_field

JOINTS = {"header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "base"}, "name": ["a", "b", "c"],
          "position": [1.0, 2.0, 3.0], "velocity": [], "effort": []}
STATE = "sensor_msgs/msg/JointState"
COV = {"pose": {"position": {"x": 1.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
       "covariance": [0.0] * 36}


def test_no_arr_names_each_array_kind():
    out = View(no_arr=True).render(JOINTS, STATE)
    assert "name: '<sequence type: string, length: 3>'\n" in out
    assert "position: '<sequence type: float64, length: 3>'\n" in out and "frame_id: base\n" in out
    cov = View(no_arr=True).render(COV, "geometry_msgs/msg/PoseWithCovariance")
    assert cov.endswith("covariance: '<array type: float64[36]>'\n---")
    tf = View(no_arr=True).render({"transforms": [{}, {}]}, "tf2_msgs/msg/TFMessage")
    assert tf == "transforms: '<sequence type: geometry_msgs/msg/TransformStamped, length: 2>'\n---"


def test_truncate_and_no_str():
    out = View(truncate=2).render(JOINTS, STATE)
    assert "name:\n- a\n- b\n- '...'\n" in out and "position:\n- 1.0\n- 2.0\n- '...'\n" in out
    assert "frame_id: ba...\n" in View(truncate=2).render(JOINTS, STATE)
    assert "frame_id: base\n" in View(truncate=None).render(JOINTS, STATE)
    assert "frame_id: '<string length: <4>>'\n" in View(no_str=True).render(JOINTS, STATE)


def test_csv_is_every_leaf_depth_first():
    assert View(csv=True).render(JOINTS, STATE) == "1,2,base,a,b,c,1.0,2.0,3.0,,"
    assert View(csv=True, truncate=1).render(JOINTS, STATE) == "1,2,b...,a,...,1.0,...,,"
    assert View(csv=True, no_arr=True).render(JOINTS, STATE) == (
        "1,2,base,<sequence type: string, length: 3>,<sequence type: float64, length: 3>,"
        "<sequence type: float64, length: 0>,<sequence type: float64, length: 0>")


def test_field_selects_and_names_what_is_missing():
    view = View(field=parse_field("header.stamp.sec"))
    assert view.render(*view.select(JOINTS, STATE)) == "1\n---"
    pos = View(field=parse_field("pose.position"))
    assert pos.render(*pos.select(COV, "geometry_msgs/msg/PoseWithCovariance")) == "x: 1.0\ny: 0.0\nz: 0.0\n---"
    with pytest.raises(FieldError, match="'header.seq'.*no field 'seq'"):
        View(field=["header", "seq"]).select(JOINTS, STATE)
    with pytest.raises(FieldError, match="no field 'w'"):
        field_type("geometry_msgs/msg/PointStamped", ["point", "w"])
    with pytest.raises(FieldError, match="is an array, it has no fields"):
        field_type(STATE, ["name", "x"])
    field_type("geometry_msgs/msg/PointStamped", ["header", "stamp", "sec"])  # fine
    with pytest.raises(FieldError, match="invalid field value"):
        parse_field("..")
    assert parse_field(".pose..position") == ["pose", "position"]  # ros2 drops empty parts


@pytest.mark.parametrize("view", [View(), View(csv=True), View(no_arr=True)], ids=["yaml", "csv", "no-arr"])
def test_a_payload_nested_beyond_any_ros_type_is_shown_raw(view):
    """500 nested msgpack arrays under a zentf encoding: shown as raw bytes, not walked into a RecursionError."""
    from zentf.cli.topic import render_sample

    payload = b"\x91" * 500 + b"\x01"
    out = render_sample(payload, "application/msgpack;evil/msg/X", False, "k", None, view)
    assert out.startswith("# raw payload: 501 bytes, encoding application/msgpack;evil/msg/X\n"), out[:100]
