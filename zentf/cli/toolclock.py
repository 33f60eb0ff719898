"""The clock a CLI tool reads ages and delays with: the wall clock, or the graph's ``/clock``.

ROS tools take ``use_sim_time``; a zentf tool does the same with ``--use-sim-time``, and also follows
``/clock`` by itself as soon as one is being published (a ``bag play --clock`` or a launch file's sim
clock): stamps in sim time minus the wall clock are decades, not delays. The tool's node keeps the wall
clock (switching it would clear its listener's buffer, as tf2_ros does on a time jump); only the
figures the tool prints read this clock.
"""
from __future__ import annotations

import threading
import time
from typing import Any, Callable, Optional

__all__ = ["ToolClock", "use_sim_time_option"]


def use_sim_time_option(func: Callable[..., Any]) -> Callable[..., Any]:
    """``--use-sim-time`` of the tools that read clocks (ROS tools' use_sim_time parameter)."""
    import click

    return click.option("--use-sim-time", is_flag=True,
                        help="Ages and delays in /clock time from the start (they switch to it anyway as soon "
                             "as /clock is published).")(func)


class ToolClock:
    """Wall time until ``/clock`` is heard (or from the start with ``use_sim_time``), then the last ``/clock``.

    ``on_switch`` runs once, on the Zenoh/executor thread, when the clock turns from wall to sim time:
    figures gathered against the wall clock are to be dropped then.
    """

    def __init__(self, node: Any, use_sim_time: bool = False,
                 on_switch: Optional[Callable[[], None]] = None) -> None:
        from zentf.core.messages import Clock

        self.forced = bool(use_sim_time)
        self._sim = self.forced
        self._sim_ns: Optional[int] = None
        self._on_switch = on_switch
        self._lock = threading.Lock()
        self._sub = node.create_subscription("/clock", Clock, self._on_clock, qos=1)

    def _on_clock(self, msg: Any) -> None:
        ns = msg.clock.nanoseconds
        with self._lock:
            switched = not self._sim
            self._sim, self._sim_ns = True, ns
        if switched and self._on_switch is not None:
            self._on_switch()

    @property
    def is_sim(self) -> bool:
        return self._sim

    def now_ns(self) -> Optional[int]:
        """Now in this clock's time (ns); None in sim time before the first /clock."""
        if not self._sim:
            return time.time_ns()
        return self._sim_ns

    def label(self) -> str:
        """Which clock the figures are in, for the output's header."""
        if not self._sim:
            return "wall clock (no /clock published)"
        how = "--use-sim-time" if self.forced else "published"
        return f"sim time from /clock ({how})" if self._sim_ns is not None else \
            "sim time from /clock (--use-sim-time; waiting for /clock)"

    def close(self) -> None:
        try:
            self._sub.destroy()
        except Exception:  # noqa: BLE001 - the session may be closing already
            pass
