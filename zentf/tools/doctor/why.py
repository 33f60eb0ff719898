"""``explain_lookup``: why a lookup_transform answers or fails, edge by edge, and what to do about it.

tf2 stops at the first edge that cannot answer and names only the lookup's two frames (and for a
Time(0) lookup the latest common time, not which link holds it back; ros2/geometry2#832). Here every
edge of the chain is looked at on its own: its publisher, time range, rate and age, whether it can
answer at the requested time, and if not whether it is late by a sample (wait), stopped (stale),
stamped by a clock that is off, or older than the buffer keeps.
"""
from __future__ import annotations

import difflib
import math
import statistics
from dataclasses import dataclass, field
from typing import Any, Optional

__all__ = ["ChainEdge", "Verdict", "Explanation", "explain_lookup"]

_NS = 1_000_000_000
#: An edge whose newest sample is this many of its periods (and PENDING_MIN s) behind the asked time is
#: stale, not merely waiting for its next sample.
STALE_PERIODS = 3.0
PENDING_MIN = 0.1
MAX_DEPTH = 1000


def _s(ns: float) -> str:
    sec = ns / _NS
    return f"{sec:.2f} s" if abs(sec) >= 1.0 else f"{sec * 1e3:.0f} ms"


@dataclass
class ChainEdge:
    """One link of the chain: ``parent -> child`` with what the buffer holds for it."""

    child: str
    parent: str
    static: bool
    publisher: str
    oldest: int
    newest: int
    rate: Optional[float]
    samples: int
    age: float                      # s between the newest stamp and "now"
    clock_offset: Optional[float] = None  # s the publisher's stamps sit behind arrival (evidence only)

    @property
    def period(self) -> Optional[float]:
        return 1.0 / self.rate if self.rate else None

    def to_dict(self) -> dict[str, Any]:
        return {"parent": self.parent, "child": self.child, "static": self.static, "publisher": self.publisher,
                "oldest": self.oldest / _NS, "newest": self.newest / _NS, "rate": self.rate,
                "samples": self.samples, "age": self.age, "clock_offset": self.clock_offset}

    def label(self) -> str:
        return f"{self.parent} -> {self.child}"


@dataclass
class Verdict:
    """The lookup at one time: does it answer, which edges fail and why, what to do."""

    label: str                      # "now", "Time(0)" or "t=..."
    time: int                       # ns asked (0: latest common time)
    ok: bool
    answered_at: Optional[int] = None
    error: str = ""
    failing: list[dict[str, Any]] = field(default_factory=list)   # {"edge", "kind", "detail"}
    fixes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"label": self.label, "time": self.time / _NS, "ok": self.ok,
                "answered_at": None if self.answered_at is None else self.answered_at / _NS,
                "error": self.error, "failing": self.failing, "fixes": self.fixes}


