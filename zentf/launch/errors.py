"""The one error type of the launcher, so every refusal reads `FILE:LINE: what is wrong`."""
from __future__ import annotations

__all__ = ["LaunchError"]


class LaunchError(Exception):
    """A launch file (or its arguments) cannot be used; nothing has been started."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line

    def __str__(self) -> str:
        if self.file is None:
            return self.message
        if self.line is None:
            return f"{self.file}: {self.message}"
        return f"{self.file}:{self.line}: {self.message}"
