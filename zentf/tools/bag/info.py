"""``bag_info``: what a recording holds, for every format (rosbag info plus the tf frames)."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from zentf.transport.names import key_to_topic

from .source import TF_TOPICS, open_bag

__all__ = ["bag_info"]


@dataclass
class _Topic:
    key: str
    type_name: str
    count: int = 0
    latched: bool = False
    first: int = 0
    last: int = 0
    senders: set[str] = field(default_factory=set)


def _size(p: Path) -> int:
    if p.is_dir():
        return sum(f.stat().st_size for f in p.iterdir() if f.is_file())
    return p.stat().st_size


def _tf_frames(bag: Any) -> Any:
    """A function payload -> [(parent, child)] for this bag's TFMessages (empty on a bad one)."""
    if bag.ros is None:
        from zentf.transport.wire.codec import unpack

        def zentf_pairs(payload: bytes) -> list[tuple[str, str]]:
            try:
                return [(t["header"]["frame_id"], t["child_frame_id"]) for t in unpack(payload)["transforms"]]
            except (ValueError, KeyError, TypeError):
                return []
        return zentf_pairs
    from .tfdecode import tf_decoder_for

    decode = tf_decoder_for(bag.ros)

    def ros_pairs(payload: bytes) -> list[tuple[str, str]]:
        try:
            return [(r[0], r[1]) for r in decode(payload)]
        except Exception:  # noqa: BLE001 - a bad message shows no frames
            return []
    return ros_pairs


def bag_info(path: str | os.PathLike) -> dict[str, Any]:
    """Format, counts per topic, time span, size, tf frames and any problem, reading the whole bag."""
    bag = open_bag(path)
    topics: dict[str, _Topic] = {}
    frames: dict[str, dict[str, str]] = {"tf": {}, "tf_static": {}}  # child -> parent
    pairs_of = None
    first = last = None
    total = 0
    for m in bag.raw():
        t = topics.get(m.topic)
        if t is None:
            t = topics[m.topic] = _Topic(m.topic, m.type_name, latched=m.latched, first=m.log_time)
        t.count += 1
        if m.log_time < t.first:
            t.first = m.log_time
        if m.log_time > t.last:
            t.last = m.log_time
        if m.sender:
            t.senders.add(m.sender)
        total += 1
        first = m.log_time if first is None or m.log_time < first else first
        last = m.log_time if last is None or m.log_time > last else last
        base = m.topic.rsplit("/", 1)[-1]
        if base in TF_TOPICS and m.type_name == "tf2_msgs/msg/TFMessage":
            if pairs_of is None:
                if bag.ros is not None:
                    bag.ros.ensure_type(m.conn)
                pairs_of = _tf_frames(bag)
            for parent, child in pairs_of(m.payload):
                frames[base][child] = parent
    duration = (last - first) / 1e9 if first is not None and last is not None else 0.0
    all_frames = sorted({f for d in frames.values() for kv in d.items() for f in kv})
    return {
        "path": bag.display, "format": bag.format.value, "encoding": bag.format.encoding,
        "size": _size(bag.path), "messages": total,
        "start": first / 1e9 if first is not None else None, "end": last / 1e9 if last is not None else None,
        "duration": duration, "complete": bag.problem is None, "problem": bag.problem,
        "skipped_chunks": bag.skipped_chunks,
        "topics": [{"key": t.key, "topic": t.key if bag.format.is_ros else key_to_topic(t.key), "type": t.type_name, "count": t.count, "latched": t.latched,
                    "frequency": ((t.count - 1) * 1e9 / (t.last - t.first)
                                  if t.last > t.first and not t.latched else None),
                    "senders": sorted(t.senders)}
                   for t in sorted(topics.values(), key=lambda t: t.key)],
        "frames": all_frames,
        "tf_edges": {k: [[p, c] for c, p in sorted(d.items())] for k, d in frames.items()},
    }
