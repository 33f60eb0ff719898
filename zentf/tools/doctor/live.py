"""The doctor on a live graph: a raw tap on the tf topics and a watch on the graph's liveliness tokens.

``TransformTap`` is the listener-side hook: it hands every TFMessage to a callback with its sender
(zentf: the node name in the attachment; ROS 2: the publisher GID of rmw_zenoh's attachment), its
arrival (monotonic, node clock, wall clock) and the sender's own clock (the Zenoh timestamp, or
rmw_zenoh's source timestamp). It decodes with the wire profile's own decoders, beside (not inside)
the listener's compiled path. ``TfDoctor`` feeds an Evidence from it and from the graph, and answers
``report()`` and ``why()`` at any time: a program may keep one next to its TransformListener and log
``doctor.why(target, source, t).text()`` when a lookup fails.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Optional, Sequence

from .checks import Report, Thresholds, run_checks
from .evidence import Evidence, GraphView, RowCapture
from .why import Explanation, explain_lookup

__all__ = ["TapMessage", "TransformTap", "GraphTap", "TfDoctor"]

TF = "tf2_msgs/msg/TFMessage"


@dataclass
class TapMessage:
    """One TFMessage as the tap saw it."""

    rows: list                      # (parent, child, stamp ns, tx, ty, tz, qx, qy, qz, qw)
    sender: str                     # node name (zentf) or publisher GID hex (ROS 2)
    is_static: bool
    key: str
    arrival_ns: int                 # time.monotonic_ns()
    clock_ns: int                   # the node's clock (wall or sim)
    wall_ns: int                    # time.time_ns()
    source_ns: Optional[int]        # the sender's clock when it sent, if the sample says
    zid: str                        # the sender's Zenoh session, if the sample says
    malformed: int = 0
    problem: Optional[str] = None


def _source_of(sample: Any) -> tuple[Optional[int], str]:
    """(the sender's clock in ns, its Zenoh session id) from a sample's Zenoh timestamp, if it has one."""
    ts = getattr(sample, "timestamp", None)
    if ts is None:
        return None, ""
    try:
        return round(ts.get_time().timestamp() * 1e9), str(ts.get_id())
    except Exception:  # noqa: BLE001
        return None, ""


class TransformTap:
    """Subscribes to tf topics (patterns allowed: '/**/tf') and calls ``on_message(TapMessage)``; never raises
    into Zenoh. ``bad(sender, key, why)`` gets payloads that are not a TFMessage at all."""

    def __init__(self, node: Any, on_message: Callable[[TapMessage], None], *,
                 tf_topics: Sequence[str] = ("tf",), tf_static_topics: Sequence[str] = ("tf_static",),
                 bad: Optional[Callable[[str, str, str], None]] = None) -> None:
        import zenoh.ext as zx

        self.node = node
        self.profile = node.wire
        self.on_message = on_message
        self.bad = bad
        self.keys: list[str] = []
        self._subs: list[Any] = []
        self._clock = node.get_clock()
        try:
            for topics, is_static in ((tf_static_topics, True), (tf_topics, False)):
                for topic in topics:
                    key = node.topic_key(topic, TF)
                    self.keys.append(key)
                    cb = self._callback(is_static)
                    if is_static:
                        self._subs.append(zx.declare_advanced_subscriber(
                            node.session, key, cb, history=zx.HistoryConfig(detect_late_publishers=True)))
                    else:
                        self._subs.append(node.session.declare_subscriber(key, cb))
        except BaseException:
            self.close()
            raise

    def _callback(self, is_static: bool) -> Callable[[Any], None]:
        def on_sample(sample: Any) -> None:
            try:
                self._handle(sample, is_static)
            except Exception:  # noqa: BLE001 - never raise in Zenoh's thread
                pass
        return on_sample

    def _sender(self, sample: Any) -> tuple[str, Optional[int], str]:
        """(sender, source ns, zid)."""
        source, zid = _source_of(sample)
        origin = self.profile.publisher_of(sample.attachment)  # a node name, or a GID the graph resolves
        if origin is None:
            return "unknown sender", source, zid
        return origin[0], (origin[1] or source), zid

    def _handle(self, sample: Any, is_static: bool) -> None:
        arrival, wall = time.monotonic_ns(), time.time_ns()
        clock = self._clock.now().nanoseconds
        key = str(sample.key_expr)
        sender, source, zid = self._sender(sample)
        cap = RowCapture()
        try:
            _, _, malformed, problem = self.profile.ingest_tf(sample.payload.to_bytes(), cap, sender, is_static)
        except ValueError as e:
            if self.bad is not None:
                self.bad(sender, key, str(e))
            return
        self.on_message(TapMessage(cap.rows, sender, is_static, key, arrival, clock, wall, source, zid,
                                   malformed, problem))

    def close(self) -> None:
        from zentf.transport.entities import undeclare_all

        undeclare_all(self._subs)
        self._subs.clear()


class GraphTap:
    """Follows the graph's liveliness tokens into an Evidence's GraphView: nodes coming and going, and
    (ROS 2) the GID of every publisher, computed from its token as rmw_zenoh does."""

    def __init__(self, session: Any, profile: Any, graph: GraphView, lock: Any) -> None:
        import zenoh

        self.graph = graph
        self.lock = lock
        self.profile = profile
        self._put = zenoh.SampleKind.PUT
        graph.known = True
        self._sub = session.liveliness().declare_subscriber(profile.liveliness_selector(None), self._on_token,
                                                            history=True)

    def _on_token(self, sample: Any) -> None:
        try:
            key = str(sample.key_expr)
            e = self.profile.parse_token(key)
            if e is None:
                return
            alive = sample.kind == self._put
            now = time.monotonic_ns()
            g = self.graph
            zid = self.profile.token_session(key)
            with self.lock:
                if e.kind == "node":
                    (g.node_seen(e.node, now, zid) if alive else g.node_gone(e.node, now))
                elif e.kind == "pub" and e.type_name == TF:
                    gid = self.profile.token_publisher(key)  # None where publishers go by their node's name
                    if gid is None:
                        return
                    if alive:
                        g.gids[gid] = (e.node, zid)
                        g.gid_gone.pop(gid, None)
                    elif gid in g.gids:
                        g.gid_gone[gid] = now
        except Exception:  # noqa: BLE001 - never raise in Zenoh's thread
            pass

    def publisher(self, attachment: Any) -> str:
        """The node that sent a sample (a ROS 2 attachment's GID resolved through the tokens), else the
        publisher as the wire names it."""
        try:
            origin = self.profile.publisher_of(attachment)
        except Exception:  # noqa: BLE001 - a foreign attachment
            origin = None
        if origin is None:
            return "unknown sender"
        hit = self.graph.gids.get(origin[0])
        return hit[0] if hit is not None else self.profile.publisher_label(origin[0])

    def close(self) -> None:
        try:
            self._sub.undeclare()
        except Exception:  # noqa: BLE001
            pass


class TfDoctor:
    """Gathers evidence on a node's tf topics and graph; ``report()`` runs the checks, ``why()`` explains
    one lookup. ``close()`` (or a ``with`` block) stops it."""

    def __init__(self, node: Any, *, tf_topics: Sequence[str] = ("tf",),
                 tf_static_topics: Sequence[str] = ("tf_static",), thresholds: Optional[Thresholds] = None,
                 cache_time: float = 10.0, watch_graph: bool = True) -> None:
        sim = node.get_parameter_value("use_sim_time", False)
        self.node = node
        self.thresholds = thresholds or Thresholds()
        self.evidence = Evidence(cache_time=cache_time, sim_time=bool(sim) and str(sim).lower() not in ("0", "false"))
        self.started = time.monotonic()
        self.graph: Optional[GraphTap] = None
        self.tap: Optional[TransformTap] = None
        try:
            if watch_graph:
                self.graph = GraphTap(node.session, node.wire, self.evidence.graph, self.evidence.lock)
            self.tap = TransformTap(node, self._on_message, tf_topics=tf_topics, tf_static_topics=tf_static_topics,
                                    bad=self._on_bad)
        except BaseException:
            self.close()
            raise
        self.evidence.topics.update(self.tap.keys)

    def _on_message(self, m: TapMessage) -> None:
        ev = self.evidence
        ev.add(m.rows, m.sender, m.is_static, arrival_ns=m.arrival_ns, clock_ns=m.clock_ns, wall_ns=m.wall_ns,
               source_ns=m.source_ns, zid=m.zid)
        if m.malformed:
            with ev.lock:
                ev._refusals.counts[("TF_MALFORMED", m.sender)] += m.malformed

    def _on_bad(self, sender: str, key: str, why: str) -> None:
        with self.evidence.lock:
            self.evidence._refusals.counts[("TF_BAD_MESSAGE", sender)] += 1

    def report(self) -> Report:
        """The checks on what was gathered so far."""
        return run_checks(self.evidence, now=time.monotonic_ns(), clock_now=self.node.get_clock().now().nanoseconds,
                          thresholds=self.thresholds, duration=time.monotonic() - self.started)

    def why(self, target: str, source: str, time: Any = None) -> Explanation:
        """explain_lookup on the doctor's own buffer (what a listener started with it would hold)."""
        return explain_lookup(self.evidence.buffer, target, source, time,
                              now=self.node.get_clock().now().nanoseconds, evidence=self.evidence,
                              clock_tolerance=self.thresholds.clock_tolerance)

    def close(self) -> None:
        for part in (self.tap, self.graph):
            if part is not None:
                part.close()

    def __enter__(self) -> "TfDoctor":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
