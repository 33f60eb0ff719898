"""Limits and status codes shared by the buffer core and its caches."""
from __future__ import annotations

__all__ = ["DEFAULT_CACHE_TIME", "MAX_GRAPH_DEPTH", "MAX_STAMP_NS", "DEFAULT_MAX_FRAMES",
           "DEFAULT_MAX_FRAME_ID_LENGTH", "INSERT_OK", "INSERT_OLD", "INSERT_REPEATED"]

#: Seconds of history a BufferCore keeps by default (tf2's DEFAULT_CACHE_TIME).
DEFAULT_CACHE_TIME = 10.0
#: Longest chain a walk follows before it reports a loop (tf2's MAX_GRAPH_DEPTH).
MAX_GRAPH_DEPTH = 1000
#: Largest stamp a buffer holds: int64 nanoseconds (year 2262). Later stamps are refused on insert.
MAX_STAMP_NS = 2**63 - 1
#: Distinct frame names a buffer takes before it refuses new ones (not in tf2, which has no bound: a
#: flood of forged names would grow a listener without limit). A robot has tens to hundreds of frames.
DEFAULT_MAX_FRAMES = 10_000
#: Longest frame id a buffer takes, in UTF-8 bytes (not in tf2, which stores a frame id of any size).
DEFAULT_MAX_FRAME_ID_LENGTH = 256

#: What a cache's insert() answers: stored, older than the cache keeps, or a stamp already held.
INSERT_OK, INSERT_OLD, INSERT_REPEATED = 0, 1, 2
