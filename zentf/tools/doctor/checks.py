"""The tf doctor's checks: each reads the Evidence and returns Findings (what, evidence, what to do).

The classic ones are roswtf's tf plugin (several authorities of one frame, re-parenting, loops,
stamps far from the receiver's time, unnormalized rotations); the rest use what a Zenoh listener
sees that neither ROS 1 nor ROS 2 did: who sent each sample and when it arrived, the sender's own
clock (Zenoh timestamps, rmw_zenoh attachments), the graph's liveliness.
"""
from __future__ import annotations

import statistics
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from typing import Any, Optional

from .evidence import EdgeStats, Evidence

__all__ = ["Finding", "Thresholds", "Report", "run_checks", "edge_table", "tree_table"]

_NS = 1_000_000_000


@dataclass
class Thresholds:
    """What counts as a problem (seconds unless said otherwise)."""

    clock_tolerance: float = 1.0   # |stamp - arrival| beyond this is a clock problem (roswtf: 1 s)
    dead_periods: float = 5.0      # a frame silent for this many of its own periods is dead...
    dead_min: float = 1.0          # ...and for at least this long
    min_samples: int = 3           # figures from fewer samples are not trusted


@dataclass
class Finding:
    """One problem: ``code`` (stable, for machines), a one-line ``title``, the evidence lines, the advice."""

    code: str
    severity: str                   # "error" or "warning"
    title: str
    evidence: list[str] = field(default_factory=list)
    advice: str = ""
    frames: list[str] = field(default_factory=list)
    publishers: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"code": self.code, "severity": self.severity, "title": self.title, "evidence": list(self.evidence),
                "advice": self.advice, "frames": list(self.frames), "publishers": list(self.publishers)}


@dataclass
class Report:
    """Everything the doctor found: problems, per-edge figures, trees; text and JSON renderings."""

    findings: list[Finding]
    edges: list[dict[str, Any]]
    trees: list[dict[str, Any]]
    messages: int
    duration: float
    source: str                     # "live" or the bag's path
    senders: int

    @property
    def healthy(self) -> bool:
        return not self.findings

    def summary(self) -> str:
        frames = len({e["frame"] for e in self.edges})
        lag = ""
        lags = [t["lct_lag"] for t in self.trees if t.get("lct_lag") is not None]
        if lags:
            worst = max(self.trees, key=lambda t: -1 if t.get("lct_lag") is None else t["lct_lag"])
            lag = (f"; Time(0) between {worst['leaves'][0]} and {worst['leaves'][1]} is "
                   f"{worst['lct_lag'] * 1e3:.0f} ms old")
        where = f"in {self.source}" if self.source != "live" else f"in {self.duration:.1f} s"
        head = (f"tf doctor: {frames} frame(s), {len(self.trees)} tree(s), {self.senders} publisher(s), "
                f"{self.messages} message(s) {where}{lag}")
        if not self.messages:
            return f"tf doctor: no tf data {where}"
        if self.healthy:
            return head + ": no problems found"
        errors = sum(f.severity == "error" for f in self.findings)
        return head + f": {len(self.findings)} problem(s) ({errors} error(s))"

    def text(self, verbose: bool = False) -> str:
        """One section per problem (what, evidence, what to do), then the summary line."""
        out: list[str] = []
        for f in self.findings:
            out.append(f"[{f.severity.upper()}] {f.title}")
            out.extend(f"    {line}" for line in f.evidence)
            if f.advice:
                out.append(f"    -> {f.advice}")
            out.append("")
        if verbose and self.edges:
            out.append(_edge_text(self.edges))
            out.append("")
        out.append(self.summary())
        return "\n".join(out)

    def to_dict(self) -> dict[str, Any]:
        return {"summary": self.summary(), "healthy": self.healthy, "source": self.source,
                "duration": self.duration, "messages": self.messages,
                "findings": [f.to_dict() for f in self.findings], "edges": self.edges, "trees": self.trees}


