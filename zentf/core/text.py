"""Text that crosses into zentf from outside: names made safe to print, and words read as booleans.

Every layer shows strings it did not write: frame ids, node and topic names, joint names, exception
texts quoting a payload, values read from a file. ``printable`` is the one way such a string reaches a
log line or a terminal. ``parse_bool`` is the one reading of a yes/no word, whether it comes from an
environment variable, a parameter, a launch file or the command line.
"""
from __future__ import annotations

import logging
from typing import Any

__all__ = ["printable", "parse_bool", "PrintableFormatter", "stderr_log_handler", "TRUE_WORDS", "FALSE_WORDS"]

_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def _escape_char(c: str) -> str:
    if c in _NAMED:
        return _NAMED[c]
    code = ord(c)
    if code < 0x100:
        return f"\\x{code:02x}"
    return f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"


def printable(text: object, limit: int | None = None) -> str:
    """``text`` as it may be printed: every character Python does not call printable is written as its
    escape (ESC -> ``\\x1b``, LF -> ``\\n``, U+202E -> ``\\u202e``), so a name sent by anyone cannot move
    the cursor, clear or recolour the terminal, reorder what follows (bidi overrides), hide text
    (zero-width and tag characters) or forge a line; a ``limit`` cuts it (a log line stays a line).

    Backslashes stay as they are, so escaping twice changes nothing; the check for the common case
    (nothing to escape) is one C call."""
    if type(text) is not str:
        text = str(text)
    if limit is not None and len(text) > limit:
        text = f"{text[:limit]}...({len(text)} chars)"
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else _escape_char(c) for c in text)


class PrintableFormatter(logging.Formatter):
    """A log formatter whose message goes through ``printable`` and a traceback line by line (it keeps its
    lines): the last guard for a string from outside that a call site logged as it came."""

    def formatMessage(self, record: logging.LogRecord) -> str:  # noqa: N802 - logging's name
        record.message = printable(record.message)
        return super().formatMessage(record)

    def formatException(self, ei: Any) -> str:  # noqa: N802 - logging's name
        return "\n".join(printable(line) for line in super().formatException(ei).split("\n"))


def stderr_log_handler(fmt: str) -> logging.Handler:
    """The handler every zentf program logs to: stderr, one ``PrintableFormatter`` line per record
    (``logging.basicConfig(handlers=[...])``)."""
    handler = logging.StreamHandler()
    handler.setFormatter(PrintableFormatter(fmt))
    return handler


#: The words ``parse_bool`` reads, case and surrounding blanks ignored (launch files, env vars and
#: ``-p name:=value`` alike; YAML's own true/false arrive as bools).
TRUE_WORDS = frozenset({"true", "yes", "on", "1"})
FALSE_WORDS = frozenset({"false", "no", "off", "0", ""})


def parse_bool(value: Any, what: str = "value") -> bool:
    """A yes/no value: a bool, 0 or 1, or one of TRUE_WORDS / FALSE_WORDS (an empty word is false, as an
    unset variable). Anything else raises ValueError naming ``what``."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    if isinstance(value, str):
        word = value.strip().lower()
        if word in TRUE_WORDS:
            return True
        if word in FALSE_WORDS:
            return False
    raise ValueError(f"{what}: expected true or false (or yes/no, on/off, 1/0), got {printable(repr(value), 80)}")
