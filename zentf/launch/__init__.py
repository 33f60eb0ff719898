"""The launcher: start whole node graphs from YAML launch files (`zentf launch`).

Layers inside: yaml_tree (lines) -> substitution -> description (check + resolve) -> supervisor
(processes) and sim_clock (/clock + control queryable) -> cli. Only sim_clock touches Zenoh.
"""
from __future__ import annotations

from .description import ClockSpec, LaunchDescription, NodeSpec, load_launch, resolve_launch_file
from .errors import LaunchError

__all__ = ["LaunchError", "LaunchDescription", "NodeSpec", "ClockSpec", "load_launch", "resolve_launch_file"]