def _edge_text(edges: list[dict[str, Any]]) -> str:
    rows = [("frame", "parent", "publisher", "topic", "rate_hz", "jitter_ms", "max_gap_ms", "delay_ms", "age_s")]
    for e in edges:
        rows.append((e["frame"], e["parent"], e["publisher"], "tf_static" if e["static"] else "tf",
                     "-" if e["rate"] is None else f"{e['rate']:.1f}",
                     "-" if e["jitter"] is None else f"{e['jitter'] * 1e3:.1f}",
                     f"{e['max_gap'] * 1e3:.0f}",
                     "-" if e["delay"] is None else f"{e['delay'] * 1e3:.1f}",
                     f"{e['age']:.2f}"))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(widths[i]) for i, c in enumerate(r)).rstrip() for r in rows)


def _fmt_s(seconds: float) -> str:
    a = abs(seconds)
    if a >= 1.0:
        return f"{seconds:.2f} s"
    return f"{seconds * 1e3:.0f} ms"


def _rate(e: EdgeStats) -> str:
    r = e.rate
    return "static" if e.static else ("one sample" if r is None else f"{r:.1f} Hz")


def _median(values: Any) -> Optional[float]:
    v = list(values)
    return statistics.median(v) if v else None


# ---------------------------------------------------------------------------------------------
# the checks
# ---------------------------------------------------------------------------------------------

def _who(ev: Evidence, sender: str) -> str:
    return ev.display(sender)