@dataclass
class Explanation:
    """Everything explain_lookup found; ``text()`` for people, ``to_dict()`` for machines."""

    target: str
    source: str
    now: int
    chain: list[ChainEdge] = field(default_factory=list)
    problem: str = ""               # the frames are unknown or not connected
    fixes: list[str] = field(default_factory=list)
    verdicts: list[Verdict] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """The lookup answers with current data: every asked time answers, or fails only for a sample that is
        due (a timeout fixes that), and no edge is stale."""
        return not self.problem and bool(self.verdicts) and all(
            (v.ok or bool(v.failing)) and all(f["kind"] == "not yet" for f in v.failing) for v in self.verdicts)

    def stale_edges(self) -> list[str]:
        """Labels of the edges found stale at any of the asked times."""
        out: list[str] = []
        for v in self.verdicts:
            for f in v.failing:
                if f["kind"] in ("stale", "holds back") and f["edge"] not in out:
                    out.append(f["edge"])
        return out

    def text(self) -> str:
        lines = [f"lookup_transform(target={self.target}, source={self.source})"]
        if self.problem:
            lines.append(f"  FAILS: {self.problem}")
            lines += [f"  -> {f}" for f in self.fixes]
            return "\n".join(lines)
        if not self.chain:
            lines.append("  same frame: the identity, at any time")
            return "\n".join(lines)
        lines.append(f"  chain ({len(self.chain)} edge(s)), now = {self.now / _NS:.3f}:")
        for e in self.chain:
            if e.static:
                figures = "static"
            else:
                figures = (f"{e.rate:.1f} Hz" if e.rate else "one sample") + (
                    f", stamps {e.oldest / _NS:.3f} .. {e.newest / _NS:.3f}, newest {_s(e.age * _NS)} old")
                if e.clock_offset is not None:
                    figures += f", stamps {_s(abs(e.clock_offset) * _NS)} " + (
                        "behind" if e.clock_offset > 0 else "ahead of") + " arrival"
            lines.append(f"    {e.label()}  [{e.publisher}]  {figures}")
        for v in self.verdicts:
            if v.ok:
                at = "" if v.answered_at is None or v.answered_at == v.time else \
                    f" at {v.answered_at / _NS:.3f} ({_s(self.now - v.answered_at)} before now)"
                lines.append(f"  at {v.label}: OK{at}")
            else:
                lines.append(f"  at {v.label}: FAILS: {v.error}")
            for f in v.failing:
                lines.append(f"    - edge {f['edge']}: {f['kind']}: {f['detail']}")
            lines += [f"    -> {fix}" for fix in v.fixes]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return {"target": self.target, "source": self.source, "now": self.now / _NS, "ok": self.ok,
                "problem": self.problem, "fixes": self.fixes, "chain": [e.to_dict() for e in self.chain],
                "stale_edges": self.stale_edges(), "verdicts": [v.to_dict() for v in self.verdicts]}


def _infos(core: Any) -> dict[str, dict[str, Any]]:
    return {i["frame"]: i for i in core.frame_info()}


def _up(frame: str, infos: dict[str, dict[str, Any]]) -> list[str]:
    chain = [frame]
    while chain[-1] in infos and len(chain) <= MAX_DEPTH:
        nxt = infos[chain[-1]]["parent"]
        if nxt in chain:
            break
        chain.append(nxt)
    return chain


def _edge_rates(evidence: Any) -> dict[tuple[str, str], tuple[Optional[float], Optional[float], str]]:
    """(child, sender) -> (arrival rate, median delay s, display name) from the doctor's evidence."""
    out = {}
    if evidence is None:
        return out
    with evidence.lock:
        for e in evidence.edges.values():
            delays = list(e.delays)
            out[(e.child, e.sender)] = (e.rate, statistics.median(delays) / _NS if len(delays) >= 3 else None,
                                        evidence.display(e.sender))
    return out


