"""The xacro engine's errors: one line each, naming the file and line where the model went wrong."""
from __future__ import annotations

__all__ = ["XacroError", "BudgetExceeded"]


class XacroError(Exception):
    """A model that cannot be expanded: ``message`` plus where (file, line) when known."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line

    def at(self, file: str | None, line: int | None) -> "XacroError":
        """This error with its place filled in, unless it already has one."""
        if self.file is None and file is not None:
            self.file, self.line = file, line
        return self

    def __str__(self) -> str:
        return self.message


class BudgetExceeded(XacroError):
    """Expansion used up its CPU, memory or size budget (raise it with ``--xacro-budget``)."""