def check_no_data(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    if ev.messages:
        return []
    topics = ", ".join(sorted(ev.topics)) or "the tf topics"
    return [Finding("no_tf_data", "warning", "no tf data received",
                    [f"listened on {topics}: no TFMessage arrived"],
                    "check that something publishes (zentf topic list), the namespace (--namespace), the tf "
                    "topics (--tf-topic, --all-namespaces) and the wire (--wire ros2 for a ROS 2 graph)")]


def check_multiple_publishers(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    """Two or more senders of one child frame on the same topic kind, at the same time."""
    by_child: dict[tuple[str, bool], list[EdgeStats]] = defaultdict(list)
    for e in ev.edges.values():
        by_child[(e.child, e.static)].append(e)
    out = []
    for (child, static), edges in sorted(by_child.items()):
        if len(edges) < 2:
            continue
        edges.sort(key=lambda e: e.first_arrival)
        overlapping = set()
        for i, a in enumerate(edges):
            for b in edges[i + 1:]:
                if static or (a.first_arrival <= b.last_arrival and b.first_arrival <= a.last_arrival
                              and a.samples >= 2 and b.samples >= 2):
                    overlapping.update((a.sender, b.sender))
        if len(overlapping) < 2:
            continue  # one took over from the other: a restart, not contention
        involved = [e for e in edges if e.sender in overlapping]
        names = [_who(ev, e.sender) for e in involved]
        topic = "tf_static" if static else "tf"
        evidence = [f"{_who(ev, e.sender)}: parent {e.parent}, {_rate(e)}, {e.samples} sample(s)" for e in involved]
        parents = {e.parent for e in involved}
        advice = ("keep one publisher of each frame: stop or remap the other node(s); a listener's buffer mixes "
                  "their samples (ROS 1 tf called it 'multiple authority contention')")
        if len(parents) > 1:
            advice += "; they also disagree about the parent, so the tree's shape flips between them"
        out.append(Finding("multiple_publishers", "error",
                           f"frame {child} has {len(involved)} publishers on {topic}: {', '.join(names)}",
                           evidence, advice, [child], [ev.display(e.sender) for e in involved]))
    return out


def check_reparenting(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    """A child frame seen with more than one parent (by one sender over time, or by several)."""
    parents: dict[str, Counter] = defaultdict(Counter)
    by: dict[tuple[str, str], set] = defaultdict(set)
    changes: dict[str, list] = defaultdict(list)
    for e in ev.edges.values():
        for p, n in e.parents.items():
            parents[e.child][p] += n
            by[(e.child, p)].add(e.sender)
        if e.changes:
            changes[e.child].append(e)
    out = []
    for child in sorted(parents):
        if len(parents[child]) < 2:
            continue
        evidence = [f"parent {p}: {n} sample(s) from {', '.join(sorted(ev.display(s) for s in by[(child, p)]))}"
                    for p, n in parents[child].most_common()]
        for e in changes.get(child, []):
            evidence.append(f"{ev.display(e.sender)} changed it {len(e.changes)} time(s), last from "
                            f"{e.changes[-1][1]} to {e.changes[-1][2]}")
        senders = sorted({ev.display(s) for p in parents[child] for s in by[(child, p)]})
        out.append(Finding("reparenting", "error", f"frame {child} changes parent: {', '.join(parents[child])}",
                           evidence, "a frame has one parent: give each publisher's frame its own name, or fix the "
                           "frame_id the publisher sends", [child], senders))
    return out


def check_static_dynamic(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    """A frame sent on both tf_static and tf; a frame whose tf_static value keeps changing."""
    kinds: dict[str, dict[bool, list[EdgeStats]]] = defaultdict(lambda: {True: [], False: []})
    for e in ev.edges.values():
        kinds[e.child][e.static].append(e)
    out = []
    for child in sorted(kinds):
        st, dyn = kinds[child][True], kinds[child][False]
        if st and dyn:
            first_static = min(e.first_arrival for e in st) <= min(e.first_arrival for e in dyn)
            evidence = [f"on tf_static from {_who(ev, e.sender)} (parent {e.parent})" for e in st]
            evidence += [f"on tf from {_who(ev, e.sender)} (parent {e.parent}, {_rate(e)})" for e in dyn]
            evidence.append("a listener keeps the kind it saw first (" + ("static" if first_static else "dynamic")
                            + "): the other publisher's samples " + ("are ignored" if first_static
                                                                     else "age out or fail lookups"))
            names = sorted({ev.display(e.sender) for e in dyn})
            out.append(Finding("static_on_tf", "error",
                               f"static frame {child} is also sent on /tf by {', '.join(names)}",
                               evidence, "send a frame that never moves only on tf_static (StaticTransformBroadcaster, "
                               "static_transform_publisher) and a moving one only on tf",
                               [child], names + sorted({ev.display(e.sender) for e in st})))
        for e in st:
            if e.values_changed and e.samples >= 2:
                out.append(Finding("dynamic_on_tf_static", "warning",
                                   f"frame {child} moves on tf_static ({ev.display(e.sender)})",
                                   [f"{e.samples} samples on tf_static, {e.values_changed} with a different value"],
                                   "tf_static keeps only the last value and no history: publish a moving frame on tf "
                                   "(TransformBroadcaster)", [child], [ev.display(e.sender)]))
    return out


def _sender_gone(ev: Evidence, sender: str) -> Optional[bool]:
    """True/False when the graph says the sender left / is there; None when the graph cannot tell."""
    if not ev.graph.known:
        return None
    if sender in ev.graph.gid_gone:
        return True
    hit = ev.graph.gids.get(sender)
    name = hit[0] if hit is not None else ev.display(sender)
    if hit is None and name not in ev.graph.nodes:
        return None  # never seen in the graph (a sender without a token, or gone before we looked)
    return not ev.graph.alive(name)


def check_dead(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    """Frames that stopped (no sample for several of their own periods) and frames whose publisher left."""
    latest_of: dict[str, int] = {}
    for e in ev.edges.values():
        latest_of[e.child] = max(latest_of.get(e.child, 0), e.last_arrival)
    out = []
    for e in sorted(ev.edges.values(), key=lambda e: (e.child, e.sender)):
        gone = _sender_gone(ev, e.sender)
        name = ev.display(e.sender)
        if e.static:
            if gone:
                out.append(Finding("publisher_left", "warning",
                                   f"static frame {e.child}'s publisher {name} left the graph",
                                   [f"parent {e.parent}; listeners that start from now on will not get it"],
                                   f"restart {name} (static frames are only latched while their publisher lives)",
                                   [e.child], [name]))
            continue
        silent = (now - e.last_arrival) / _NS
        if latest_of[e.child] > e.last_arrival:
            continue  # someone else still publishes this frame
        period = e.period
        limit = max(th.dead_periods * period, th.dead_min) if period is not None else th.dead_min
        stopped = e.samples >= th.min_samples and silent > limit
        if not (stopped or (gone and silent > 0)):
            continue
        evidence = [f"parent {e.parent}; last sample {_fmt_s(silent)} ago"
                    + (f" (it came at {e.rate:.1f} Hz)" if e.rate else "")]
        if gone:
            left = ev.graph.gone_at(name)
            evidence.append(f"its publisher {name} left the graph"
                            + (f" {_fmt_s((now - left) / _NS)} ago" if left and left <= now else ""))
            advice = f"restart {name}; lookups through {e.child} fail once its last sample is older than they ask for"
            title = f"frame {e.child} is dead: its publisher {name} left the graph"
        else:
            if ev.graph.known and gone is not None:
                evidence.append(f"its publisher {name} is still in the graph: it stopped sending {e.child}")
            advice = (f"find out why {name} stopped sending {e.child} (crashed timer, lost input, blocked thread); "
                      "lookups at recent times fail with 'extrapolation into the future'")
            title = f"frame {e.child} is dead: no sample for {_fmt_s(silent)} from {name}"
        out.append(Finding("dead_frame", "error", title, evidence, advice, [e.child], [name]))
    return out


def _parent_map(ev: Evidence) -> dict[str, tuple[str, str]]:
    """child -> (parent, sender) of its most recent sample."""
    best: dict[str, EdgeStats] = {}
    for e in ev.edges.values():
        b = best.get(e.child)
        if b is None or e.last_arrival > b.last_arrival:
            best[e.child] = e
    return {c: (e.parent, e.sender) for c, e in best.items()}


def _roots_and_loops(pm: dict[str, tuple[str, str]]) -> tuple[dict[str, list[str]], list[list[str]]]:
    """(root -> frames under it, loops as frame lists)."""
    root_of: dict[str, str] = {}
    loops: list[list[str]] = []
    in_loop: set[str] = set()
    for start in pm:
        path: list[str] = []
        seen: dict[str, int] = {}
        f = start
        while f in pm and f not in root_of and f not in seen:
            seen[f] = len(path)
            path.append(f)
            f = pm[f][0]
        if f in seen:  # a loop: the frames from where we met it
            loop = path[seen[f]:]
            if not in_loop.intersection(loop):
                loops.append(loop)
                in_loop.update(loop)
            top = "loop:" + min(loop)
        elif f in root_of:
            top = root_of[f]
        else:
            top = f  # a frame nobody parents
        for x in path:
            root_of[x] = top
        root_of.setdefault(f, top)
    trees: dict[str, list[str]] = defaultdict(list)
    for frame, top in root_of.items():
        if not top.startswith("loop:"):
            trees[top].append(frame)
    return {r: sorted(v) for r, v in trees.items()}, loops


def check_tree(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    """More than one root (trees that do not connect), and loops."""
    pm = _parent_map(ev)
    trees, loops = _roots_and_loops(pm)
    out = []
    if len(trees) > 1:
        ordered = sorted(trees.items(), key=lambda kv: (-len(kv[1]), kv[0]))
        evidence = []
        pubs: list[str] = []
        for root, frames in ordered:
            senders = sorted({ev.display(pm[f][1]) for f in frames if f in pm and pm[f][0] == root})
            pubs += senders
            shown = ", ".join(f for f in frames if f != root)[:200]
            evidence.append(f"root {root}: {len(frames)} frame(s) ({shown}); its children come from "
                            f"{', '.join(senders) or '?'}")
        out.append(Finding("multiple_roots", "error",
                           f"{len(trees)} trees do not connect: roots {', '.join(r for r, _ in ordered)}",
                           evidence, "a lookup between frames of different trees fails with 'not part of the same "
                           "tree': publish the transform that joins them (e.g. map -> odom), or fix the "
                           "frame_id of the publisher that started the extra root",
                           [r for r, _ in ordered], sorted(set(pubs))))
    for loop in loops:
        steps = [f"{pm[f][0]} -> {f} by {ev.display(pm[f][1])}" for f in loop]
        names = sorted({ev.display(pm[f][1]) for f in loop})
        out.append(Finding("loop", "error", f"frames {' -> '.join(loop + loop[:1])} form a loop",
                           steps, "every frame has one parent and the parents lead to one root: one of these "
                           "publishers has its frame_id and child_frame_id swapped or names the wrong parent",
                           list(loop), names))
    return out


def check_clock(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    """Senders whose stamps sit persistently ahead of or behind this machine's clock (or /clock)."""
    per: dict[str, list[int]] = defaultdict(list)
    own: dict[str, list[int]] = defaultdict(list)
    transit: dict[str, list[int]] = defaultdict(list)
    for e in ev.edges.values():
        if not e.static:
            per[e.sender].extend(e.delays)
            own[e.sender].extend(e.own_clock)
            transit[e.sender].extend(e.transit)
    medians = {s: statistics.median(v) / _NS for s, v in per.items() if len(v) >= th.min_samples}
    if not medians:
        return []
    floor = min((m for m in medians.values() if m >= 0), default=0.0)
    ref = "/clock (sim time)" if ev.sim_time else "this machine's clock"
    out = []
    for sender, delay in sorted(medians.items()):
        if abs(delay) <= th.clock_tolerance:
            continue
        name = ev.display(sender)
        zid = ev.zid_of(sender)
        where = f" (Zenoh session {zid[:12]})" if zid else ""
        side = "behind" if delay > 0 else "ahead of"
        evidence = [f"median stamp {_fmt_s(abs(delay))} {side} arrival over {len(per[sender])} sample(s); "
                    f"latency floor {_fmt_s(floor)} (the smallest median of any publisher)"]
        stamp_vs_own = _median(own[sender])
        wire = _median(transit[sender])
        if stamp_vs_own is not None and wire is not None:
            evidence.append(f"its stamps are {_fmt_s(stamp_vs_own / _NS)} from its own clock when it sends; "
                            f"its clock reads {_fmt_s(-wire / _NS)} from ours (transit included)")
            if abs(stamp_vs_own) / _NS > th.clock_tolerance:
                cause = ("it stamps with a time that is not its clock's now (old sensor or replayed stamps, "
                         "a fixed offset, sim time without /clock here)")
            else:
                cause = "its clock is not synchronized with this machine's (chrony/NTP)"
        elif ev.sim_time:
            cause = "it does not follow /clock (use_sim_time), or stamps with another time"
        else:
            cause = "its clock is not synchronized (chrony/NTP), or it stamps with a time that is not now"
        if delay > 0:
            advice = (f"fix {name}'s time ({cause}); meanwhile lookups at now() fail with 'extrapolation into the "
                      f"future' unless they wait about {_fmt_s(delay)}: use Time(0) or a timeout")
        else:
            advice = (f"fix {name}'s time ({cause}); zentf's listener refuses stamps more than 5 s ahead "
                      "(TF_FUTURE_DATA) and tf2 keeps the future-dated value as the latest")
        out.append(Finding("clock_offset", "warning",
                           f"publisher {name}{where} stamps {_fmt_s(abs(delay))} {side} {ref}",
                           evidence, advice, sorted({e.child for e in ev.edges.values() if e.sender == sender}),
                           [name]))
    return out


_REFUSAL_ADVICE = {
    "TF_OLD_DATA": "samples older than the buffer's cache time behind the newest of that frame: two publishers of "
                   "one frame, a sender whose clock is behind, or a bag replayed without sim time",
    "TF_REPEATED_DATA": "the same stamp twice for one frame: publishing faster than the stamp changes, a static "
                        "transform re-sent on /tf with one stamp, or two publishers of one frame",
    "TF_FUTURE_DATA": "stamps more than 5 s ahead of this machine: the sender's clock runs ahead (chrony/NTP) or it "
                      "post-dates on purpose (set tf_future_tolerance if so)",
    "TF_NAN_INPUT": "NaN or infinite values: fix the computation that produced them",
    "TF_DENORMALIZED_QUATERNION": "rotations that are not unit quaternions: normalize before sending",
    "TF_SELF_TRANSFORM": "frame_id equals child_frame_id",
    "TF_NO_FRAME_ID": "empty frame_id",
    "TF_NO_CHILD_FRAME_ID": "empty child_frame_id",
}


def check_refusals(ev: Evidence, th: Thresholds, now: int) -> list[Finding]:
    """What a listener's buffer refuses, per reason and sender, with counts."""
    out = []
    for reason, counts in sorted(ev.refusals().items()):
        total = sum(counts.values())
        if not total:
            continue
        evidence = [f"{ev.display(s)}: {n} sample(s)" for s, n in counts.most_common(10)]
        if len(counts) > 10:
            evidence.append(f"... and {len(counts) - 10} more sender(s)")
        out.append(Finding(reason.lower(), "warning",
                           f"{reason}: a listener refused {total} sample(s) from "
                           f"{', '.join(ev.display(s) for s, _ in counts.most_common(3))}",
                           evidence, _REFUSAL_ADVICE.get(reason, "see the sender's messages"), [],
                           [ev.display(s) for s in counts]))
    return out


CHECKS = (check_no_data, check_multiple_publishers, check_static_dynamic, check_reparenting, check_tree,
          check_dead, check_clock, check_refusals)


# ---------------------------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------------------------

def edge_table(ev: Evidence, now: int) -> list[dict[str, Any]]:
    """Per (frame, publisher, topic): rate, jitter, largest gap, median delay, age."""
    out = []
    for e in sorted(ev.edges.values(), key=lambda e: (e.child, e.static, e.sender)):
        d = _median(e.delays)
        out.append({"frame": e.child, "parent": e.parent, "publisher": ev.display(e.sender), "static": e.static,
                    "samples": e.samples, "rate": e.rate, "jitter": e.jitter, "max_gap": e.max_gap,
                    "delay": None if d is None else d / _NS, "age": max(0.0, (now - e.last_arrival) / _NS)})
    return out


def tree_table(ev: Evidence, clock_now: int) -> list[dict[str, Any]]:
    """Per tree: root, frames, and the Time(0) lag between its two most distant leaves."""
    pm = _parent_map(ev)
    trees, _ = _roots_and_loops(pm)
    out = []
    for root, frames in sorted(trees.items(), key=lambda kv: (-len(kv[1]), kv[0])):
        parents = {pm[f][0] for f in frames if f in pm}
        leaves = [f for f in frames if f not in parents][:200]
        depth: dict[str, list[str]] = {}
        for f in leaves:
            chain = [f]
            while chain[-1] in pm and len(chain) <= len(frames):
                chain.append(pm[chain[-1]][0])
            depth[f] = chain
        best: Optional[tuple[int, str, str]] = None
        for i, a in enumerate(leaves):
            for b in leaves[i + 1:]:
                common = set(depth[a])
                k = next((j for j, x in enumerate(depth[b]) if x in common), None)
                if k is None:
                    continue
                dist = k + depth[a].index(depth[b][k])
                if best is None or dist > best[0]:
                    best = (dist, a, b)
        entry: dict[str, Any] = {"root": root, "frames": len(frames), "leaves": None, "lct_lag": None}
        if best is not None:
            entry["leaves"] = [best[1], best[2]]
            try:
                lct = ev.buffer.get_latest_common_time(best[1], best[2]).nanoseconds
                entry["lct_lag"] = (clock_now - lct) / _NS if lct else None
            except Exception:  # noqa: BLE001 - no common time: the lag is unknown
                pass
        out.append(entry)
    return out


def run_checks(ev: Evidence, *, now: int, clock_now: int, thresholds: Optional[Thresholds] = None,
               duration: float = 0.0, source: str = "live") -> Report:
    """Every check on the evidence as of ``now`` (arrival clock) / ``clock_now`` (stamps' clock)."""
    th = thresholds or Thresholds()
    with ev.lock:
        findings: list[Finding] = []
        for check in CHECKS:
            findings.extend(check(ev, th, now))
        order = {"error": 0, "warning": 1}
        findings.sort(key=lambda f: order.get(f.severity, 2))
        return Report(findings, edge_table(ev, now), tree_table(ev, clock_now), ev.messages, duration, source,
                      len(ev.senders))
