"""Services over Zenoh queryables: ``node.create_service`` / ``node.create_client`` (rclpy's API).

A server is a *complete* queryable on the service's key; a call is one Zenoh ``get`` carrying the
request; the server answers with one ok reply (the response) or one error reply (UTF-8 text, encoding
``ERROR_ENCODING``: why the request failed, escaped and cut to ERROR_TEXT_LIMIT characters on both sides:
it may quote a payload). Keys, payloads and attachments are the node's wire profile's
(zentf.transport.wire): on zentf's wire the key is the resolved service name (``spawn`` in namespace
``sim`` is ``sim/spawn``), payloads msgpack labelled ``<type>_Request`` / ``_Response``, the request's
attachment the caller's node name (docs/protocol.md); under ``--wire ros2`` they are rmw_zenoh's, so
ROS 2 nodes call zentf's services and the other way round (docs/ros2.md). Where the wire's queries carry
selector parameters (zentf's), ``deadline_ms`` says how many milliseconds the caller waits, so a server
that would wait for something (the buffer server) stops when its caller has given up. Graph tokens
(``srv``, ``cli``) let tools list them. A service type the wire cannot carry (no ROS 2 .srv definition)
is skipped with one warning; the node runs.

``Service`` runs its handler on the node's executor, one call at a time, like rclpy's single-threaded
executor. ``ServiceServer`` is the layer below: its ``on_call`` gets each ``ServiceCall`` on Zenoh's
thread and answers when it can, from any thread (the buffer server answers at once or from a worker).
"""
from __future__ import annotations

import asyncio
import concurrent.futures
import inspect
import logging
import threading
import time as _time
from collections.abc import Callable
from typing import Any

from ..core.messages import Message
from ..core.services import ServiceType
from ..core.text import printable
from .entities import undeclare_all
from ..ros import UnknownTypeError

__all__ = ["Service", "ServiceServer", "ServiceCall", "Client", "ServiceException", "ServiceTimeoutError",
           "ServiceUnavailableError", "ERROR_ENCODING", "DEADLINE_PARAMETER", "ERROR_TEXT_LIMIT", "error_text",
           "received_error_text"]

log = logging.getLogger("zentf.transport.service")

#: Encoding of an error reply: the reason as UTF-8 text.
ERROR_ENCODING = "text/plain;zentf/service_error"
#: Zenoh needs a finite query timeout; "wait forever" is this many seconds (about 11.5 days).
_FOREVER = 1_000_000.0
#: The selector parameter of a call saying in how many milliseconds its caller gives up.
DEADLINE_PARAMETER = "deadline_ms"
#: Most characters of an error reply's text (before escaping): a reason, not a copy of the payload.
ERROR_TEXT_LIMIT = 1000
#: rclpy's default service QoS depth (rmw_qos_profile_services_default), shown in ROS 2 tokens.
DEFAULT_DEPTH = 10


def error_text(text: str, limit: int = ERROR_TEXT_LIMIT) -> str:
    """An error reply's text as it may travel and be shown: control characters escaped, at most ``limit``
    characters of the original (a handler's exception may quote a 100 KB payload), 4 x ``limit`` once
    escaped."""
    out = printable(text, limit)
    return out if len(out) <= 4 * limit else out[:4 * limit - 3] + "..."


def received_error_text(raw: bytes) -> str:
    """The text of an error reply from anyone, as it may be shown (``error_text`` with room for what a
    zentf server already cut and escaped)."""
    return error_text(raw[:16 * ERROR_TEXT_LIMIT].decode("utf-8", "replace"), 4 * ERROR_TEXT_LIMIT)


def _service_key(node: Any, name: str, srv_type: type[ServiceType], role: str) -> str | None:
    """The key of the service under the node's wire profile; None (after one warning per type, rate
    limited) when the ros2 profile has no definition of the type."""
    try:
        return node.wire.service_key(name, srv_type.TYPE_NAME)
    except UnknownTypeError:
        node._bad_input.log(logging.WARNING, ("ros2-no-srv", srv_type.TYPE_NAME),
                            "%s %s skipped: no ROS 2 definition for %s, it cannot travel with --wire ros2",
                            role, name, srv_type.TYPE_NAME)
        return None


class ServiceException(Exception):
    """A service call failed: the server's handler raised or refused the request (rospy's name)."""


class ServiceTimeoutError(ServiceException, TimeoutError):
    """No response within the call's timeout."""


class ServiceUnavailableError(ServiceException):
    """No server answered: none is running, or it went away during the call."""


