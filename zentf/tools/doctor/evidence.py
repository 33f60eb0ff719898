"""What the tf doctor gathers: every transform with its sender, arrival time and source time.

``Evidence`` takes decoded TFMessages (rows as ``BufferCore.set_transforms_raw`` takes them) with who
sent them and when they arrived, and keeps per (child frame, sender, topic) figures: parents, rates,
gaps, how far stamps sit from arrival (and from the sender's own clock when the sample carries its
source time). It also inserts every row into a buffer of its own, exactly as a listener would, and
counts what that buffer refuses per sender (TF_OLD_DATA, TF_REPEATED_DATA, TF_NAN_INPUT...) plus
the samples stamped too far ahead (TF_FUTURE_DATA, zentf's listener guard). Every table is bounded:
a flood of forged frame or sender names costs a fixed amount of memory.
"""
from __future__ import annotations

import math
import threading
from collections import Counter, deque
from dataclasses import dataclass, field
from typing import Any, Iterable, Optional

from zentf.transport.wire.codec import RowCapture

__all__ = ["RowCapture", "Evidence", "EdgeStats", "SenderStats", "GraphView", "MAX_EDGES", "MAX_SENDERS"]

#: (child, sender, static) tables beyond these bounds count the extra samples as "overflow" only.
MAX_EDGES = 10_000
MAX_SENDERS = 1_000
#: Delays (arrival - stamp) kept per edge for the medians.
DELAY_WINDOW = 256
#: Parent changes kept per edge.
CHANGE_WINDOW = 16
_NS = 1_000_000_000


@dataclass
class EdgeStats:
    """One child frame as one sender publishes it on one topic (tf or tf_static)."""

    child: str
    sender: str
    static: bool
    parent: str = ""
    parents: Counter = field(default_factory=Counter)
    changes: deque = field(default_factory=lambda: deque(maxlen=CHANGE_WINDOW))  # (arrival ns, old, new)
    samples: int = 0
    first_arrival: int = 0          # monotonic-like ns (rates, gaps, age)
    last_arrival: int = 0
    first_stamp: int = 0
    last_stamp: int = 0
    newest_stamp: int = 0
    intervals: int = 0
    interval_sum: float = 0.0       # s
    interval_sq: float = 0.0
    max_gap: float = 0.0            # s
    delays: deque = field(default_factory=lambda: deque(maxlen=DELAY_WINDOW))   # arrival clock - stamp, ns
    own_clock: deque = field(default_factory=lambda: deque(maxlen=DELAY_WINDOW))  # stamp - source time, ns
    transit: deque = field(default_factory=lambda: deque(maxlen=DELAY_WINDOW))    # arrival wall - source, ns
    first_values: Optional[tuple] = None
    values_changed: int = 0
    topics: set = field(default_factory=set)

    @property
    def rate(self) -> Optional[float]:
        """Samples per second over arrival times (None below 2 samples)."""
        if self.intervals < 1 or self.interval_sum <= 0:
            return None
        return self.intervals / self.interval_sum

    @property
    def period(self) -> Optional[float]:
        return None if self.intervals < 1 else self.interval_sum / self.intervals

    @property
    def jitter(self) -> Optional[float]:
        """Standard deviation of the arrival intervals (s)."""
        if self.intervals < 2:
            return None
        mean = self.interval_sum / self.intervals
        return math.sqrt(max(0.0, self.interval_sq / self.intervals - mean * mean))


@dataclass
class SenderStats:
    """One sender (a node name, a ROS 2 publisher GID, a bag's caller id)."""

    key: str
    messages: int = 0
    samples: int = 0
    first_arrival: int = 0
    last_arrival: int = 0
    zid: str = ""                   # the Zenoh session its samples' timestamps name
    topics: set = field(default_factory=set)


