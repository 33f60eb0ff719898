"""Pure text/DOT renderers for the CLI tools, kept free of Zenoh so they are cheap and unit-testable."""
from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Sequence

from zentf.core.rotation import matrix_from_quaternion, rpy_from_quaternion  # numpy-free: tf echo's start
from zentf.core.text import printable  # names from the network, printed: the one escaping rule

__all__ = [
    "printable", "FrameStat", "NodeDesc", "format_echo",
    "frame_trees", "format_frame_tree", "frames_dot", "node_graph_dot",
    "format_node_graph", "format_hz", "format_stamp", "stats_from_frame_info",
]


def format_stamp(stamp_ns: int) -> str:
    """SEC.NANOSEC with the nanoseconds zero-padded (tf2_echo's unpadded form is ambiguous)."""
    sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
    return f"{sec}.{nsec:09d}"


def _vec(values: Iterable[float], p: int) -> str:
    return "[" + ", ".join(f"{v:.{p}f}" for v in values) + "]"


def format_echo(stamp_ns: int, translation: Sequence[float], rotation: Sequence[float],
                precision: int = 3) -> str:
    """One tf2_echo block: time, translation, quaternion, RPY (rad and deg), 4x4 matrix.

    The RPY is zentf.core.rotation's: tf2's getRPY, except at gimbal lock where tf2's roll is
    rounding noise and this one is the rotation's (docs/cli.md).
    """
    p = max(0, int(precision))
    rpy = rpy_from_quaternion(rotation)
    m = matrix_from_quaternion(rotation)
    width = p + 3
    rows = [m[i] + [translation[i]] for i in range(3)] + [[0.0, 0.0, 0.0, 1.0]]
    lines = [
        f"At time {format_stamp(stamp_ns)}",
        f"- Translation: {_vec(translation, p)}",
        f"- Rotation: in Quaternion (xyzw) {_vec(rotation, p)}",
        f"- Rotation: in RPY (radian) {_vec(rpy, p)}",
        f"- Rotation: in RPY (degree) {_vec((math.degrees(a) for a in rpy), p)}",
        "- Matrix:",
    ]
    lines += ["".join(f" {v:{width}.{p}f}" for v in row) for row in rows]
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# Frame statistics (the content of tf2's allFramesAsYAML) -> tree text and Graphviz DOT.
# --------------------------------------------------------------------------------------------

@dataclass
class FrameStat:
    """One buffered edge PARENT -> CHILD with view_frames' figures."""

    child: str
    parent: str
    broadcaster: str = "no recorded authority"
    rate: float = 0.0
    most_recent: float = 0.0
    oldest: float = 0.0
    buffer_length: float = 0.0
    delay: float | None = None
    static: bool | None = None

    @property
    def is_static(self) -> bool:
        if self.static is not None:
            return self.static
        return self.most_recent == 0.0 and self.oldest == 0.0


def frame_trees(stats: Sequence[FrameStat]) -> list[tuple[str, list[FrameStat]]]:
    """Group edges into trees: [(root, edges in depth-first order)], roots sorted; cycles kept too."""
    by_parent: dict[str, list[FrameStat]] = {}
    children = set()
    for s in stats:
        by_parent.setdefault(s.parent, []).append(s)
        children.add(s.child)
    for lst in by_parent.values():
        lst.sort(key=lambda s: s.child)
    roots = sorted(p for p in by_parent if p not in children)
    seen: set[str] = set()
    trees = []

    def walk(frame: str, acc: list[FrameStat]) -> None:
        for s in by_parent.get(frame, []):
            if s.child in seen:
                continue
            seen.add(s.child)
            acc.append(s)
            walk(s.child, acc)

    for root in roots:
        acc: list[FrameStat] = []
        seen.add(root)
        walk(root, acc)
        trees.append((root, acc))
    # Frames on a loop have no root; show each loop as its own "tree".
    for s in sorted(stats, key=lambda s: s.child):
        if s.child not in seen:
            acc = [s]
            seen.add(s.child)
            walk(s.child, acc)
            trees.append((s.parent, acc))
    return trees


def _edge_summary(s: FrameStat) -> str:
    if s.is_static:
        return f"static, {printable(s.broadcaster)}"
    return f"{s.rate:.1f} Hz, {printable(s.broadcaster)}"


def format_frame_tree(stats: Sequence[FrameStat]) -> str:
    """Indented text tree of every frame tree (view_frames --print)."""
    if not stats:
        return "No tf data received"
    lines: list[str] = []
    by_parent: dict[str, list[FrameStat]] = {}
    for s in stats:
        by_parent.setdefault(s.parent, []).append(s)
    for lst in by_parent.values():
        lst.sort(key=lambda s: s.child)
    trees = frame_trees(stats)
    for i, (root, _) in enumerate(trees):
        if i:
            lines.append("")
        lines.append(printable(root))
        visited = {root}

        def walk(frame: str, prefix: str) -> None:
            kids = [s for s in by_parent.get(frame, []) if s.child not in visited]
            for k, s in enumerate(kids):
                last = k == len(kids) - 1
                visited.add(s.child)
                lines.append(f"{prefix}{'└── ' if last else '├── '}{printable(s.child)}  ({_edge_summary(s)})")
                walk(s.child, prefix + ("    " if last else "│   "))

        walk(root, "")
    return "\n".join(lines)


def _esc(text: str) -> str:
    return printable(text).replace("\\", "\\\\").replace('"', '\\"')


def _q(name: str) -> str:
    return '"' + _esc(name) + '"'


_TREE_COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"]