def _check_srv_type(srv_type: Any) -> type[ServiceType]:
    if isinstance(srv_type, str):
        from ..core.services import service_type

        return service_type(srv_type)
    if not (isinstance(srv_type, type) and issubclass(srv_type, ServiceType)):
        raise TypeError(f"expected a service type such as zentf.core.services.Trigger, got {srv_type!r}")
    return srv_type


def _takes_response(handler: Callable[..., Any]) -> bool:
    """rclpy handlers are ``handler(request, response)``; rospy's ``handler(request)`` works too."""
    try:
        params = list(inspect.signature(handler).parameters.values())
    except (TypeError, ValueError):
        return True
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


class ServiceCall:
    """One request a server received, as it travelled: ``decode()`` reads it, ``respond(response)`` or
    ``fail(reason)`` answers it, once, from any thread (through the node's wire profile)."""

    __slots__ = ("server", "payload", "encoding", "caller", "_query", "_context")

    def __init__(self, server: "ServiceServer", query: Any, payload: bytes, encoding: str, caller: str,
                 context: Any) -> None:
        self.server = server
        self.payload = payload
        self.encoding = encoding
        self.caller = caller  # who sent it, for log lines
        self._query = query
        self._context = context

    @property
    def carried_type(self) -> str | None:
        """The request type the request says it is (where the wire labels payloads), else None."""
        return self.server.node.wire.encoded_type(self.encoding)

    @property
    def deadline(self) -> float | None:
        """Seconds from the request's arrival until its caller gives up (its ``deadline_ms`` parameter), or
        None when it did not say (or said something that is not a count of milliseconds)."""
        try:
            text = self._query.parameters.get(DEADLINE_PARAMETER) if self._query is not None else None
        except Exception:  # noqa: BLE001 - a query without readable parameters says nothing
            return None
        if text is None or not text.isdigit() or len(text) > 12:
            return None
        return int(text) / 1000.0

    def decode(self) -> Message:
        """The request message; ValueError says what was wrong."""
        srv = self.server
        return srv.node.wire.decode_request(self.payload, self.encoding, srv.key, srv.srv_type.Request)

    def respond(self, response: Message) -> None:
        """Answer with a response; an error encoding it is raised and leaves the call open (for ``fail``)."""
        srv = self.server
        wire_profile = srv.node.wire
        resp_type = srv.srv_type.Response.TYPE_NAME
        payload = wire_profile.encode(response, resp_type)
        query, self._query = self._query, None
        if query is None:
            return
        try:
            wire_profile.reply(query, payload, self._context, resp_type)
        except Exception as e:
            log.debug("service %s: reply failed: %s", srv.service_name, e)
        finally:
            _drop(query)

    def fail(self, reason: str) -> None:
        """Answer with an error reply saying why the request failed (the client raises ServiceException)."""
        query, self._query = self._query, None
        if query is not None:
            _reply_err(query, reason)


class ServiceServer:
    """The queryable and graph token of a service under the node's wire profile; ``on_call(ServiceCall)``
    runs on Zenoh's thread (a server that answers at once, or hands the call to a worker). ``active`` is
    False when the wire cannot carry the type (logged once; the node runs)."""

    def __init__(self, node: Any, name: str, srv_type: type[ServiceType] | str,
                 on_call: Callable[[ServiceCall], None], *, depth: int = DEFAULT_DEPTH) -> None:
        self.node = node
        self.srv_type = _check_srv_type(srv_type)
        self.service_name = name
        self._on_call = on_call
        self._destroyed = False
        key = _service_key(node, name, self.srv_type, "service")
        #: False when the service could not be offered (no ROS 2 definition under --wire ros2)
        self.active = key is not None
        self.key = key or ""
        self._queryable = self._token = None
        if key is None:
            return
        self._queryable = node.session.declare_queryable(key, self._on_query, complete=True)
        self._token = node.declare_entity("srv", name, self.srv_type.TYPE_NAME, key=key, depth=depth)
        node.add_on_shutdown(self.destroy)

    def _on_query(self, query: Any) -> None:  # Zenoh thread
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            enc = str(query.encoding) if query.encoding is not None else ""
            try:
                caller, context = self.node.wire.request_caller(query.attachment)
            except ValueError as e:
                self.node._bad_input.log(logging.WARNING, ("srv", self.key), "refused request on service %s: %s",
                                         self.service_name, e)
                _reply_err(query, f"service {self.service_name}: {e}")
                return
        except Exception as e:  # pragma: no cover - zenoh gave us something odd
            _reply_err(query, f"unreadable request: {e}")
            return
        self._on_call(ServiceCall(self, query, payload, enc, caller, context))

    def destroy(self) -> None:
        if self._destroyed:
            return
        self._destroyed = True
        undeclare_all((self._queryable, self._token))


