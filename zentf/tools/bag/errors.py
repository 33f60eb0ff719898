"""Errors of the bag tools: each one line naming the file and what was wrong."""
from __future__ import annotations

__all__ = ["BagError", "UnknownFormatError", "MissingDependencyError"]


class BagError(Exception):
    """A bag file that cannot be opened or written; one line naming the file and the reason."""


class UnknownFormatError(BagError):
    """A path that is no bag zentf reads; the message names what was found instead."""


class MissingDependencyError(BagError):
    """A ROS bag needs the optional ``rosbags`` package; the message says how to install it."""

    def __init__(self, what: str) -> None:
        super().__init__(f"{what} needs the 'rosbags' package: pip install 'zentf[ros]'")