def frames_dot(stats: Sequence[FrameStat], recorded_at: float | None = None, clock: str = "") -> str:
    """view_frames DOT: one cluster per disconnected tree, every edge labelled with its figures; ``clock``
    names the clock of the recording time and the ages."""
    if not stats:
        return 'digraph G {\n  "No tf data received";\n}\n'
    out = ["digraph G {", "  rankdir=TB;", '  node [shape=ellipse, fontname="Helvetica"];',
           '  edge [fontname="Helvetica", fontsize=10];']
    trees = frame_trees(stats)
    for i, (root, edges) in enumerate(trees):
        colour = _TREE_COLOURS[i % len(_TREE_COLOURS)]
        frames = [root] + [e.child for e in edges]
        out.append(f"  subgraph cluster_{i} {{")
        label = f"tree {i + 1}: root {root}" if len(trees) > 1 else f"root {root}"
        out.append(f'    label={_q(label)}; style="rounded,dashed"; color="{colour}"; fontcolor="{colour}";')
        for f in frames:
            out.append(f'    {_q(f)} [color="{colour}"];')
        out.append("  }")
        for e in edges:
            if e.is_static:
                recent = "Most recent transform: 0.000 (static)"
            elif recorded_at is not None:
                recent = f"Most recent transform: {e.most_recent:.3f} ( {recorded_at - e.most_recent:.3f} sec old)"
            else:
                recent = f"Most recent transform: {e.most_recent:.3f}"
            label = (f"Broadcaster: {_esc(e.broadcaster)}\\nAverage rate: {e.rate:.3f} Hz\\n{recent}\\n"
                     f"Oldest transform: {e.oldest:.3f}\\nBuffer length: {e.buffer_length:.3f} sec\\n")
            out.append(f'  {_q(e.parent)} -> {_q(e.child)} [label="{label}", color="{colour}"];')
    if recorded_at is not None or clock:
        out.append("  subgraph cluster_legend {")
        out.append('    style=bold; color=black; label="view_frames Result";')
        if recorded_at is not None:
            out.append(f'    "Recorded at time: {recorded_at:.3f}" [shape=plaintext];')
        if clock:
            out.append(f'    {_q("Clock: " + clock)} [shape=plaintext];')
        out.append("  }")
    out.append("}")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------------------
# Node <-> topic graph (rqt_graph).
# --------------------------------------------------------------------------------------------

@dataclass
class NodeDesc:
    """A live node as seen through liveliness: full name and its topics (name -> type)."""

    name: str
    publications: dict[str, str] = field(default_factory=dict)
    subscriptions: dict[str, str] = field(default_factory=dict)


def node_graph_dot(nodes: Sequence[NodeDesc]) -> str:
    """rqt_graph-style DOT: nodes are ellipses, topics boxes; node -> topic -> node."""
    out = ["digraph zentf_graph {", "  rankdir=LR;", '  node [fontname="Helvetica"];']
    topics: dict[str, str] = {}
    for n in nodes:
        topics.update(n.publications)
        topics.update(n.subscriptions)
    for n in sorted(nodes, key=lambda n: n.name):
        out.append(f"  {_q('n:' + n.name)} [label={_q(n.name)}, shape=ellipse, color=\"#1f77b4\"];")
    for t in sorted(topics):
        out.append(f"  {_q('t:' + t)} [label={_q(t)}, shape=box, color=\"#2ca02c\"];")
    for n in sorted(nodes, key=lambda n: n.name):
        for t in sorted(n.publications):
            out.append(f"  {_q('n:' + n.name)} -> {_q('t:' + t)};")
        for t in sorted(n.subscriptions):
            out.append(f"  {_q('t:' + t)} -> {_q('n:' + n.name)};")
    out.append("}")
    return "\n".join(out) + "\n"


def format_node_graph(nodes: Sequence[NodeDesc]) -> str:
    """Text listing of the node graph: one line per edge, 'node -> topic' / 'topic -> node'."""
    if not nodes:
        return "No nodes found"
    lines = []
    p = printable
    for n in sorted(nodes, key=lambda n: n.name):
        lines.append(p(n.name))
        for t in sorted(n.publications):
            lines.append(f"  -> {p(t)} [{p(n.publications[t])}]" if n.publications[t] else f"  -> {p(t)}")
        for t in sorted(n.subscriptions):
            lines.append(f"  <- {p(t)} [{p(n.subscriptions[t])}]" if n.subscriptions[t] else f"  <- {p(t)}")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# topic hz
# --------------------------------------------------------------------------------------------

def format_hz(arrivals: Sequence[float]) -> str | None:
    """ros2 topic hz block for arrival times (s); None until two messages have arrived."""
    if len(arrivals) < 2:
        return None
    deltas = [b - a for a, b in zip(arrivals, arrivals[1:])]
    mean = sum(deltas) / len(deltas)
    rate = 1.0 / mean if mean > 0 else float("inf")
    std = statistics.pstdev(deltas) if len(deltas) > 1 else 0.0
    return (f"average rate: {rate:.3f}\n"
            f"\tmin: {min(deltas):.3f}s max: {max(deltas):.3f}s std dev: {std:.5f}s window: {len(arrivals)}")


def _sec(t: Any) -> float:
    return t.nanoseconds / 1e9


def stats_from_frame_info(infos: Iterable[Mapping]) -> list[FrameStat]:
    """FrameStats from BufferCore.frame_info() dicts (Time stamps, explicit static flag)."""
    out = []
    for d in infos:
        newest, oldest = _sec(d.get("most_recent_transform", 0.0)), _sec(d.get("oldest_transform", 0.0))
        out.append(FrameStat(
            child=str(d["frame"]), parent=str(d.get("parent", "")),
            broadcaster=str(d.get("broadcaster", "no recorded authority")), rate=float(d.get("rate", 0.0)),
            most_recent=newest, oldest=oldest, buffer_length=newest - oldest,
            static=bool(d["static"]) if "static" in d else None))
    return out
