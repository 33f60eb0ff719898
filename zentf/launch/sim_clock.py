"""The launcher's sim clock: publishes `/clock` and obeys pause/resume/rate queries on Zenoh.

Control protocol (one Zenoh query, text payload, JSON reply; documented in docs/launch.md):
key `@zentf/clock/control`; payload `status` (or empty), `pause`, `resume`, `rate FACTOR`;
reply `{"time": seconds, "time_ns": int, "rate": float, "paused": bool}` or an error reply text.
"""
from __future__ import annotations

import json
import logging
import math
import os
import threading
import time
from typing import Any

from ..core.time import ns_from_sec
from ..transport.clock import MAX_RATE, MIN_RATE
from .description import ClockSpec

__all__ = ["SimTime", "SimClockPublisher", "CONTROL_KEY", "CLOCK_NODE_PREFIX", "query_clock"]

CONTROL_KEY = "@zentf/clock/control"
#: The clock's hidden node is named this + the launcher's pid: tools find a running clock in the graph by it.
CLOCK_NODE_PREFIX = "_zentf_launch_clock_"
log = logging.getLogger("zentf.launch")


class SimTime:
    """Sim time = anchor + rate x wall time elapsed since the anchor, frozen while paused."""

    def __init__(self, start_ns: int, rate: float = 1.0, paused: bool = False) -> None:
        self._lock = threading.Lock()
        self._anchor_sim = int(start_ns)
        self._anchor_wall = time.monotonic_ns()
        self.rate = float(rate)
        self.paused = bool(paused)

    def now_ns(self) -> int:
        with self._lock:
            return self._now_locked()

    def _now_locked(self) -> int:
        if self.paused:
            return self._anchor_sim
        return self._anchor_sim + int((time.monotonic_ns() - self._anchor_wall) * self.rate)

    def _reanchor(self) -> None:
        self._anchor_sim = self._now_locked()
        self._anchor_wall = time.monotonic_ns()

    def pause(self) -> None:
        with self._lock:
            self._reanchor()
            self.paused = True

    def resume(self) -> None:
        with self._lock:
            self._anchor_wall = time.monotonic_ns()
            self.paused = False

    def set_rate(self, rate: float) -> None:
        if not (isinstance(rate, (int, float)) and MIN_RATE <= rate <= MAX_RATE):
            raise ValueError(f"rate must be between {MIN_RATE:g} and {MAX_RATE:g}, got {rate!r}")
        with self._lock:
            self._reanchor()
            self.rate = float(rate)

    def state(self) -> dict[str, Any]:
        with self._lock:
            now = self._now_locked()
            return {"time": now / 1e9, "time_ns": now, "rate": self.rate, "paused": self.paused}


class SimClockPublisher:
    """Owns a hidden node that publishes `/clock` at `frequency` Hz on the launch's wire (``wire``,
    ``domain_id``: zentf's or ROS 2's) and serves CONTROL_KEY (the launcher's own protocol, on any wire)."""

    def __init__(self, spec: ClockSpec, zenoh_options: Any, *, wire: str = "zentf", domain_id: int = 0) -> None:
        from zentf.core.messages import Clock as ClockMsg
        from zentf.transport.node import Node
        from zentf.transport.options import NodeOptions

        start_ns = time.time_ns() if spec.start is None else ns_from_sec(spec.start, "clock start")
        self.sim = SimTime(start_ns, spec.rate, spec.paused)
        self.period = 1.0 / spec.frequency
        self._msg_type = ClockMsg
        opts = NodeOptions(name=f"{CLOCK_NODE_PREFIX}{os.getpid()}", namespace="", zenoh=zenoh_options, wire=wire,
                           domain_id=domain_id)
        self.node = Node(options=opts, check_unique=False)
        self._pub = self.node.create_publisher("/clock", ClockMsg)
        self._queryable = self.node.session.declare_queryable(CONTROL_KEY, self._on_query)
        self._wake = threading.Event()
        self._stop = False
        self._publish()
        self._thread = threading.Thread(target=self._run, name="zentf-launch-clock", daemon=True)
        self._thread.start()
        log.info("sim clock: /clock from t=%.3f s at %gx, %g Hz%s; control on %s", start_ns / 1e9, spec.rate,
                 spec.frequency, " (paused)" if spec.paused else "", CONTROL_KEY)

    def _publish(self) -> None:
        from zentf.core.time import Time

        self._pub.publish(self._msg_type(clock=Time(nanoseconds=self.sim.now_ns())))

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop:
            next_t += self.period
            delay = next_t - time.monotonic()
            if delay < -self.period:  # fell behind (loaded machine): do not burst to catch up
                next_t = time.monotonic()
                delay = 0.0
            if delay > 0 and self._wake.wait(delay):
                self._wake.clear()
                next_t = time.monotonic()
            if self._stop:
                return
            try:
                self._publish()
            except Exception as e:  # the session is closing, or the network is gone for a moment
                if self._stop:
                    return
                log.debug("publishing /clock failed: %s", e)

    def control(self, command: str) -> dict[str, Any]:
        """Apply one control command (the queryable's payload); ValueError names a bad one."""
        words = command.split()
        if not words or words == ["status"]:
            pass
        elif words == ["pause"]:
            self.sim.pause()
            log.info("sim clock paused at t=%.3f s", self.sim.now_ns() / 1e9)
        elif words == ["resume"]:
            self.sim.resume()
            log.info("sim clock resumed at t=%.3f s", self.sim.now_ns() / 1e9)
        elif words[0] == "rate" and len(words) == 2:
            try:
                rate = float(words[1])
            except ValueError:
                raise ValueError(f"rate must be a number > 0, got {words[1]!r}") from None
            self.sim.set_rate(rate)
            log.info("sim clock rate set to %gx", rate)
        else:
            raise ValueError(f"unknown clock command {command!r} (status, pause, resume, rate FACTOR)")
        self._wake.set()  # publish the new state at once
        return self.sim.state()

    def _on_query(self, query: Any) -> None:  # Zenoh thread
        try:
            command = query.payload.to_string() if query.payload is not None else ""
            state = self.control(command)
            query.reply(query.key_expr, json.dumps(state))
        except ValueError as e:
            query.reply_err(str(e))
        except Exception as e:  # never let a query kill the clock
            try:
                query.reply_err(f"internal error: {e}")
            except Exception:
                pass

    def close(self) -> None:
        self._stop = True
        self._wake.set()
        self._thread.join(timeout=1.0)
        try:
            self._queryable.undeclare()
        except Exception:
            pass
        self.node.shutdown()


def query_clock(session: Any, command: str, timeout: float = 2.0) -> dict[str, Any]:
    """Send one control command to a running launcher's clock; RuntimeError if nobody answers in time."""
    deadline = time.monotonic() + timeout
    errors: list[str] = []
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            break
        for reply in session.get(CONTROL_KEY, payload=command, timeout=min(left, 0.5)):
            if reply.ok is not None:
                return json.loads(reply.ok.payload.to_string())
            errors.append(reply.err.payload.to_string())
        if errors:
            raise ValueError(errors[0])
        # a fresh peer session may not know the launcher yet: ask again until the deadline
        time.sleep(min(0.05, max(0.0, deadline - time.monotonic())))
    raise RuntimeError(f"no sim clock answered on {CONTROL_KEY} within {timeout:g} s "
                       "(is a launch file with a clock: section running on this Zenoh network?)")
