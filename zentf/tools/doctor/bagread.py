"""The doctor on a recording: every /tf and /tf_static message of a bag with its sender and log time.

A bag's log time is when the recorder received the message, so it stands in for the arrival time (and
the end of the recording for "now"). zentf bags and ROS 1 bags name each message's sender (the node
name, the caller id); rosbag2 bags do not, so their publishers cannot be told apart there.
"""
from __future__ import annotations

import os
from typing import Callable, Optional

from .checks import Report, Thresholds, run_checks
from .evidence import Evidence, RowCapture

__all__ = ["evidence_from_bag", "diagnose_bag"]

_NS = 1_000_000_000


def _is_tf(topic: str) -> Optional[bool]:
    """True for tf_static, False for tf, None for any other topic."""
    last = topic.rstrip("/").rsplit("/", 1)[-1]
    return True if last == "tf_static" else False if last == "tf" else None


def evidence_from_bag(path: str | os.PathLike, *, start: Optional[float] = None, end: Optional[float] = None,
                      cache_time: float = 10.0, on_problem: Optional[Callable[[str], None]] = None) -> Evidence:
    """An Evidence of the bag's transform messages logged in [start, end] (seconds; None: open)."""
    from zentf.tools.bag import open_bag
    from zentf.tools.bag.tfdecode import TF_TYPE, tf_decoder_for
    from zentf.transport.wire.codec import ingest_tf

    lo = None if start is None else round(start * _NS)
    hi = None if end is None else round(end * _NS)
    bag = open_bag(path)
    ev = Evidence(cache_time=cache_time)
    ev.graph.known = False

    def inside(t: int) -> bool:
        return (lo is None or t >= lo) and (hi is None or t <= hi)

    if bag.ros is None:
        for m in bag.raw():
            kind = _is_tf(m.topic)
            if kind is None or not inside(m.log_time):
                continue
            cap = RowCapture()
            sender = m.sender or "unknown sender"
            try:
                _, _, malformed, _ = ingest_tf(m.payload, cap, sender, kind)
            except ValueError:
                with ev.lock:
                    ev._refusals.counts[("TF_BAD_MESSAGE", sender)] += 1
                continue
            ev.add(cap.rows, sender, kind, arrival_ns=m.log_time, topic=m.topic)
            if malformed:
                with ev.lock:
                    ev._refusals.counts[("TF_MALFORMED", sender)] += malformed
    else:
        ros = bag.ros
        decode = tf_decoder_for(ros)
        refused: set[int] = set()
        for conn, t, raw in ros.messages():
            kind = _is_tf(conn.topic)
            if kind is None or not inside(t) or id(conn) in refused:
                continue
            why = None if conn.msgtype == TF_TYPE else f"type {conn.msgtype} is not {TF_TYPE}"
            if why is None and ros.ros1:
                why = ros.ensure_type(conn)
            if why:
                refused.add(id(conn))
                if on_problem is not None:
                    on_problem(f"{bag.display}: {conn.topic}: {why}; skipped")
                continue
            sender = conn.callerid or "unknown sender"
            try:
                rows = decode(raw)
            except Exception:  # noqa: BLE001 - one bad message costs itself
                with ev.lock:
                    ev._refusals.counts[("TF_BAD_MESSAGE", sender)] += 1
                continue
            ev.add(rows, sender, kind, arrival_ns=t, topic=conn.topic)
        bag.problem, bag.skipped_chunks = ros.problem, ros.skipped_chunks
    if bag.problem and on_problem is not None:
        on_problem(f"{bag.display}: {bag.problem}; read the readable part")
    return ev


def diagnose_bag(path: str | os.PathLike, *, start: Optional[float] = None, end: Optional[float] = None,
                 thresholds: Optional[Thresholds] = None,
                 on_problem: Optional[Callable[[str], None]] = None) -> Report:
    """The doctor's report on a recording; "now" is the last transform message's log time."""
    ev = evidence_from_bag(path, start=start, end=end, on_problem=on_problem)
    now = ev.last_arrival
    return run_checks(ev, now=now, clock_now=now, thresholds=thresholds,
                      duration=(ev.last_arrival - ev.first_arrival) / _NS, source=os.fspath(path))
