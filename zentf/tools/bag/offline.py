"""The offline buffer: a recording's /tf and /tf_static in one Buffer, no network.

``load_buffer(path)`` inserts every transform in file order with tf2's semantics (the same
result as inserting sample by sample), with a cache time that never prunes while loading; the
cache time is then set to the span of the recording's stamps, so lookups work at any time of it.
The bytes go through the compiled loader (``bulk``, ``tfload.pyx``) chunk by chunk. ``start``/``end``
load a time window only (reading only the chunks that can hold it where the file has an index);
``load_buffer_at`` widens such a window around one time until a lookup there answers as the whole
recording would.
"""
from __future__ import annotations

import logging
import os
from collections.abc import Callable, Collection
from typing import Any

from .source import open_bag

__all__ = ["load_buffer", "load_buffer_at"]

log = logging.getLogger("zentf.tools.bag")

_LOAD_CACHE_NS = 1 << 62  # nothing is pruned while loading
_NS = 1_000_000_000


def _ns(t: Any) -> int | None:
    """A time given as a Time/Duration, int nanoseconds or float seconds -> int ns (None stays None)."""
    if t is None:
        return None
    if hasattr(t, "nanoseconds"):
        return int(t.nanoseconds)
    if isinstance(t, float):
        return round(t * _NS)
    return int(t)


def load_buffer(path: str | os.PathLike, *, topics: Collection[str] | None = None,
                on_problem: Callable[[str], None] | None = None, start: Any = None, end: Any = None) -> Any:
    """A Buffer holding every transform of the bag at ``path`` (any format zentf reads).

    ``topics``: the transform topics to load (default: every topic named tf or tf_static, in any
    namespace). ``start``/``end`` (Time, int ns or float s; either may be None): only transforms
    stamped in [start, end] are loaded, static ones always. The cache time is the span of the stamps
    (at least 1 ns). A damaged bag loads its readable part; ``on_problem`` (default: a logged
    warning) gets one line naming the file and what was unreadable. BagError if the file cannot be
    opened at all.
    """
    from zentf import Buffer
    from zentf.core.time import Duration

    from .bulk import load_into

    bag = open_bag(path)
    buf = Buffer(cache_time=Duration(nanoseconds=_LOAD_CACHE_NS))
    problem, _ = load_into(bag, buf, topics, _ns(start), _ns(end))
    newest = oldest = None
    for f in buf.frame_info():
        if f["static"]:
            continue
        n, o = f["most_recent_transform"].nanoseconds, f["oldest_transform"].nanoseconds
        newest = n if newest is None else max(newest, n)
        oldest = o if oldest is None else min(oldest, o)
    buf.set_cache_time(Duration(nanoseconds=max(1, (newest - oldest) if newest is not None else 1)))
    if problem:
        line = f"{bag.display}: {problem}; loaded the readable part"
        if on_problem is not None:
            on_problem(line)
        else:
            log.warning("%s", line)
    return buf


def load_buffer_at(path: str | os.PathLike, time: Any, frames: tuple[str, str] | None = None, *,
                   topics: Collection[str] | None = None, on_problem: Callable[[str], None] | None = None,
                   margin: float = 2.0) -> Any:
    """A Buffer of the transforms stamped around ``time`` (and every static one): enough that a lookup
    of ``frames`` (target, source) at ``time`` answers as it would in the whole recording.

    Loads a window of ``margin`` s each side, reading only the chunks that hold it (MCAP chunk index,
    ROS 1 index); while the lookup fails the window is widened (x4), up to the whole recording. Without
    ``frames`` one window is loaded. ``time`` 0 or None (the latest) loads the whole recording.
    """
    from zentf.core.exceptions import TransformException

    t = _ns(time)
    if not t:
        return load_buffer(path, topics=topics, on_problem=on_problem)
    half = max(1, round(margin * _NS))
    problems: list[str] = []
    while True:
        problems.clear()
        buf = load_buffer(path, topics=topics, on_problem=problems.append, start=t - half, end=t + half)
        if frames is None:
            break
        try:
            buf.lookup_transform(frames[0], frames[1], _time(t))
            break
        except TransformException:
            pass
        span = buf.frame_info()
        if half >= 1 << 62 or not span and half > 1 << 40:
            break
        half = min(half * 4, 1 << 62)
        if half >= 1 << 50:  # beyond any recording: the whole of it
            problems.clear()
            buf = load_buffer(path, topics=topics, on_problem=problems.append)
            break
    for line in problems:
        (on_problem or (lambda s: log.warning("%s", s)))(line)
    return buf


def _time(ns: int) -> Any:
    from zentf.core.time import Time

    return Time(nanoseconds=ns)
