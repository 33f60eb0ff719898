"""Services over Zenoh queryables: ``node.create_service`` / ``node.create_client`` (rclpy's API).

A server is a *complete* queryable on the service's key (the resolved service name, exactly as a
topic: ``spawn`` in namespace ``sim`` is key ``sim/spawn``). A call is one Zenoh ``get`` carrying the
request (msgpack, encoding ``application/msgpack;<type>_Request``, attachment = caller node); the
server answers with one ok reply (the response, ``..._Response``) or one error reply (UTF-8 text:
why the request failed, escaped and cut to ERROR_TEXT_LIMIT characters on both sides: it may quote a
payload). The selector's ``deadline_ms`` parameter says how many milliseconds the caller waits, so a
server that would wait for something (the buffer server) stops when its caller has given up. Handlers run on the server node's executor, one at a time, like rclpy's
single-threaded executor. Graph tokens ``@zentf/srv/...`` and ``@zentf/cli/...`` let tools list them.
Details in docs/protocol.md.

Under the ``ros2`` wire profile (``--wire ros2``) services speak rmw_zenoh's service wire instead, so
ROS 2 nodes call zentf's services and the other way round (docs/ros2.md): the key is
``<domain>/<service>/<DDS service type>/<RIHS01 hash>``, payloads are CDR without encoding, the request
carries rmw_zenoh's attachment (sequence number, time, client GID) and the reply the same sequence
number and GID with the server's time; queries target all complete queryables, unconsolidated, and
``SS``/``SC`` liveliness tokens announce servers and clients. A service type zentf has no .srv
definition for cannot travel that way: the server or client is skipped with one warning, the node runs.
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

from .wire import codec as wire
from ..core.messages import Message
from ..core.services import ServiceType
from ..core.text import printable
from .entities import undeclare_all
from ..ros import CdrError, UnknownTypeError
from ..ros import codec as cdr_codec

__all__ = ["Service", "Client", "ServiceException", "ServiceTimeoutError", "ServiceUnavailableError",
           "ERROR_ENCODING", "DEADLINE_PARAMETER", "ERROR_TEXT_LIMIT", "error_text",
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


class Service:
    """A service server: answers each request with ``handler(request, response)``'s return value."""

    def __init__(self, node: Any, name: str, srv_type: type[ServiceType] | str,
                 handler: Callable[..., Any], *, depth: int = DEFAULT_DEPTH) -> None:
        self.node = node
        self.srv_type = _check_srv_type(srv_type)
        self.service_name = name
        self.handler = handler
        self._two_args = _takes_response(handler)
        self._req_type = self.srv_type.Request.TYPE_NAME
        self._resp_enc = wire.encoding_for(self.srv_type.Response.TYPE_NAME)
        self._ros2 = node.wire.name == "ros2"
        self._destroyed = False
        key = _service_key(node, name, self.srv_type, "service")
        #: False when the service could not be offered (no ROS 2 definition under --wire ros2)
        self.active = key is not None
        self.key = key or ""
        self._queryable = self._token = None
        if key is None:
            return
        self._queryable = node.session.declare_queryable(key, self._on_query, complete=True)
        self._token = node._declare_entity("srv", self.srv_type.TYPE_NAME, key, topic=name, depth=depth)
        node.add_on_shutdown(self.destroy)

    def _on_query(self, query: Any) -> None:  # Zenoh thread: copy, hand over to the executor
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            if self._ros2:
                self._on_ros2_query(query, payload)
                return
            enc = str(query.encoding) if query.encoding is not None else ""
            caller = wire.authority_of(query.attachment, "unknown caller")
        except Exception as e:  # pragma: no cover - zenoh gave us something odd
            self._reply_err(query, f"unreadable request: {e}")
            return
        self.node._post(lambda: self._serve(query, payload, enc, caller))

    def _on_ros2_query(self, query: Any, payload: bytes) -> None:
        """rmw_zenoh's request: CDR payload, attachment (sequence number, time, client GID) required."""
        from .wire.profiles import parse_ros2_attachment

        name = self.service_name
        try:
            raw = query.attachment.to_bytes() if query.attachment is not None else b""
            seq, _, gid = parse_ros2_attachment(raw)
        except ValueError as e:
            self.node._bad_input.log(logging.WARNING, ("srv", self.key),
                                     "refused request on service %s: no rmw_zenoh attachment (%s)", name, e)
            self._reply_err(query, f"service {name}: request without rmw_zenoh attachment")
            return
        self.node._post(lambda: self._serve(query, payload, "", f"client {gid.hex()}", (seq, gid)))

    def _serve(self, query: Any, payload: bytes, enc: str, caller: str,
               ros2_id: tuple[int, bytes] | None = None) -> None:
        name = self.service_name
        type_name = wire.type_name_from_encoding(enc)
        if type_name is not None and type_name != self._req_type:
            self._reply_err(query, f"service {name} is {self.srv_type.TYPE_NAME}: "
                                   f"refused a {type_name} request")
            return
        try:
            if ros2_id is not None:
                request = _as_class(cdr_codec.decode(payload, self._req_type), self.srv_type.Request)
            else:
                request = wire.decode(payload, self.srv_type.Request) if payload else self.srv_type.Request()
        except ValueError as e:
            self.node._bad_input.log(logging.WARNING, ("srv", self.key),
                                     "refused bad request on service %s from %s: %s", name, caller, e)
            self._reply_err(query, f"bad request for {self.srv_type.TYPE_NAME}: {e}")
            return
        try:
            response = (self.handler(request, self.srv_type.Response()) if self._two_args
                        else self.handler(request))
            if isinstance(response, dict):
                response = self.srv_type.Response.from_dict(response)
            if not isinstance(response, self.srv_type.Response):
                raise TypeError(f"handler returned {type(response).__name__}, "
                                f"expected {self.srv_type.Response.__name__}")
            out = cdr_codec.encode(response) if ros2_id is not None else wire.encode(response)
        except Exception as e:
            reason = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
            self.node._bad_input.log(logging.WARNING, ("srv-handler", self.key),  # a flood of failing calls
                                     "service %s: handler failed for %s: %s", name, caller, reason)
            self._reply_err(query, f"service {name} failed: {reason}")
            return
        try:
            if ros2_id is not None:  # rmw_zenoh's reply: no encoding; the request's sequence number and GID
                from .wire.profiles import ros2_attachment

                query.reply(query.key_expr, out, attachment=ros2_attachment(ros2_id[0], _time.time_ns(), ros2_id[1]))
            else:
                query.reply(query.key_expr, out, encoding=self._resp_enc)
        except Exception as e:
            log.debug("service %s: reply failed: %s", name, e)
        finally:
            _drop(query)

    def _reply_err(self, query: Any, text: str) -> None:
        try:
            query.reply_err(error_text(text).encode("utf-8"), encoding=ERROR_ENCODING)
        except Exception as e:
            log.debug("service %s: error reply failed: %s", self.service_name, e)
        finally:
            _drop(query)

    def destroy(self) -> None:
        if self._destroyed:
            return
        self._destroyed = True
        undeclare_all((self._queryable, self._token))


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
        import zenoh

        self.node = node
        self.srv_type = _check_srv_type(srv_type)
        self.service_name = name
        self._req_enc = wire.encoding_for(self.srv_type.Request.TYPE_NAME)
        self._resp_type = self.srv_type.Response.TYPE_NAME
        self._attachment = node.get_fully_qualified_name().encode()
        self._ros2 = node.wire.name == "ros2"
        self._destroyed = False
        self._querier = self._token = None
        self._attacher: Any = None
        key = _service_key(node, name, self.srv_type, "client of")
        #: False when the client could not be made (no ROS 2 definition under --wire ros2): calls fail
        self.active = key is not None
        self.key = key or ""
        if key is None:
            return
        if self._ros2:  # rmw_zenoh: every complete queryable, no consolidation, per-client GID and sequence
            self._target = zenoh.QueryTarget.ALL_COMPLETE
            self._consolidation = zenoh.ConsolidationMode.NONE
            self._token, token_key = node._declare_entity("cli", self.srv_type.TYPE_NAME, key, topic=name,
                                                          depth=depth, with_key=True)
            self._attacher = node.wire.attacher(node, token_key)
        else:
            self._target = zenoh.QueryTarget.BEST_MATCHING
            self._consolidation = None
            self._token = node._declare_entity("cli", self.srv_type.TYPE_NAME, key)
        self._querier = node.session.declare_querier(key, target=self._target, consolidation=self._consolidation)
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
        ros2 = self._ros2
        if ros2:
            try:
                payload = cdr_codec.encode(req)
            except CdrError as e:
                raise TypeError(f"service {name}: cannot encode the request: {e}") from None
            attachment = self._attacher()
            seq = int.from_bytes(attachment[:8], "little", signed=True)
        else:
            payload = wire.encode(req)
            attachment = self._attachment
            seq = 0
        limit = _FOREVER if timeout is None else float(timeout)
        started = _time.monotonic()
        resp_cls = self.srv_type.Response
        resp_type = self._resp_type

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
                if ros2:
                    if ok.attachment is not None:  # rmw_zenoh pairs reply and request by the sequence number
                        from .wire.profiles import parse_ros2_attachment

                        got = parse_ros2_attachment(ok.attachment.to_bytes())[0]
                        if got != seq:
                            raise ValueError(f"reply to request {got}, expected {seq}")
                    fut.set_result(_as_class(cdr_codec.decode(ok.payload.to_bytes(), resp_type), resp_cls))
                    return
                enc_type = wire.type_name_from_encoding(str(ok.encoding))
                if enc_type is not None and enc_type != resp_type:
                    raise ValueError(f"response is a {enc_type}, expected {resp_type}")
                fut.set_result(wire.decode(ok.payload.to_bytes(), resp_cls))
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
            if ros2:
                self.node.session.get(self.key, handler, target=self._target, consolidation=self._consolidation,
                                      timeout=limit, payload=payload, attachment=attachment)
            else:  # the selector says when this caller gives up (a server may stop waiting for it then)
                selector = f"{self.key}?{DEADLINE_PARAMETER}={int(limit * 1000)}"
                self.node.session.get(selector, handler, target=self._target, timeout=limit, payload=payload,
                                      encoding=self._req_enc, attachment=attachment)
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


def _as_class(value: Any, cls: type[Message]) -> Any:
    """A decoded CDR value as the service's own class: the codec returns a plain dict for a type that has no
    registered class (one made from its definition, zentf.ros.classes), and handlers and callers get instances."""
    if isinstance(value, dict):
        try:
            return cls.from_dict(cdr_codec.fit_plain(cls, value))
        except (ValueError, TypeError) as e:
            raise CdrError(f"{cls.TYPE_NAME}: {e}") from None
    return value