class GraphView:
    """Who is in the graph and since when: nodes (fully qualified names) and ROS 2 publisher GIDs."""

    def __init__(self) -> None:
        self.known = False                       # a graph was watched at all (not a bag)
        self.nodes: dict[str, list] = {}         # fq name -> [first seen ns, gone ns or None]
        self.gids: dict[str, tuple[str, str]] = {}  # gid hex -> (node fq name, zid)
        self.gid_gone: dict[str, int] = {}
        self.zids: dict[str, str] = {}           # node fq name -> zid (ROS 2 tokens carry it)

    def node_seen(self, name: str, when: int, zid: str = "") -> None:
        entry = self.nodes.get(name)
        if entry is None:
            if len(self.nodes) < MAX_SENDERS * 4:
                self.nodes[name] = [when, None]
        else:
            entry[1] = None
        if zid:
            self.zids[name] = zid

    def node_gone(self, name: str, when: int) -> None:
        entry = self.nodes.get(name)
        if entry is not None:
            entry[1] = when

    def alive(self, name: str) -> Optional[bool]:
        """True/False when the graph was watched and the node is (not) in it; None when unknown."""
        if not self.known:
            return None
        entry = self.nodes.get(name)
        return entry is not None and entry[1] is None

    def gone_at(self, name: str) -> Optional[int]:
        entry = self.nodes.get(name)
        return None if entry is None else entry[1]


class _RefusalCounter:
    """Stands in for a BufferCore's rate-limited logger: counts (reason, sender) instead of printing."""

    def __init__(self) -> None:
        self.counts: Counter = Counter()

    def log(self, level: int, key: Any, fmt: str, *args: Any) -> None:
        if isinstance(key, tuple) and len(key) == 2:
            self.counts[key] += 1


