"""Picking a node's wire profile by name (``--wire`` / ``ZENTF_WIRE``, ``ROS_DOMAIN_ID``).

The interface is ``base.WireProfile``; the siblings are ``zentf_wire.ZentfProfile`` (the default: msgpack,
``@zentf`` tokens, docs/protocol.md) and ``ros2.Ros2Profile`` (rmw_zenoh's format, docs/ros2.md).
"""
from __future__ import annotations

from .base import Attacher, GraphEntry, WireProfile
from .ros2 import (ROS2_AUTHORITY, ROS2_DEFAULT_DEPTH, ROS2_PARAMETER_SERVICE_DEPTH, ROS2_ROUTER,
                   ROS2_SERVICE_DEPTH, Ros2Profile, parse_ros2_attachment, parse_ros2_token, qos_string,
                   ros2_attachment)
from .zentf_wire import ZentfProfile

__all__ = ["WireProfile", "ZentfProfile", "Ros2Profile", "Attacher", "GraphEntry", "make_profile", "PROFILES",
           "qos_string", "parse_ros2_token", "ros2_attachment", "parse_ros2_attachment", "ROS2_DEFAULT_DEPTH",
           "ROS2_AUTHORITY", "ROS2_ROUTER", "ROS2_SERVICE_DEPTH", "ROS2_PARAMETER_SERVICE_DEPTH"]

#: the profiles by the name ``--wire`` takes
PROFILES = ("zentf", "ros2")


def make_profile(wire_name: str | None = None, domain_id: int | str | None = None) -> WireProfile:
    """The profile by name ('zentf' default, 'ros2'); ValueError names a bad name or domain."""
    name = (wire_name or "zentf").strip().lower()
    if name == "zentf":
        return ZentfProfile()
    if name != "ros2":
        raise ValueError(f"unknown wire profile {wire_name!r} (choose zentf or ros2)")
    try:
        dom = int(domain_id) if domain_id not in (None, "") else 0
    except (TypeError, ValueError):
        raise ValueError(f"ROS_DOMAIN_ID must be an integer 0-232, got {domain_id!r}") from None
    if not 0 <= dom <= 232:
        raise ValueError(f"ROS_DOMAIN_ID must be an integer 0-232, got {dom}")
    return Ros2Profile(dom)
