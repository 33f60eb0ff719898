"""Deprecated path: the ROS 2 graph recorder lives in zentf.tools.bag.ros2record now."""
from __future__ import annotations

from .bag.ros2record import Ros2BagWriter

__all__ = ["Ros2BagWriter"]