def explain_lookup(buffer: Any, target: str, source: str, time: Any = None, *, now: Any = None,
                   evidence: Any = None, clock_tolerance: float = 1.0) -> Explanation:
    """Explain ``buffer.lookup_transform(target, source, time)``: the chain, each edge's publisher, time
    range, rate and age, and at ``time`` (default: both ``now`` and Time(0)) whether it answers, which
    edges fail (every one of them) and the fix. ``buffer`` is a Buffer/BufferCore; ``now`` (Time, ns or
    s; default the buffer node's clock, else the wall clock); ``evidence`` (zentf.tools.doctor.Evidence,
    optional) adds arrival rates, publisher names and clock offsets."""

    now_ns = _to_ns(now) if now is not None else _clock_now(buffer)
    ex = Explanation(target, source, now_ns)
    core = getattr(buffer, "buffer", buffer) if not hasattr(buffer, "frame_info") else buffer
    infos = _infos(core)
    known = set(core.get_frames()) if hasattr(core, "get_frames") else set(infos)
    for frame, what in ((target, "target"), (source, "source")):
        if frame not in known:
            close = difflib.get_close_matches(frame, sorted(known), n=3)
            ex.problem = f"{what} frame {frame!r} does not exist (the buffer knows {len(known)} frame(s))"
            ex.fixes.append(f"did you mean {', '.join(close)}?" if close else
                            "check the name (tf frames have no leading '/') and that its publisher runs")
            return ex
    if target == source:
        ex.verdicts.append(Verdict("now", now_ns, True))
        return ex
    up_s, up_t = _up(source, infos), _up(target, infos)
    common = next((f for f in up_s if f in set(up_t)), None)
    if common is None:
        ex.problem = (f"{source} and {target} are not connected: {source} hangs under {up_s[-1]}, "
                      f"{target} under {up_t[-1]}")
        ex.fixes.append(f"publish a transform that joins {up_s[-1]} and {up_t[-1]} (or fix the frame_id of "
                        "the publisher that started the extra root); 'zentf tf doctor' lists the trees")
        return ex
    rates = _edge_rates(evidence)
    frames = up_s[:up_s.index(common)] + list(reversed(up_t[:up_t.index(common)]))
    for f in frames:
        i = infos[f]
        sender = i["broadcaster"]
        rate, offset, name = rates.get((f, sender), (None, None, None))
        newest, oldest = i["most_recent_transform"].nanoseconds, i["oldest_transform"].nanoseconds
        if rate is None and not i["static"] and i["samples"] > 1 and newest > oldest:
            rate = (i["samples"] - 1) / ((newest - oldest) / _NS)
        if name is None:
            name = evidence.display(sender) if evidence is not None else sender
        ex.chain.append(ChainEdge(f, i["parent"], bool(i["static"]), name, oldest, newest, rate, i["samples"],
                                  0.0 if i["static"] else (now_ns - newest) / _NS, offset))
    times = [("now", now_ns), ("Time(0)", 0)] if time is None else [(_label(time), _to_ns(time))]
    for label, t in times:
        ex.verdicts.append(_verdict(core, ex, label, t, clock_tolerance))
    return ex


def _label(time: Any) -> str:
    t = _to_ns(time)
    return "Time(0)" if t == 0 else f"t={t / _NS:.3f}"


def _to_ns(t: Any) -> int:
    if hasattr(t, "nanoseconds"):
        return int(t.nanoseconds)
    if isinstance(t, float):
        return round(t * _NS)
    return int(t)


def _clock_now(buffer: Any) -> int:
    import time as _time

    node = getattr(buffer, "node", None)
    if node is not None:
        try:
            n = node.get_clock().now().nanoseconds
            if n:
                return n
        except Exception:  # noqa: BLE001
            pass
    return _time.time_ns()


def _stale_detail(e: ChainEdge, behind: int) -> str:
    s = f"its newest sample is {_s(behind)} older than the asked time"
    if e.rate:
        s += f" (it came at {e.rate:.1f} Hz, every {_s(_NS / e.rate)})"
    return s + f": {e.publisher} stopped sending it, or sends it late"


