"""tf2_ros.Buffer: BufferCore plus blocking, asyncio and future-based lookups woken by inserts (no polling)."""
from __future__ import annotations

import asyncio
import concurrent.futures
import heapq
import itertools
import logging
import threading
import time as _time
from typing import Any, Callable, Optional, Union

from ..core.buffer_core import DEFAULT_CACHE_TIME, BufferCore, TimeArg
from ..core.constants import DEFAULT_MAX_FRAME_ID_LENGTH, DEFAULT_MAX_FRAMES
from ..core.messages import TransformStamped
from ..core.time import Duration, to_duration

__all__ = ["Buffer"]

logger = logging.getLogger("zentf.transport.buffer")

TimeoutArg = Union[Duration, float, int, None]


def _timeout_s(timeout: TimeoutArg) -> float:
    if timeout is None:
        return 0.0
    return max(0.0, to_duration(timeout).to_sec())


def _limit_s(timeout: TimeoutArg) -> Optional[float]:
    """Timeout of an async/future wait: None waits for ever (ROS 2's *_async), else seconds >= 0."""
    return None if timeout is None else _timeout_s(timeout)


class _Pending:
    """One async/future wait: ``check()`` after inserts, ``fire(result)`` exactly once."""

    __slots__ = ("check", "fire")

    def __init__(self, check: Callable[[], bool], fire: Callable[[Any], None]) -> None:
        self.check, self.fire = check, fire


class _Deadlines:
    """Timeouts of future-based waits: one thread sleeping until the earliest deadline (started lazily)."""

    def __init__(self) -> None:
        self._heap: list[tuple[float, int, Callable[[], None]]] = []
        self._seq = itertools.count()
        self._cond = threading.Condition()
        self._thread: Optional[threading.Thread] = None
        self._closed = False

    def add(self, delay: float, fn: Callable[[], None]) -> None:
        with self._cond:
            if self._closed:
                return
            heapq.heappush(self._heap, (_time.monotonic() + delay, next(self._seq), fn))
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="zentf-buffer-deadlines", daemon=True)
                self._thread.start()
            self._cond.notify()

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._closed:
                    left = self._heap[0][0] - _time.monotonic() if self._heap else None
                    if left is not None and left <= 0:
                        break
                    self._cond.wait(left)
                if self._closed:
                    return
                fn = heapq.heappop(self._heap)[2]
            try:
                fn()
            except Exception:  # pragma: no cover - fn only resolves futures
                logger.exception("timeout callback failed")

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._heap.clear()
            self._cond.notify()
            thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(5)


