"""tf2's per-frame caches: TimeCache (samples over time) and StaticCache (one sample, any time).

As in tf2 (cache.cpp, static_cache.cpp), BufferCore keeps one cache object per frame and asks it
for the sample at a time; the walk over the tree stays in buffer_core.py. Storage is compact:
parallel ``array.array`` columns (int64 stamps in ns, int32 parent ids, 7 float64 values per
sample; ~68 bytes a sample), oldest first, searched with ``bisect``. Callers hold BufferCore's lock.
"""
from __future__ import annotations

import math
from array import array
from bisect import bisect_left, bisect_right
from typing import Optional

from .constants import INSERT_OK as _OK, INSERT_OLD as _OLD, INSERT_REPEATED as _REPEATED
from .time import fmt_stamp

__all__ = ["TimeCache", "StaticCache"]


class TimeCache:
    """Samples of one dynamic frame, oldest first (tf2 TimeCache)."""

    __slots__ = ("stamps", "parents", "data", "start", "max_ns", "latest", "newest", "oldest",
                 "memo_t", "memo", "spans", "last_span", "authority")
    is_static = False

    def __init__(self, max_ns: int) -> None:
        self.max_ns = max_ns
        self.authority = "no recorded authority"  # of the last accepted sample (tf2 keeps it too)
        self.clear()

    def clear(self) -> None:
        self.stamps = array("q")   # int64 ns, ascending
        self.parents = array("i")  # parent frame id per sample
        self.data = array("d")     # tx, ty, tz, qx, qy, qz, qw per sample
        self.start = 0             # logical first index (lazy pruning, compacted at 1/8 dead)
        self.newest = -1           # newest stamp, -1 when empty
        self.oldest = -1           # oldest live stamp
        self.latest: Optional[tuple] = None  # newest sample as a tuple, built on first use
        self.memo_t = -1           # last interpolated query time and its answer: a chain
        self.memo: Optional[tuple] = None    # re-walked at the same time reuses it
        # interpolation constants of recently queried intervals, by older stamp (validated
        # against the newer stamp, so inserts in between are noticed); small and bounded
        self.spans: dict[int, tuple] = {}
        self.last_span: Optional[tuple] = None  # (t0, t1, span) of the last query: time series
                                                # walk forward inside one interval, no bisect

    def __len__(self) -> int:
        return len(self.stamps) - self.start

    def _sample(self, i: int) -> tuple:
        d = self.data
        k = 7 * i
        return (self.parents[i], d[k], d[k + 1], d[k + 2], d[k + 3], d[k + 4], d[k + 5], d[k + 6])

    def insert(self, stamp: int, parent: int, values: tuple) -> int:
        newest = self.newest
        st = self.stamps
        if stamp > newest:
            st.append(stamp)
            self.parents.append(parent)
            self.data.extend(values)
            self.newest = stamp
            self.latest = None
            if newest < 0:
                self.oldest = stamp
                return _OK
            newest = stamp
        else:
            if newest > stamp + self.max_ns:
                return _OLD
            n = len(st)
            i = bisect_left(st, stamp, self.start, n)
            if st[i] == stamp:
                return _REPEATED
            st.insert(i, stamp)
            self.parents.insert(i, parent)
            k = 7 * i
            self.data[k:k] = array("d", values)
            self.memo_t = -1
            self.last_span = None  # an interval was split
            if i == self.start:
                self.oldest = stamp
        if self.oldest < newest - self.max_ns:
            self.prune()
        return _OK

    def prune(self) -> None:
        """Drop samples older than newest - cache time, right after an insert (ROS 1 order; ROS 2
        prunes before inserting): pop while oldest + max < newest."""
        st = self.stamps
        start = bisect_left(st, self.newest - self.max_ns, self.start, len(st))
        self.oldest = st[start]
        self.memo_t = -1  # the memoized time may have fallen out
        if start >= 8 and 8 * start > len(st):  # keep dead samples under 1/8 of the storage
            del st[:start]
            del self.parents[:start]
            del self.data[:7 * start]
            start = 0
        self.start = start

    def get(self, t: int) -> Optional[tuple]:
        """(parent, tx, ty, tz, qx, qy, qz, qw) at t, interpolated; None if not available."""
        newest = self.newest
        if t == newest or t == 0:
            if newest < 0:
                return None
            latest = self.latest
            if latest is None:
                latest = self.latest = self._sample(len(self.stamps) - 1)
            return latest
        if t == self.memo_t:
            return self.memo
        oldest = self.oldest
        if t > newest or t < oldest or newest == oldest:
            return None
        if t == oldest:
            return self._sample(self.start)
        last = self.last_span
        if last is not None and last[0] <= t < last[1]:
            t0 = last[0]
            span = last[2]
        else:
            st = self.stamps
            i = bisect_right(st, t, self.start, len(st)) - 1
            t0 = st[i]
            span = self.spans.get(t0)
            if span is None or span[0] != st[i + 1]:
                span = self._span(i)
            self.last_span = (t0, span[0], span)
        if span[1] is None:
            return span[2]  # different parents: no interpolation, the older sample applies
        _, inv_dt, p, x0, y0, z0, dx, dy, dz, qx, qy, qz, qw, ax, ay, az, aw, theta = span
        r = (t - t0) * inv_dt
        if theta:
            c = math.cos(r * theta)
            s = math.sin(r * theta)
            qx, qy, qz, qw = qx * c + ax * s, qy * c + ay * s, qz * c + az * s, qw * c + aw * s
        res = (p, x0 + r * dx, y0 + r * dy, z0 + r * dz, qx, qy, qz, qw)
        self.memo_t = t
        self.memo = res
        return res

    def _span(self, i: int) -> tuple:
        """Constants to interpolate between samples i and i+1 exactly like tf2.

        tf2's slerp is (q0·sin((1-r)θ) + ±q1·sin(rθ)) / sin θ, with θ from the normalized dot
        product and the sign picking the short way; rewritten as q0·cos(rθ) + a·sin(rθ) with
        a = (±q1 - q0·cos θ) / sin θ (an identity, no normalization assumed), so each query costs
        one cos and one sin. Translation: p0 + r·(p1 - p0).
        """
        st = self.stamps
        parents = self.parents
        d = self.data
        k = 7 * i
        p = parents[i]
        if parents[i + 1] != p:
            span: tuple = (st[i + 1], None, (p, d[k], d[k + 1], d[k + 2], d[k + 3], d[k + 4], d[k + 5], d[k + 6]))
        else:
            x0, y0, z0, w0 = d[k + 3], d[k + 4], d[k + 5], d[k + 6]
            x1, y1, z1, w1 = d[k + 10], d[k + 11], d[k + 12], d[k + 13]
            dot = x0 * x1 + y0 * y1 + z0 * z1 + w0 * w1
            c = (-dot if dot < 0 else dot) / math.sqrt(
                (x0 * x0 + y0 * y0 + z0 * z0 + w0 * w0) * (x1 * x1 + y1 * y1 + z1 * z1 + w1 * w1))
            theta = math.acos(1.0 if c > 1.0 else c)
            if theta != 0.0:
                if dot < 0:
                    x1, y1, z1, w1 = -x1, -y1, -z1, -w1
                ct, inv = math.cos(theta), 1.0 / math.sin(theta)
                a = ((x1 - x0 * ct) * inv, (y1 - y0 * ct) * inv, (z1 - z0 * ct) * inv, (w1 - w0 * ct) * inv)
            else:
                a = (0.0, 0.0, 0.0, 0.0)
            span = (st[i + 1], 1.0 / (st[i + 1] - st[i]), p, d[k], d[k + 1], d[k + 2],
                    d[k + 7] - d[k], d[k + 8] - d[k + 1], d[k + 9] - d[k + 2], x0, y0, z0, w0, *a, theta)
        spans = self.spans
        if len(spans) >= 16:
            spans.clear()
        spans[st[i]] = span
        return span

    def parent_at(self, t: int) -> int:
        """Parent id of the sample that applies at t (the older one), 0 if none (tf2 getParent)."""
        newest = self.newest
        if newest < 0:
            return 0
        if t == 0 or t == newest:
            return self.parents[len(self.parents) - 1]
        oldest = self.oldest
        if t > newest or t < oldest or newest == oldest:
            return 0
        st = self.stamps
        return self.parents[bisect_right(st, t, self.start, len(st)) - 1]

    def error(self, t: int) -> str:
        """The text tf2's findClosest gives for a failed query at t (empty cache: no text)."""
        n = len(self)
        if n == 0:
            return ""
        newest, oldest = self.newest, self.oldest
        if n == 1:
            return (f"Lookup would require extrapolation at time {fmt_stamp(t)}, "
                    f"but only time {fmt_stamp(newest)} is in the buffer")
        if t > newest:
            return (f"Lookup would require extrapolation {fmt_stamp(t - newest)}s into the future.  "
                    f"Requested time {fmt_stamp(t)} but the latest data is at time {fmt_stamp(newest)}")
        return (f"Lookup would require extrapolation {fmt_stamp(oldest - t)}s into the past.  "
                f"Requested time {fmt_stamp(t)} but the earliest data is at time {fmt_stamp(oldest)}")

    def latest_stamp_parent(self) -> tuple[int, int]:
        if self.newest < 0:
            return 0, 0
        return self.newest, self.parents[len(self.parents) - 1]

    def newest_stamp(self) -> int:
        return 0 if self.newest < 0 else self.newest

    def oldest_stamp(self) -> int:
        return 0 if self.newest < 0 else self.oldest

    def nbytes(self) -> int:
        return (self.stamps.buffer_info()[1] * 8 + self.parents.buffer_info()[1] * 4
                + self.data.buffer_info()[1] * 8)


class StaticCache:
    """The single sample of a static frame, valid at every time (tf2 StaticCache)."""

    __slots__ = ("sample", "parents", "authority")
    is_static = True
    newest = 0        # statics report stamp 0 (ignored by the latest-common-time minimum)

    def __init__(self) -> None:
        self.sample: tuple = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        self.parents = [0]  # same shape as TimeCache.parents[-1] for the fast LCT walk
        self.authority = "no recorded authority"

    def __len__(self) -> int:
        return 1

    def insert(self, stamp: int, parent: int, values: tuple) -> int:
        self.sample = (parent, *map(float, values))
        self.parents = [parent]
        return _OK

    def clear(self) -> None:
        """Static frames survive clear() in tf2."""

    def get(self, t: int) -> tuple:
        return self.sample

    def parent_at(self, t: int) -> int:
        return self.sample[0]

    def error(self, t: int) -> str:
        return ""

    def latest_stamp_parent(self) -> tuple[int, int]:
        return 0, self.sample[0]

    def newest_stamp(self) -> int:
        return 0

    def oldest_stamp(self) -> int:
        return 0

    def nbytes(self) -> int:
        return 64
