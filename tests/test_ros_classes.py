"""Classes made from ROS definitions (zentf.ros.classes): ROS field names, types and defaults, CDR round trips, and
.srv texts registered at run time."""
from __future__ import annotations

import pytest

from zentf.ros import UnknownTypeError, decode_plain, encode, register_service_definition
from zentf.ros.classes import message_class, service_class


def test_a_made_message_has_the_definitions_fields_and_defaults():
    mesh = message_class("visualization_msgs/msg/MeshFile")
    assert mesh().to_dict() == {"filename": "", "data": []}
    cov = message_class("geometry_msgs/msg/PoseWithCovariance")  # hand-written: kept
    assert cov.__module__ == "zentf.core.messages"
    with pytest.raises(ValueError, match="unknown field 'nope'"):
        mesh.from_dict({"nope": 1})
    with pytest.raises(UnknownTypeError):
        message_class("nope_msgs/msg/Nope")


def test_a_made_service_round_trips_through_cdr():
    frames = service_class("tf2_msgs/srv/FrameGraph")
    assert frames.Request().to_dict() == {} and frames.Response.TYPE_NAME == "tf2_msgs/srv/FrameGraph_Response"
    resp = frames.Response(frame_yaml="av1: {parent: world}")
    assert decode_plain(encode(resp), frames.Response.TYPE_NAME) == {"frame_yaml": "av1: {parent: world}"}
    assert service_class("tf2_msgs/srv/FrameGraph") is frames  # cached


def test_a_service_registered_at_run_time_gets_a_class_and_a_new_one_when_registered_again():
    register_service_definition("zentf_test_srvs/srv/Scale", "float64 factor\nint32[3] axes\n---\nbool ok\n")
    scale = service_class("zentf_test_srvs/srv/Scale")
    req = scale.Request.from_dict({"factor": 2.5})
    assert req.to_dict() == {"factor": 2.5, "axes": [0, 0, 0]}  # a fixed array defaults to its length
    assert decode_plain(encode(req), scale.Request.TYPE_NAME) == {"factor": 2.5, "axes": [0, 0, 0]}
    register_service_definition("zentf_test_srvs/srv/Scale", "float64 factor\nstring unit\n---\nbool ok\n")
    again = service_class("zentf_test_srvs/srv/Scale")
    assert again is not scale and again.Request().to_dict() == {"factor": 0.0, "unit": ""}
    with pytest.raises(UnknownTypeError):
        service_class("zentf_test_srvs/srv/Nope")
