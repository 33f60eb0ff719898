"""tf2's exception classes, by the names ROS users already catch."""
from __future__ import annotations

__all__ = [
    "TransformException", "LookupException", "ConnectivityException", "ExtrapolationException",
    "InvalidArgumentException", "TimeoutException", "TypeException",
]


class TransformException(Exception):
    """Base of every tf2 error."""


class LookupException(TransformException):
    """A frame does not exist (or the tree contains a loop)."""


class ConnectivityException(TransformException):
    """The two frames are not part of the same tree."""


class ExtrapolationException(TransformException):
    """The requested time lies outside the buffered data of a link."""


class InvalidArgumentException(TransformException):
    """A frame id is empty or starts with '/', or a value is malformed."""


class TimeoutException(TransformException):
    """A blocking wait ran out of time."""


class TypeException(TransformException):
    """transform() was given a type it cannot transform."""
