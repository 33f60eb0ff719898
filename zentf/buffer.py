"""tf2_ros.Buffer: BufferCore plus blocking lookups that wake when data arrives (no polling)."""
from __future__ import annotations

import threading
import time as _time
from typing import Any, Optional, Union

from .core.buffer_core import DEFAULT_CACHE_TIME, BufferCore, TimeArg
from .core.constants import DEFAULT_MAX_FRAME_ID_LENGTH, DEFAULT_MAX_FRAMES
from .core.messages import TransformStamped
from .core.time import Duration, to_duration

__all__ = ["Buffer"]

TimeoutArg = Union[Duration, float, int, None]


def _timeout_s(timeout: TimeoutArg) -> float:
    if timeout is None:
        return 0.0
    return max(0.0, to_duration(timeout).to_sec())


class Buffer(BufferCore):
    """Buffer(cache_time=None, node=None, *, max_frames=10000, max_frame_id_length=256): timeouts are
    wall-clock seconds (or Duration); the bounds are BufferCore's (None lifts one).

    A listener (or anything calling set_transform*) fills it from another thread; waiters wake on
    every insert through BufferCore's insert callbacks.
    """

    def __init__(self, cache_time: Union[Duration, float, int, None] = None, node: Any = None, *,
                 max_frames: Optional[int] = DEFAULT_MAX_FRAMES,
                 max_frame_id_length: Optional[int] = DEFAULT_MAX_FRAME_ID_LENGTH) -> None:
        super().__init__(DEFAULT_CACHE_TIME if cache_time is None else cache_time, max_frames=max_frames,
                         max_frame_id_length=max_frame_id_length)
        self.node = node
        self._cond = threading.Condition()
        self._generation = 0
        self._waiters = 0
        self._closed = False
        self.add_insert_callback(self._wake)

    def _wake(self) -> None:
        # Hot path (every inserted message): lock-free unless someone waits. A waiter reads the
        # generation before checking and re-checks it inside wait_for, so no wake-up is lost.
        self._generation += 1
        if self._waiters:
            with self._cond:
                self._cond.notify_all()

    def clear(self) -> None:
        super().clear()
        with self._cond:
            self._generation += 1
            self._cond.notify_all()

    def close(self) -> None:
        """Release every blocked waiter (they report failure)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def _wait_until(self, check: Any, timeout: TimeoutArg) -> tuple[bool, str]:
        """Run ``check() -> (ok, msg)`` now and after each insert until ok or the timeout passes."""
        limit = _timeout_s(timeout)
        deadline = _time.monotonic() + limit
        while True:
            with self._cond:
                gen = self._generation
            ok, msg = check()
            if ok or limit <= 0:
                return ok, msg
            left = deadline - _time.monotonic()
            if left <= 0 or self._closed:
                return False, (msg + (". " if msg else "") +
                               f"canTransform returned after {limit - max(left, 0.0):.6f} timeout was {limit:.6f}.")
            with self._cond:
                self._waiters += 1
                try:
                    self._cond.wait_for(lambda: self._generation != gen or self._closed, left)
                finally:
                    self._waiters -= 1

    def wait_for(self, predicate: Any, timeout: TimeoutArg) -> bool:
        """Block until ``predicate()`` is true, re-checking after every insert (or the timeout passes)."""
        def check() -> tuple[bool, str]:
            try:
                return bool(predicate()), ""
            except Exception:  # e.g. a lookup that cannot succeed yet
                return False, ""

        return self._wait_until(check, timeout)[0]

    def can_transform(self, target_frame: str, source_frame: str, time: TimeArg,  # type: ignore[override]
                      timeout: TimeoutArg = None, return_debug_tuple: bool = False) -> Any:
        """True once target<-source at time is available, waiting up to ``timeout`` for it."""
        ok, msg = self._wait_until(
            lambda: BufferCore.can_transform(self, target_frame, source_frame, time, True), timeout)
        return (ok, msg) if return_debug_tuple else ok

    def can_transform_full(self, target_frame: str, target_time: TimeArg, source_frame: str,  # type: ignore[override]
                           source_time: TimeArg, fixed_frame: str, timeout: TimeoutArg = None,
                           return_debug_tuple: bool = False) -> Any:
        ok, msg = self._wait_until(
            lambda: BufferCore.can_transform_full(self, target_frame, target_time, source_frame, source_time,
                                                  fixed_frame, True), timeout)
        return (ok, msg) if return_debug_tuple else ok

    def lookup_transform(self, target_frame: str, source_frame: str, time: TimeArg,  # type: ignore[override]
                         timeout: TimeoutArg = None) -> TransformStamped:
        """tf2_ros: wait (can_transform with timeout), then the plain lookup raises the real error."""
        if _timeout_s(timeout) > 0:
            self.can_transform(target_frame, source_frame, time, timeout)
        return BufferCore.lookup_transform(self, target_frame, source_frame, time)

    def lookup_transform_full(self, target_frame: str, target_time: TimeArg, source_frame: str,  # type: ignore[override]
                              source_time: TimeArg, fixed_frame: str, timeout: TimeoutArg = None) -> TransformStamped:
        if _timeout_s(timeout) > 0:
            self.can_transform_full(target_frame, target_time, source_frame, source_time, fixed_frame, timeout)
        return BufferCore.lookup_transform_full(self, target_frame, target_time, source_frame, source_time,
                                                fixed_frame)

    def transform(self, object_stamped: Any, target_frame: str, timeout: TimeoutArg = None,
                  new_type: Any = None) -> Any:
        """A PointStamped/Vector3Stamped/PoseStamped expressed in target_frame (tf2_ros order of args)."""
        from .core import geometry  # numpy loads only when transform helpers are used (CLI start-up)

        return geometry.transform(self, object_stamped, target_frame, new_type,
                                  timeout if _timeout_s(timeout) > 0 else None)

    def transform_full(self, object_stamped: Any, target_frame: str, target_time: TimeArg, fixed_frame: str,
                       timeout: TimeoutArg = None, new_type: Any = None) -> Any:
        from .core import geometry

        return geometry.transform_full(self, object_stamped, target_frame, target_time, fixed_frame, new_type,
                                       timeout if _timeout_s(timeout) > 0 else None)
