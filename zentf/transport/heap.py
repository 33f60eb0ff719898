"""Hand memory freed after a burst back to the OS: glibc keeps it in each thread's malloc arena.

A flood of big messages passes through buffers that Zenoh's threads and the listener's thread allocate
and free again; glibc's allocator keeps the freed pages in the arena of the thread that used them
(each thread has its own), so the process's RSS stays at its peak after the flood has been handled;
after a flood of forged frames most of a listener's growth is such free memory (docs/performance.md).
``malloc_trim(0)`` returns the free pages of every arena. Other C libraries (musl, macOS)
have no such call: there ``release_free_memory`` does nothing.
"""
from __future__ import annotations

import ctypes
import sys
from typing import Any, Callable

__all__ = ["release_free_memory", "BurstRelease"]


def _malloc_trim() -> Callable[[int], int] | None:
    """glibc's malloc_trim, or None where the C library has none."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        fn: Any = ctypes.CDLL(None).malloc_trim  # the C library the process already runs on
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_size_t]
    fn.restype = ctypes.c_int
    return fn


_TRIM = _malloc_trim()


def release_free_memory() -> bool:
    """Return the free pages of every malloc arena to the OS (``malloc_trim(0)``, without the GIL).

    True if the call exists here (glibc). It walks the arenas' free lists (~0.02 ms with nothing to
    give back, ~2 ms for 35 MB), so call it when a burst is over, not per message.
    """
    if _TRIM is None:
        return False
    _TRIM(0)
    return True


class BurstRelease:
    """Gives freed memory back after bursts of big messages handled on threads one does not own (Zenoh's
    callbacks): ``note(nbytes)`` per message releases once ``threshold`` bytes went through since the last
    release, and, when an eighth of that came since, once more after no message came for ``quiet`` s
    (the burst's tail)."""

    def __init__(self, threshold: int = 8 * 1024 * 1024, quiet: float = 0.2) -> None:
        import threading

        self.threshold = threshold
        self.quiet = quiet
        self._bytes = 0          # noted since the last release (a count: races lose a little, no harm)
        self._seen = 0           # messages noted, for the quiet check
        self._timer: Any = None
        self._lock = threading.Lock()

    def note(self, nbytes: int) -> None:
        """A message of ``nbytes`` was handled (or dropped) on this thread."""
        self._bytes += nbytes
        self._seen += 1
        if self._bytes >= self.threshold:
            self._bytes = 0
            release_free_memory()
        elif self._bytes >= self.threshold // 8 and self._timer is None:  # (less is not worth a thread)
            self._arm()

    def _arm(self) -> None:
        import threading

        with self._lock:
            if self._timer is not None:
                return
            seen = self._seen
            self._timer = threading.Timer(self.quiet, self._tail, (seen,))
            self._timer.daemon = True
            self._timer.start()

    def _tail(self, seen: int) -> None:
        with self._lock:
            self._timer = None
        if self._seen != seen:  # not quiet yet: look again later
            self._arm()
            return
        self._bytes = 0
        release_free_memory()

    def close(self) -> None:
        with self._lock:
            timer, self._timer = self._timer, None
        if timer is not None:
            timer.cancel()
