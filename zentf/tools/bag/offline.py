"""The offline buffer: a whole recording's /tf and /tf_static in one Buffer, no network.

``load_buffer(path)`` inserts every transform in file order with tf2's semantics (the same
result as inserting sample by sample), with a cache time that never prunes while loading; the
cache time is then set to the span of the recording's stamps, so lookups work at any time of it.
"""
from __future__ import annotations

import logging
import os
from collections.abc import Callable, Collection
from typing import Any

from .source import open_bag

__all__ = ["load_buffer"]

log = logging.getLogger("zentf.tools.bag")

_LOAD_CACHE_NS = 1 << 62  # nothing is pruned while loading
_BATCH = 4096


def load_buffer(path: str | os.PathLike, *, topics: Collection[str] | None = None,
                on_problem: Callable[[str], None] | None = None) -> Any:
    """A Buffer holding every transform of the bag at ``path`` (any format zentf reads).

    ``topics``: the transform topics to load (default: every topic named tf or tf_static, in any
    namespace). The cache time is the span of the stamps (at least 1 ns). A damaged bag loads
    its readable part; ``on_problem`` (default: a logged warning) gets one line saying where it
    stopped. BagError if the file cannot be opened at all.
    """
    from zentf.transport.buffer import Buffer
    from zentf.core.time import Duration
    from zentf.transport.wire.codec import ingest_tf

    bag = open_bag(path)
    buf = Buffer(cache_time=Duration(nanoseconds=_LOAD_CACHE_NS))
    insert = buf.set_transforms_raw
    # rows of consecutive messages with the same (static, authority) go in as one batch: same order,
    # same result, one lock and one wake-up per batch
    batch: list = []
    key: tuple[bool, str] = (False, "")
    for is_static, authority, payload, rows in bag.tf(topics):
        if rows is None:
            try:
                ingest_tf(payload, buf, authority, is_static)
            except ValueError as e:
                log.debug("undecodable TFMessage in %s: %s", path, e)
            continue
        if (is_static, authority) != key or len(batch) >= _BATCH:
            if batch:
                insert(batch, key[1], key[0])
            batch = []
            key = (is_static, authority)
        batch += rows
    if batch:
        insert(batch, key[1], key[0])
    newest = oldest = None
    for f in buf.frame_info():
        if f["static"]:
            continue
        n, o = f["most_recent_transform"].nanoseconds, f["oldest_transform"].nanoseconds
        newest = n if newest is None else max(newest, n)
        oldest = o if oldest is None else min(oldest, o)
    buf.set_cache_time(Duration(nanoseconds=max(1, (newest - oldest) if newest is not None else 1)))
    if bag.problem:
        line = f"{bag.display}: {bag.problem}; loaded the readable part"
        if on_problem is not None:
            on_problem(line)
        else:
            log.warning("%s", line)
    return buf
