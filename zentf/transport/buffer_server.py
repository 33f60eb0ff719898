"""tf2_ros's BufferServer / BufferClient: one process keeps the tf buffer, others ask it for lookups.

The answer to the field's usual complaint (every Python process deserializes all of ``tf``): a
BufferClient has the Buffer API (``lookup_transform``, ``lookup_transform_full``, ``can_transform``,
``transform``) and subscribes to nothing; each call is one Zenoh query to the server's queryable
``tf2_buffer_server`` (type ``tf2_msgs/action/LookupTransform``; tf2_ros runs it as an action,
zentf as a service, one request and one reply, with no feedback or cancel), on the node's wire like
any service (zentf.transport.service; under ``--wire ros2`` zentf's clients and servers reach each
other, ROS 2's action clients do not). The server answers at once from Zenoh's thread when it can; a
lookup that must wait (``timeout`` > 0) waits on the buffer's insert events in a worker thread, never
polling. A wait never outlives its caller: the call says when its caller gives up (``deadline_ms``,
see ``zentf.transport.service``), a request that does not say is taken to give up after Zenoh's
default query timeout, and the server caps every wait (``max_wait``), so a wait slot held by a client
that left is free again by then. Errors come back as tf2's exception classes with the server's text
(cut and escaped). A client whose server restarts simply reaches the new one.
"""
from __future__ import annotations

import logging
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from ..core.buffer_core import _ns
from ..core.exceptions import (ConnectivityException, ExtrapolationException, InvalidArgumentException,
                              LookupException, TimeoutException, TransformException)
from ..core.messages import TransformStamped
from ..core.services import TF2Error, LookupTransform
from ..core.time import Duration, Time, to_duration
from .service import ERROR_TEXT_LIMIT, ServiceCall, ServiceServer, error_text

__all__ = ["BufferServer", "BufferClient", "DEFAULT_NAME"]

log = logging.getLogger("zentf.transport.buffer_server")

#: tf2_ros's default name of the buffer server.
DEFAULT_NAME = "tf2_buffer_server"
#: Longest wait the server grants a lookup by default (s); ``max_wait`` changes it.
DEFAULT_MAX_WAIT = 60.0
#: How long a caller that did not say when it gives up is taken to wait (s): Zenoh's default query timeout.
UNSTATED_DEADLINE = 10.0
#: A wait ends this much (s) before its caller's deadline, so the answer can still reach it.
_REPLY_MARGIN = 0.02

_CODES: list[tuple[type[Exception], int]] = [
    (LookupException, TF2Error.LOOKUP_ERROR), (ConnectivityException, TF2Error.CONNECTIVITY_ERROR),
    (ExtrapolationException, TF2Error.EXTRAPOLATION_ERROR), (InvalidArgumentException, TF2Error.INVALID_ARGUMENT_ERROR),
    (TimeoutException, TF2Error.TIMEOUT_ERROR), (TransformException, TF2Error.TRANSFORM_ERROR)]
_EXCEPTIONS = {code: cls for cls, code in _CODES}
_Response = LookupTransform.Response


def _code(e: BaseException) -> int:
    for cls, code in _CODES:
        if isinstance(e, cls):
            return code
    return TF2Error.TRANSFORM_ERROR