class Evidence:
    """Per (child, sender, topic) figures of every transform seen, and a listener's buffer of them.

    ``add(rows, sender, is_static, arrival_ns=..., clock_ns=..., wall_ns=..., source_ns=...)`` from any
    thread: ``arrival_ns`` orders arrivals (monotonic, or a bag's log time), ``clock_ns`` is the
    receiving node's clock at arrival (wall or sim time: what stamps are compared with), ``wall_ns``
    this machine's wall clock and ``source_ns`` the sender's own clock when the sample carried it
    (a Zenoh timestamp, rmw_zenoh's attachment), else None.
    """

    def __init__(self, *, cache_time: float = 10.0, future_tolerance: Optional[float] = 5.0,
                 sim_time: bool = False) -> None:
        from zentf.core.buffer_core import BufferCore
        from zentf.core.time import Duration

        self.lock = threading.RLock()  # checks hold it while they read (re-entrant: they call back in)
        self.edges: dict[tuple[str, str, bool], EdgeStats] = {}
        self.senders: dict[str, SenderStats] = {}
        self.names: dict[str, str] = {}          # sender key -> display name (resolved later for GIDs)
        self.graph = GraphView()
        self.buffer = BufferCore(Duration.from_sec(cache_time))
        self._refusals = _RefusalCounter()
        self.buffer._warn = self._refusals       # the buffer's refusal lines become counts per sender
        self.future_ns = None if future_tolerance is None else round(future_tolerance * _NS)
        self.future: Counter = Counter()         # sender -> samples stamped beyond clock + tolerance
        self.sim_time = sim_time
        self.messages = 0
        self.overflow = 0                        # samples beyond the table bounds
        self.first_arrival = 0
        self.last_arrival = 0
        self.last_clock = 0
        self.topics: set[str] = set()

    # ------------------------------------------------------------------ input
    def add(self, rows: Iterable[tuple], sender: str, is_static: bool, *, arrival_ns: int,
            clock_ns: Optional[int] = None, wall_ns: Optional[int] = None, source_ns: Optional[int] = None,
            zid: str = "", topic: str = "") -> None:
        """One TFMessage's rows (parent, child, stamp ns, tx, ty, tz, qx, qy, qz, qw) from ``sender``."""
        clock_ns = arrival_ns if clock_ns is None else clock_ns
        wall_ns = clock_ns if wall_ns is None else wall_ns
        with self.lock:
            self.messages += 1
            if not self.first_arrival:
                self.first_arrival = arrival_ns
            self.last_arrival = max(self.last_arrival, arrival_ns)
            self.last_clock = max(self.last_clock, clock_ns)
            if topic and len(self.topics) < 64:
                self.topics.add(topic)
            s = self.senders.get(sender)
            if s is None:
                if len(self.senders) >= MAX_SENDERS:
                    self.overflow += 1
                    return
                s = self.senders[sender] = SenderStats(sender, first_arrival=arrival_ns)
            s.messages += 1
            s.last_arrival = arrival_ns
            if zid:
                s.zid = zid
            if topic and len(s.topics) < 16:
                s.topics.add(topic)
            for row in rows:
                s.samples += 1
                self._add_row(row, sender, is_static, arrival_ns, clock_ns, wall_ns, source_ns, topic)

    def _add_row(self, row: tuple, sender: str, is_static: bool, arrival: int, clock: int, wall: int,
                 source: Optional[int], topic: str) -> None:
        parent, child, stamp = row[0], row[1], row[2]
        key = (child, sender, is_static)
        e = self.edges.get(key)
        if e is None:
            if len(self.edges) >= MAX_EDGES:
                self.overflow += 1
                return
            e = self.edges[key] = EdgeStats(child, sender, is_static, first_arrival=arrival, first_stamp=stamp)
        if e.samples:
            gap = (arrival - e.last_arrival) / _NS
            if gap >= 0:
                e.intervals += 1
                e.interval_sum += gap
                e.interval_sq += gap * gap
                if gap > e.max_gap:
                    e.max_gap = gap
        if e.parent and parent != e.parent:
            e.changes.append((arrival, e.parent, parent))
        e.parent = parent
        if len(e.parents) < 16 or parent in e.parents:
            e.parents[parent] += 1
        e.samples += 1
        e.last_arrival = arrival
        e.last_stamp = stamp
        if stamp > e.newest_stamp:
            e.newest_stamp = stamp
        if topic and len(e.topics) < 8:
            e.topics.add(topic)
        values = tuple(row[3:10])
        if e.first_values is None:
            e.first_values = values
        elif values != e.first_values:
            e.values_changed += 1
        if not is_static and clock:  # (sim time before the first /clock: nothing to compare with)
            e.delays.append(clock - stamp)
            if source is not None:
                e.own_clock.append(stamp - source)
                e.transit.append(wall - source)
            if self.future_ns is not None and clock and stamp > clock + self.future_ns:
                self.future[sender] += 1   # zentf's listener refuses it: it never reaches the buffer
                return
        try:
            self.buffer.set_transform_raw(*row[:10], sender, is_static)
        except Exception:  # noqa: BLE001 - a malformed row is counted by the buffer's checks or dropped
            self._refusals.counts[("TF_MALFORMED", sender)] += 1

    # ------------------------------------------------------------------ output helpers
    def refusals(self) -> dict[str, Counter]:
        """reason -> Counter(sender -> refused samples), TF_FUTURE_DATA included."""
        out: dict[str, Counter] = {}
        with self.lock:
            for (reason, sender), n in self._refusals.counts.items():
                out.setdefault(str(reason), Counter())[sender] += n
            for sender, n in self.future.items():
                out.setdefault("TF_FUTURE_DATA", Counter())[sender] += n
        return out

    def display(self, sender: str) -> str:
        """A sender as people know it: its node name (ROS 2 GIDs resolved through the graph)."""
        name = self.names.get(sender)
        if name:
            return name
        hit = self.graph.gids.get(sender)
        if hit is not None:
            return hit[0]
        return sender or "unknown sender"

    def zid_of(self, sender: str) -> str:
        s = self.senders.get(sender)
        if s is not None and s.zid:
            return s.zid
        hit = self.graph.gids.get(sender)
        if hit is not None and hit[1]:
            return hit[1]
        return self.graph.zids.get(self.display(sender), "")

    def snapshot_edges(self) -> list[EdgeStats]:
        with self.lock:
            return list(self.edges.values())