def _verdict(core: Any, ex: Explanation, label: str, t: int, tol: float) -> Verdict:
    from zentf.core.time import Time

    from zentf.core.buffer_core import BufferCore

    # BufferCore's own check, not a Buffer's override (which would wait, and reads its 4th argument as a timeout)
    ok, error = BufferCore.can_transform(core, ex.target, ex.source, Time(nanoseconds=t), True) \
        if isinstance(core, BufferCore) else (True, "")
    v = Verdict(label, t, bool(ok), error=" ".join(str(error).split()))
    dynamic = [e for e in ex.chain if not e.static]
    if t == 0:
        if not dynamic:
            v.answered_at = 0
            return v
        try:
            lct = core.get_latest_common_time(ex.target, ex.source).nanoseconds
        except Exception as exc:  # noqa: BLE001
            v.ok, v.error = False, " ".join(str(exc).split())
            return v
        v.answered_at = lct
        lag = ex.now - lct
        if not v.ok:
            for e in dynamic:
                if lct < e.oldest:
                    v.failing.append({"edge": e.label(), "kind": "too old",
                                      "detail": f"the latest common time is {_s(e.oldest - lct)} before the oldest "
                                                f"sample the buffer keeps of it ({e.publisher})"})
            v.fixes.append("the edges' data do not overlap in time: a stale edge's last sample is older than what "
                           "the buffer keeps of the others (its cache_time)")
        pinning = [e for e in dynamic if e.newest == lct]
        for e in dynamic:
            age = ex.now - e.newest
            if age / _NS > max(STALE_PERIODS * (e.period or 0.0), PENDING_MIN):
                kind = "holds back" if e in pinning else "stale"
                detail = (f"the latest common time is its newest sample, {_s(lag)} before now" if e in pinning
                          else _stale_detail(e, age).replace("the asked time", "now"))
                if e.clock_offset is not None and e.clock_offset > tol:
                    detail += f"; {e.publisher} stamps {_s(e.clock_offset * _NS)} behind arrival"
                v.failing.append({"edge": e.label(), "kind": kind, "detail": detail})
        if v.failing:
            v.fixes.append(f"Time(0) answers, but with data {_s(lag)} old: " + "; ".join(
                (f"fix {e.publisher}'s clock or stamps (chrony/NTP)" if e.clock_offset is not None
                 and e.clock_offset > tol else f"make {e.publisher} send edge {e.label()} again")
                for e in dynamic if any(f["edge"] == e.label() for f in v.failing)))
        return v
    stale: list[ChainEdge] = []
    pending: list[tuple[ChainEdge, int]] = []
    for e in dynamic:
        if t > e.newest:
            behind = t - e.newest
            period = e.period or 0.0
            if e.clock_offset is not None and e.clock_offset > tol:
                v.failing.append({"edge": e.label(), "kind": "clock",
                                  "detail": f"{e.publisher} stamps {_s(e.clock_offset * _NS)} behind arrival: its "
                                            "samples for this time arrive that much later"})
                stale.append(e)
            elif behind / _NS > max(STALE_PERIODS * period, PENDING_MIN):
                v.failing.append({"edge": e.label(), "kind": "stale", "detail": _stale_detail(e, behind)})
                stale.append(e)
            else:
                v.failing.append({"edge": e.label(), "kind": "not yet",
                                  "detail": f"the sample for this time is due: newest is {_s(behind)} older"})
                pending.append((e, behind))
        elif t < e.oldest:
            v.failing.append({"edge": e.label(), "kind": "too old",
                              "detail": f"the buffer holds it from {e.oldest / _NS:.3f} on "
                                        f"({_s(e.oldest - t)} after the asked time)"})
    if v.ok:
        v.failing.clear()  # interpolation found data after all (exact stamps)
        return v
    if pending and not stale:
        wait = max(b + round((e.period or 0.0) * _NS) for e, b in pending)
        wait_s = math.ceil(wait / _NS * 100) / 100 * 2
        v.fixes.append(f"wait: add a timeout of {wait_s:.2f} s (lookup_transform(..., timeout=Duration(seconds="
                       f"{wait_s:.2f}))) or look up Time(0)")
    for e in stale:
        if any(f["edge"] == e.label() and f["kind"] == "clock" for f in v.failing):
            v.fixes.append(f"fix {e.publisher}'s clock or stamps (chrony/NTP): edge {e.label()}")
        else:
            v.fixes.append(f"edge {e.label()}: make {e.publisher} send it again (is it running? 'zentf tf doctor' "
                           "says whether it left the graph)")
    if stale:
        v.fixes.append("or look up Time(0) for the latest data every edge has")
    if any(f["kind"] == "too old" for f in v.failing):
        v.fixes.append("the asked time is older than the buffer keeps: look up sooner or give the Buffer a longer "
                       "cache_time")
    return v