class Service(ServiceServer):
    """A service server: answers each request with ``handler(request, response)``'s return value, on the
    node's executor, one at a time."""

    def __init__(self, node: Any, name: str, srv_type: type[ServiceType] | str,
                 handler: Callable[..., Any], *, depth: int = DEFAULT_DEPTH) -> None:
        self.handler = handler
        self._two_args = _takes_response(handler)
        super().__init__(node, name, srv_type, self._post, depth=depth)

    def _post(self, call: ServiceCall) -> None:  # Zenoh thread: hand over to the executor
        self.node._post(lambda: self._serve(call))

    def _serve(self, call: ServiceCall) -> None:
        name = self.service_name
        carried = call.carried_type
        if carried is not None and carried != self.srv_type.Request.TYPE_NAME:
            call.fail(f"service {name} is {self.srv_type.TYPE_NAME}: refused a {carried} request")
            return
        try:
            request = call.decode()
        except ValueError as e:
            self.node._bad_input.log(logging.WARNING, ("srv", self.key),
                                     "refused bad request on service %s from %s: %s", name, call.caller, e)
            call.fail(f"bad request for {self.srv_type.TYPE_NAME}: {e}")
            return
        try:
            response = (self.handler(request, self.srv_type.Response()) if self._two_args
                        else self.handler(request))
            if isinstance(response, dict):
                response = self.srv_type.Response.from_dict(response)
            if not isinstance(response, self.srv_type.Response):
                raise TypeError(f"handler returned {type(response).__name__}, "
                                f"expected {self.srv_type.Response.__name__}")
            call.respond(response)
        except Exception as e:
            reason = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
            self.node._bad_input.log(logging.WARNING, ("srv-handler", self.key),  # a flood of failing calls
                                     "service %s: handler failed for %s: %s", name, call.caller, reason)
            call.fail(f"service {name} failed: {reason}")


def _reply_err(query: Any, text: str) -> None:
    try:
        query.reply_err(error_text(text).encode("utf-8"), encoding=ERROR_ENCODING)
    except Exception as e:
        log.debug("error reply failed: %s", e)
    finally:
        _drop(query)


def _drop(query: Any) -> None:
    """Finish the query now (the caller's get completes) instead of when Python frees it."""
    try:
        query.drop()
    except Exception:
        pass