class Buffer(BufferCore):
    """Buffer(cache_time=None, node=None, *, max_frames=10000, max_frame_id_length=256): timeouts are
    wall-clock seconds (or Duration); the bounds are BufferCore's (None lifts one).

    A listener (or anything calling set_transform*) fills it from another thread; waiters wake on
    every insert (BufferCore's generation counter, in C: no callback per insert while nobody waits).
    """

    def __init__(self, cache_time: Union[Duration, float, int, None] = None, node: Any = None, *,
                 max_frames: Optional[int] = DEFAULT_MAX_FRAMES,
                 max_frame_id_length: Optional[int] = DEFAULT_MAX_FRAME_ID_LENGTH) -> None:
        super().__init__(DEFAULT_CACHE_TIME if cache_time is None else cache_time, max_frames=max_frames,
                         max_frame_id_length=max_frame_id_length)
        self.node = node
        self._cond = threading.Condition()
        self._waiters = 0
        self._closed = False
        self._pending: set[_Pending] = set()
        self._pending_lock = threading.Lock()
        self._wanted_lock = threading.Lock()  # innermost: taken under _cond or _pending_lock, takes none
        self._deadlines = _Deadlines()

    # Waking waiters: every successful insert bumps BufferCore's C counter ``_generation`` (no Python
    # call per insert); only while ``_wake_wanted`` (blocked waiters + pending async waits) is non-zero
    # does the inserting thread call ``_wake``. A waiter registers before it checks and re-checks the
    # generation inside wait_for, so no wake-up is lost.
    def _update_wanted(self, waiters: int = 0) -> None:
        with self._wanted_lock:
            self._waiters += waiters
            self._wake_wanted = self._waiters + len(self._pending)

    def _wake(self) -> None:
        if self._waiters:
            with self._cond:
                self._cond.notify_all()
        if self._pending:
            self._run_pending()

    def clear(self) -> None:
        super().clear()
        with self._cond:
            self._generation += 1
            self._cond.notify_all()

    def close(self) -> None:
        """Release every blocked, async and future waiter (they report failure)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        with self._pending_lock:
            pending = tuple(self._pending)
        for p in pending:
            self._finish(p, False)
        self._deadlines.close()

    # ------------------------------------------------------------------ async and future waits
    # Each wait registers a check that runs after every insert (BufferCore's wake-up, in
    # the listener's thread) and resolves its future exactly once: True when available, False at
    # its timeout or on close(), the exception if the check raises. Cancelling the future drops
    # the wait. ROS 2's tf2_ros offers the asyncio-style names; the *_future twins are for threads.

    def _run_pending(self) -> None:
        with self._pending_lock:
            todo = tuple(self._pending)
        for p in todo:
            try:
                ok = p.check()
            except Exception as e:  # e.g. an invalid frame name: the waiter gets the error
                self._finish(p, e)
                continue
            if ok:
                self._finish(p, True)

    def _finish(self, p: _Pending, result: Any) -> bool:
        """Resolve p with result unless something resolved or dropped it first."""
        with self._pending_lock:
            if p not in self._pending:
                return False
            self._pending.discard(p)
            self._update_wanted()
        p.fire(result)
        return True

    def _discard(self, p: _Pending) -> None:
        with self._pending_lock:
            self._pending.discard(p)
            self._update_wanted()

    def _add_pending(self, check: Callable[[], bool], fire: Callable[[Any], None]) -> _Pending:
        p = _Pending(check, fire)
        with self._pending_lock:
            self._pending.add(p)
            self._update_wanted()
        if self._closed:
            self._finish(p, False)
            return p
        try:  # checked after registering, so an insert in between is never missed
            ok = check()
        except Exception as e:
            self._finish(p, e)
            return p
        if ok:
            self._finish(p, True)
        return p

    def _wait_async(self, check: Callable[[], bool], timeout: TimeoutArg, what: str) -> "asyncio.Future[bool]":
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            raise RuntimeError(f"{what} needs a running asyncio loop; from a thread use "
                               f"{what.replace('_async', '_future')}") from None
        fut: asyncio.Future[bool] = loop.create_future()

        def settle(result: Any) -> None:  # in the loop
            if not fut.done():
                if isinstance(result, BaseException):
                    fut.set_exception(result)
                else:
                    fut.set_result(result)

        def fire(result: Any) -> None:  # any thread
            try:
                loop.call_soon_threadsafe(settle, result)
            except RuntimeError:  # the loop is closed: nobody is waiting any more
                pass

        p = self._add_pending(check, fire)
        limit = _limit_s(timeout)
        handle = loop.call_later(limit, self._finish, p, False) if limit is not None else None

        def done(_: Any) -> None:
            if handle is not None:
                handle.cancel()
            self._discard(p)

        fut.add_done_callback(done)
        return fut

    def _wait_future(self, check: Callable[[], bool], timeout: TimeoutArg) -> "concurrent.futures.Future[bool]":
        fut: concurrent.futures.Future[bool] = concurrent.futures.Future()

        def fire(result: Any) -> None:
            try:
                if isinstance(result, BaseException):
                    fut.set_exception(result)
                else:
                    fut.set_result(result)
            except concurrent.futures.InvalidStateError:  # cancelled meanwhile
                pass

        p = self._add_pending(check, fire)
        limit = _limit_s(timeout)
        if limit is not None and not fut.done():
            self._deadlines.add(limit, lambda: self._finish(p, False))
        fut.add_done_callback(lambda _: self._discard(p))
        return fut

    def _can_check(self, target_frame: str, source_frame: str, time: TimeArg) -> Callable[[], bool]:
        return lambda: BufferCore.can_transform(self, target_frame, source_frame, time)

    def _can_full_check(self, target_frame: str, target_time: TimeArg, source_frame: str, source_time: TimeArg,
                  fixed_frame: str) -> Callable[[], bool]:
        return lambda: BufferCore.can_transform_full(self, target_frame, target_time, source_frame, source_time,
                                                     fixed_frame)

    def wait_for_transform_async(self, target_frame: str, source_frame: str, time: TimeArg,
                                 timeout: TimeoutArg = None) -> "asyncio.Future[bool]":
        """tf2_ros (ROS 2): an awaitable that gives True once target<-source at time is available.

        ``timeout`` (zentf extra; None waits for ever, as ROS 2) gives False when it passes.
        Call it inside a running asyncio loop; cancelling the future drops the wait.
        """
        return self._wait_async(self._can_check(target_frame, source_frame, time), timeout, "wait_for_transform_async")

    def wait_for_transform_full_async(self, target_frame: str, target_time: TimeArg, source_frame: str,
                                      source_time: TimeArg, fixed_frame: str,
                                      timeout: TimeoutArg = None) -> "asyncio.Future[bool]":
        return self._wait_async(self._can_full_check(target_frame, target_time, source_frame, source_time, fixed_frame),
                                timeout, "wait_for_transform_full_async")

    async def lookup_transform_async(self, target_frame: str, source_frame: str, time: TimeArg,
                                     timeout: TimeoutArg = None) -> TransformStamped:
        """tf2_ros (ROS 2): await the transform; after ``timeout`` the plain lookup raises tf2's error."""
        await self.wait_for_transform_async(target_frame, source_frame, time, timeout)
        return BufferCore.lookup_transform(self, target_frame, source_frame, time)

    async def lookup_transform_full_async(self, target_frame: str, target_time: TimeArg, source_frame: str,
                                          source_time: TimeArg, fixed_frame: str,
                                          timeout: TimeoutArg = None) -> TransformStamped:
        await self.wait_for_transform_full_async(target_frame, target_time, source_frame, source_time,
                                                 fixed_frame, timeout)
        return BufferCore.lookup_transform_full(self, target_frame, target_time, source_frame, source_time,
                                                fixed_frame)

    def wait_for_transform_future(self, target_frame: str, source_frame: str, time: TimeArg,
                                  timeout: TimeoutArg = None) -> "concurrent.futures.Future[bool]":
        """wait_for_transform_async for threads: a concurrent.futures.Future (True, or False at timeout)."""
        return self._wait_future(self._can_check(target_frame, source_frame, time), timeout)

    def wait_for_transform_full_future(self, target_frame: str, target_time: TimeArg, source_frame: str,
                                       source_time: TimeArg, fixed_frame: str,
                                       timeout: TimeoutArg = None) -> "concurrent.futures.Future[bool]":
        return self._wait_future(self._can_full_check(target_frame, target_time, source_frame, source_time, fixed_frame),
                                 timeout)

    def _lookup_future(self, wait: "concurrent.futures.Future[bool]",
                       lookup: Callable[[], TransformStamped]) -> "concurrent.futures.Future[TransformStamped]":
        out: concurrent.futures.Future[TransformStamped] = concurrent.futures.Future()

        def chain(w: "concurrent.futures.Future[bool]") -> None:
            if w.cancelled():
                out.cancel()
                return
            try:
                w.result()
                result = lookup()
            except Exception as e:
                try:
                    out.set_exception(e)
                except concurrent.futures.InvalidStateError:
                    pass
                return
            try:
                out.set_result(result)
            except concurrent.futures.InvalidStateError:
                pass

        out.add_done_callback(lambda o: wait.cancel() if o.cancelled() else None)
        wait.add_done_callback(chain)
        return out

    def lookup_transform_future(self, target_frame: str, source_frame: str, time: TimeArg,
                                timeout: TimeoutArg = None) -> "concurrent.futures.Future[TransformStamped]":
        """lookup_transform_async for threads: the future holds the transform, or tf2's error after timeout."""
        return self._lookup_future(self.wait_for_transform_future(target_frame, source_frame, time, timeout),
                                   lambda: BufferCore.lookup_transform(self, target_frame, source_frame, time))

    def lookup_transform_full_future(self, target_frame: str, target_time: TimeArg, source_frame: str,
                                     source_time: TimeArg, fixed_frame: str,
                                     timeout: TimeoutArg = None) -> "concurrent.futures.Future[TransformStamped]":
        return self._lookup_future(
            self.wait_for_transform_full_future(target_frame, target_time, source_frame, source_time, fixed_frame,
                                                timeout),
            lambda: BufferCore.lookup_transform_full(self, target_frame, target_time, source_frame, source_time,
                                                     fixed_frame))

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
                self._update_wanted(1)
                try:
                    self._cond.wait_for(lambda: self._generation != gen or self._closed, left)
                finally:
                    self._update_wanted(-1)

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
        """A stamped message (any geometry.registered_types()) expressed in target_frame (tf2_ros order of args)."""
        from ..core import geometry  # numpy loads only when transform helpers are used (CLI start-up)

        return geometry.transform(self, object_stamped, target_frame, new_type,
                                  timeout if _timeout_s(timeout) > 0 else None)

    def transform_full(self, object_stamped: Any, target_frame: str, target_time: TimeArg, fixed_frame: str,
                       timeout: TimeoutArg = None, new_type: Any = None) -> Any:
        from ..core import geometry

        return geometry.transform_full(self, object_stamped, target_frame, target_time, fixed_frame, new_type,
                                       timeout if _timeout_s(timeout) > 0 else None)