class BufferServer:
    """Answers LookupTransform queries from ``buffer`` (a Buffer that a TransformListener fills).

    ``max_waiting`` bounds the lookups waiting for data at once (each holds a worker thread); one more
    is answered with a TIMEOUT_ERROR saying the server is busy. A wait lasts the request's ``timeout``,
    but never past its caller's deadline nor ``max_wait`` seconds, so abandoned waits free their slots.
    """

    def __init__(self, buffer: Any, node: Any, ns: str = DEFAULT_NAME, *, max_waiting: int = 64,
                 max_wait: float = DEFAULT_MAX_WAIT) -> None:
        if not 0.0 < max_wait <= 1e6:  # (a float: NaN is refused too)
            raise ValueError(f"max_wait must be within (0, 1e6] seconds, got {max_wait!r}")
        self.buffer = buffer
        self.node = node
        self.name = node.resolve_topic_name(ns)
        self.requests = 0
        self.errors = 0
        self._max_waiting = max_waiting
        self.max_wait = float(max_wait)
        self._waiting = 0
        self._lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_workers=max_waiting, thread_name_prefix="tf2-buffer-server")
        self._closed = False
        self._server = ServiceServer(node, self.name, LookupTransform, self._on_call)
        #: the service's key on the node's wire ('' when the wire cannot carry it)
        self.key = self._server.key
        node.add_on_shutdown(self.destroy)

    def _on_call(self, call: ServiceCall) -> None:
        """Zenoh thread: decode, answer now if possible, else hand the wait to a worker."""
        self.requests += 1
        try:
            carried = call.carried_type
            if carried is not None and carried != LookupTransform.Request.TYPE_NAME:
                raise ValueError(f"{self.name} is {LookupTransform.TYPE_NAME}: refused a {carried} request")
            req = call.decode()
            if req.timeout.nanoseconds < 0:
                raise ValueError(f"timeout must not be negative, got {req.timeout.nanoseconds / 1e9:g} s")
            args = (req.target_frame, req.target_time.nanoseconds, req.source_frame, req.source_time.nanoseconds,
                    req.fixed_frame, req.advanced)
            timeout_ns = req.timeout.nanoseconds
            deadline = call.deadline
        except Exception as e:
            self.errors += 1
            self._reply(call, None, TF2Error.INVALID_ARGUMENT_ERROR, f"bad LookupTransform request: {e}")
            return
        try:
            self._reply(call, self._lookup(*args, 0.0), 0, "")
            return
        except TransformException as e:
            if timeout_ns <= 0:
                self._reply(call, None, _code(e), str(e))
                return
        except Exception as e:  # the buffer refused the arguments (e.g. a type error)
            self._reply(call, None, TF2Error.TRANSFORM_ERROR, f"{type(e).__name__}: {e}")
            return
        with self._lock:
            busy = self._waiting >= self._max_waiting or self._closed
            if not busy:
                self._waiting += 1
        if busy:
            self._reply(call, None, TF2Error.TIMEOUT_ERROR,
                        f"buffer server {self.name} is busy ({self._max_waiting} lookups waiting)")
            return
        left = UNSTATED_DEADLINE if deadline is None else deadline
        self._pool.submit(self._wait_and_reply, call, args,
                          max(0.0, min(timeout_ns / 1e9, left - _REPLY_MARGIN, self.max_wait)))

    def _lookup(self, target: str, tt: int, source: str, st: int, fixed: str, advanced: bool,
                timeout: float) -> TransformStamped:
        if advanced:
            return self.buffer.lookup_transform_full(target, Time(nanoseconds=tt), source, Time(nanoseconds=st),
                                                     fixed, timeout)
        return self.buffer.lookup_transform(target, source, Time(nanoseconds=st), timeout)

    def _wait_and_reply(self, call: ServiceCall, args: tuple, timeout: float) -> None:
        """Worker: the buffer's own event-driven wait (woken by each insert), then the answer."""
        try:
            self._reply(call, self._lookup(*args, timeout), 0, "")
        except TransformException as e:
            self._reply(call, None, _code(e), str(e))
        except Exception as e:
            self._reply(call, None, TF2Error.TRANSFORM_ERROR, f"{type(e).__name__}: {e}")
        finally:
            with self._lock:
                self._waiting -= 1

    def _reply(self, call: ServiceCall, ts: TransformStamped | None, code: int, text: str) -> None:
        resp = _Response(transform=ts) if ts is not None else _Response()
        if code:
            resp.error = TF2Error(code, error_text(text))
        try:
            call.respond(resp)
        except Exception as e:  # a transform the wire cannot encode (say, a huge stamp): tf2's error instead
            call.respond(_Response(error=TF2Error(TF2Error.TRANSFORM_ERROR, f"cannot send the transform: {e}")))

    def destroy(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._server.destroy()
        self._pool.shutdown(wait=False, cancel_futures=True)


class BufferClient:
    """The Buffer API answered by a BufferServer (tf2_ros.BufferClient); subscribes to nothing.

    ``timeout_padding`` (seconds) is added to each lookup's timeout for the network round trip.
    """

    def __init__(self, node: Any, ns: str = DEFAULT_NAME, check_frequency: float | None = None,
                 timeout_padding: float = 2.0) -> None:
        from .service import Client

        self.node = node
        self.timeout_padding = float(timeout_padding)
        self._client = Client(node, node.resolve_topic_name(ns), LookupTransform)
        self.name = self._client.service_name

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """True once a server is reachable (event-driven)."""
        return self._client.wait_for_service(timeout)

    def lookup_transform(self, target_frame: str, source_frame: str, time: Any,
                         timeout: Any = 0.0) -> TransformStamped:
        """target <- source at time; waits up to ``timeout`` on the server for the data."""
        req = LookupTransform.Request(target_frame=target_frame, source_frame=source_frame,
                                      source_time=Time(nanoseconds=_ns(time)), timeout=_duration(timeout))
        return self._call(req)

    def lookup_transform_full(self, target_frame: str, target_time: Any, source_frame: str, source_time: Any,
                              fixed_frame: str, timeout: Any = 0.0) -> TransformStamped:
        req = LookupTransform.Request(target_frame=target_frame, source_frame=source_frame,
                                      source_time=Time(nanoseconds=_ns(source_time)), timeout=_duration(timeout),
                                      target_time=Time(nanoseconds=_ns(target_time)), fixed_frame=fixed_frame,
                                      advanced=True)
        return self._call(req)

    def can_transform(self, target_frame: str, source_frame: str, time: Any, timeout: Any = 0.0,
                      return_debug_tuple: bool = False) -> Any:
        try:
            self.lookup_transform(target_frame, source_frame, time, timeout)
            ok, msg = True, ""
        except TransformException as e:
            ok, msg = False, str(e)
        return (ok, msg) if return_debug_tuple else ok

    def can_transform_full(self, target_frame: str, target_time: Any, source_frame: str, source_time: Any,
                           fixed_frame: str, timeout: Any = 0.0, return_debug_tuple: bool = False) -> Any:
        try:
            self.lookup_transform_full(target_frame, target_time, source_frame, source_time, fixed_frame, timeout)
            ok, msg = True, ""
        except TransformException as e:
            ok, msg = False, str(e)
        return (ok, msg) if return_debug_tuple else ok

    def transform(self, object_stamped: Any, target_frame: str, timeout: Any = None, new_type: Any = None) -> Any:
        """A stamped object expressed in target_frame (the math runs here, the lookup on the server)."""
        from ..core import geometry

        return geometry.transform(self, object_stamped, target_frame, new_type, timeout)

    def transform_full(self, object_stamped: Any, target_frame: str, target_time: Any, fixed_frame: str,
                       timeout: Any = None, new_type: Any = None) -> Any:
        from ..core import geometry

        return geometry.transform_full(self, object_stamped, target_frame, target_time, fixed_frame, new_type,
                                       timeout)

    def _call(self, req: Any) -> TransformStamped:
        from .service import ServiceException

        wait = req.timeout.nanoseconds / 1e9
        if not self._client.service_is_ready() and not self._client.wait_for_service(max(wait, 0.0)):
            raise TimeoutException(f"no buffer server at {self.name} (waited {wait:g} s)")
        try:
            resp = self._client.call(req, timeout=wait + self.timeout_padding)
        except ServiceException as e:
            raise TimeoutException(f"buffer server {self.name}: {e}") from None
        err = resp.error
        if err.error != TF2Error.NO_ERROR:
            raise _EXCEPTIONS.get(err.error, TransformException)(error_text(err.error_string, 4 * ERROR_TEXT_LIMIT))
        return resp.transform

    def destroy(self) -> None:
        self._client.destroy()


def _duration(timeout: Any) -> Duration:
    if timeout is None:
        return Duration()
    d = to_duration(timeout)
    return d if d.nanoseconds > 0 else Duration()