class Client:
    """A service client: ``wait_for_service``, ``call`` (blocking) and ``call_async`` (a Future)."""

    def __init__(self, node: Any, name: str, srv_type: type[ServiceType] | str, *,
                 depth: int = DEFAULT_DEPTH) -> None:
        self.node = node
        self.srv_type = _check_srv_type(srv_type)
        self.service_name = name
        profile = node.wire
        enc = profile.encoding(self.srv_type.Request.TYPE_NAME)
        #: the arguments of each query besides payload and attachment: the wire's target, consolidation, encoding
        self._get_options = {**profile.service_query_options(), **({} if enc is None else {"encoding": enc})}
        self._destroyed = False
        self._querier = self._token = None
        self._attacher: Any = None
        key = _service_key(node, name, self.srv_type, "client of")
        #: False when the client could not be made (no ROS 2 definition under --wire ros2): calls fail
        self.active = key is not None
        self.key = key or ""
        if key is None:
            return
        self._token = node.declare_entity("cli", name, self.srv_type.TYPE_NAME, key=key, depth=depth)
        self._attacher = profile.attacher(node, self._token.key)
        self._querier = node.session.declare_querier(key, **profile.service_query_options())
        node.add_on_shutdown(self.destroy)

    def service_is_ready(self) -> bool:
        """True when a server for this name is reachable now."""
        if self._querier is None:
            return False
        try:
            return bool(self._querier.matching_status.matching)
        except Exception:
            return False

    def wait_for_service(self, timeout: float | None = None) -> bool:
        """Block until a server is reachable (event-driven); False after ``timeout`` seconds."""
        if self.service_is_ready():
            return True
        if self._querier is None:
            return False
        ev = threading.Event()
        listener = self._querier.declare_matching_listener(lambda st: st.matching and ev.set())
        try:
            return self.service_is_ready() or ev.wait(timeout)
        finally:
            try:
                listener.undeclare()
            except Exception:
                pass

    def call_async(self, request: Message | dict | None = None,
                   timeout: float | None = None) -> concurrent.futures.Future:
        """Send the request; the Future gets the response or a ServiceException saying why not.

        ``await client.acall(req)`` (or ``asyncio.wrap_future(client.call_async(req))``) in asyncio code.
        """
        import zenoh

        if self._destroyed:
            raise RuntimeError(f"client of {self.service_name} is destroyed")
        if timeout is not None and not timeout > 0:
            raise ValueError(f"timeout must be > 0 seconds, got {timeout!r}")
        req = self._request(request)
        fut: concurrent.futures.Future = concurrent.futures.Future()
        fut.set_running_or_notify_cancel()
        name = self.service_name
        if not self.active:
            fut.set_exception(ServiceUnavailableError(
                f"service {name}: no ROS 2 definition for {self.srv_type.TYPE_NAME} (--wire ros2)"))
            return fut
        profile = self.node.wire
        try:
            payload = profile.encode(req, self.srv_type.Request.TYPE_NAME)
        except (TypeError, ValueError, OverflowError) as e:
            raise TypeError(f"service {name}: cannot encode the request: {e}") from None
        attachment = self._attacher()
        limit = _FOREVER if timeout is None else float(timeout)
        started = _time.monotonic()
        resp_cls = self.srv_type.Response

        def on_reply(reply: Any) -> None:  # Zenoh thread
            if fut.done():
                return
            try:
                ok = reply.ok
                if ok is None:
                    err = reply.err
                    text = received_error_text(err.payload.to_bytes()) if err is not None else ""
                    if err is not None and str(err.encoding) == ERROR_ENCODING:
                        fut.set_exception(ServiceException(text or f"service {name}: error reply"))
                    elif text.strip().lower() == "timeout":  # Zenoh's own reply when the query times out
                        fut.set_exception(ServiceTimeoutError(f"service {name}: no response within {limit:g} s"))
                    else:
                        fut.set_exception(ServiceException(f"service {name}: {text or 'query failed'}"))
                    return
                profile.check_reply(ok.attachment, attachment)
                fut.set_result(profile.decode_response(ok.payload.to_bytes(), ok.encoding, resp_cls))
            except Exception as e:
                if not fut.done():
                    fut.set_exception(ServiceException(f"service {name}: bad response: {e}"))

        def on_done() -> None:  # the query finished: every server answered, left or timed out
            if fut.done():
                return
            waited = _time.monotonic() - started
            if timeout is not None and waited >= 0.9 * limit:
                fut.set_exception(ServiceTimeoutError(f"service {name}: no response within {timeout:g} s"))
            else:
                fut.set_exception(ServiceUnavailableError(
                    f"service {name}: no response (no server is running, or it went away during the call)"))

        try:
            handler = zenoh.handlers.Callback(on_reply, on_done, indirect=False)
            # the selector says when this caller gives up (a server may stop waiting for it then), where
            # the wire's queries carry parameters
            selector = (f"{self.key}?{DEADLINE_PARAMETER}={int(limit * 1000)}"
                        if self.node.wire.query_parameters else self.key)
            self.node.session.get(selector, handler, timeout=limit, payload=payload, attachment=attachment,
                                  **self._get_options)
        except Exception as e:
            fut.set_exception(ServiceException(f"service {name}: query failed: {e}"))
        return fut

    def call(self, request: Message | dict | None = None, timeout: float | None = None) -> Message:
        """Send the request and block for the response; ServiceException (or a subclass) says why not."""
        fut = self.call_async(request, timeout)
        try:
            return fut.result(None if timeout is None else timeout + 5.0)  # Zenoh ends the query first
        except concurrent.futures.TimeoutError:
            raise ServiceTimeoutError(f"service {self.service_name}: no response within {timeout:g} s") from None

    async def acall(self, request: Message | dict | None = None, timeout: float | None = None) -> Message:
        """asyncio form of ``call``."""
        return await asyncio.wrap_future(self.call_async(request, timeout))

    def _request(self, request: Message | dict | None) -> Message:
        cls = self.srv_type.Request
        if request is None:
            return cls()
        if isinstance(request, dict):
            return cls.from_dict(request)
        if not isinstance(request, cls):
            raise TypeError(f"service {self.service_name} takes {cls.__name__}, got {type(request).__name__}")
        return request

    def destroy(self) -> None:
        if self._destroyed:
            return
        self._destroyed = True
        undeclare_all((self._querier, self._token))

