"""Errors of the ROS format layer: one class per concern, all ValueErrors, messages one line."""
from __future__ import annotations

__all__ = ["RosFormatError", "DefinitionError", "CdrError", "UnknownTypeError"]


class RosFormatError(ValueError):
    """Base of zentf.ros errors."""


class DefinitionError(RosFormatError):
    """A .msg definition could not be parsed or resolved."""


class CdrError(RosFormatError):
    """A CDR payload is malformed (truncated, bad header, bad length) or a value does not fit its field."""


class UnknownTypeError(RosFormatError, KeyError):
    """No definition for a ROS type name."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "unknown type"
