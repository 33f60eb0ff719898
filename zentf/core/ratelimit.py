"""Rate-limited log lines for floods of bad input: one line per (reason, sender) per period, then a count.

tf2 prints one line per refused sample; a flood of NaN transforms then writes megabytes a second.
Here the first line of a key (reason and sender) prints at once, the next ones of that key within
``period`` seconds are only counted, and the next line printed for the key says how many were
suppressed. A global budget (``burst`` lines, refilled at ``rate`` lines a second) bounds floods of
many keys (forged sender names), and the key table is bounded too. Checking costs a dict lookup and
a clock read; nothing is formatted for a suppressed line. Every argument but a number (frame ids,
sender names, exceptions quoting a payload) is printed through ``zentf.core.text.printable``, so a
name holding ESC, CR or LF cannot rewrite the terminal or forge log lines.
"""
from __future__ import annotations

import logging
import numbers
import time
from typing import Any, Callable, Hashable

from .text import printable

__all__ = ["RateLimitedLogger"]

#: Longest stretch of one argument in a log line: a megabyte frame id is still one short line.
ARG_LIMIT = 256


class RateLimitedLogger:
    """``log(level, key, fmt, *args)`` logs at most once per ``period`` s per key, with the suppressed count.

    Lock-free (each step is one dict operation under the GIL): threads logging at once may, rarely,
    miscount a suppressed line, never fail.
    """

    __slots__ = ("logger", "period", "rate", "burst", "max_keys", "clock", "_next", "_suppressed", "_tokens",
                 "_stamp")

    def __init__(self, logger: logging.Logger, period: float = 5.0, *, rate: float = 2.0, burst: int = 20,
                 max_keys: int = 1024, clock: Callable[[], float] = time.monotonic) -> None:
        self.logger = logger
        self.clock = clock
        self.period = period
        self.rate = rate
        self.burst = burst
        self.max_keys = max_keys
        self._next: dict[Hashable, float] = {}       # key -> when its next line may print
        self._suppressed: dict[Hashable, int] = {}   # key -> lines counted since its last line
        self._tokens = float(burst)
        self._stamp = clock()

    def allow(self, key: Hashable) -> int:
        """-1: suppress this line (counted); else how many of this key were suppressed before it."""
        now = self.clock()
        nxt = self._next.get(key)
        if nxt is not None and now < nxt:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return -1
        tokens = self._tokens
        if now > self._stamp:  # (a clock that steps back only stops the refill)
            tokens = min(self.burst, tokens + (now - self._stamp) * self.rate)
        self._stamp = now
        if tokens < 1.0:  # the global budget is spent: count it against the key, retry later
            self._tokens = tokens
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return -1
        self._tokens = tokens - 1.0
        if nxt is None and len(self._next) >= self.max_keys:
            self._forget(now)
        self._next[key] = now + self.period
        return self._suppressed.pop(key, 0)

    def _forget(self, now: float) -> None:
        """Bound the key table: drop keys whose period is over, or the oldest half if none is."""
        table = self._next.copy()  # (one C call: other threads may log meanwhile, lock-free)
        expired = [k for k, t in table.items() if t <= now]
        if len(expired) < len(table) // 2:
            expired = list(table)[: len(table) // 2]
        for k in expired:
            self._next.pop(k, None)
            self._suppressed.pop(k, None)

    def log(self, level: int, key: Hashable, msg: str, *args: Any, exc_info: Any = None) -> bool:
        """Log ``msg % args`` unless suppressed, every argument but numbers escaped (``printable``, cut at
        ARG_LIMIT), with ``exc_info``'s traceback if given; True if a line was written."""
        n = self.allow(key)
        if n < 0:
            return False
        args = tuple(a if isinstance(a, numbers.Number) else printable(a, ARG_LIMIT) for a in args)
        if n:
            msg += " (%d similar suppressed)"
            args = (*args, n)
        self.logger.log(level, msg, *args, exc_info=exc_info)
        return True
