"""The URDF package's one error class: what was wrong, in which element, at which file:line."""
from __future__ import annotations

from ..core.text import printable

__all__ = ["URDFError"]


class URDFError(ValueError):
    """A URDF that cannot be used; str() is one line: ``FILE:LINE: ELEMENT: what is wrong``, its control
    characters escaped (names come from the file: a LF, CR or ESC in one cannot split or forge lines)."""

    def __init__(self, message: str, *, element: str | None = None, file: str | None = None,
                 line: int | None = None) -> None:
        self.message = message
        self.element = element
        self.file = file
        self.line = line
        super().__init__(str(self))

    def __str__(self) -> str:
        where = self.file or "<string>"
        if self.line is not None:
            where += f":{self.line}"
        what = f"{self.element}: " if self.element else ""
        return printable(f"{where}: {what}{self.message}", 4000)
