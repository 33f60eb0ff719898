"""joint_state_publisher_gui without Qt: a web page served by the process itself.

One slider per movable joint within its limits (continuous joints: ±π), its live value beside it,
Randomize and Center buttons. The page polls ``GET /state`` and sends ``POST /set`` (JSON). Safe
by default: it listens on 127.0.0.1 only, answers only requests whose Host header is that address
(no DNS rebinding), and changes values only on JSON POSTs (a cross-site form cannot send those).
Whatever a client sends or does, the server answers in one line or closes quietly: a bad value gets
400 with its reason, a client that resets or hangs up costs no traceback, each connection has a
timeout per read and a deadline, and at most MAX_CONNECTIONS are served at once (503 beyond).
"""
from __future__ import annotations

import json
import logging
import socket
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import TYPE_CHECKING, Any

from ..core.ratelimit import RateLimitedLogger

if TYPE_CHECKING:  # the program (joint_state_publisher) imports this module
    from .joint_state_publisher import JointStatePublisher

__all__ = ["JointStateGui", "PAGE", "MAX_CONNECTIONS", "READ_TIMEOUT", "CONNECTION_DEADLINE"]

log = logging.getLogger("zentf.joint_state_gui")
_limited = RateLimitedLogger(log)
_MAX_BODY = 64 * 1024
#: connections served at once (the page keeps one or two; more get 503 and are closed)
MAX_CONNECTIONS = 16
#: seconds a connection may keep the server waiting for its next bytes
READ_TIMEOUT = 5.0
#: seconds any one connection may last, however slowly it keeps sending
CONNECTION_DEADLINE = 20.0
_BUSY = (b"HTTP/1.0 503 Service Unavailable\r\nContent-Type: application/json\r\nContent-Length: 35\r\n"
         b"Connection: close\r\n\r\n{\"error\": \"too many connections\"}\r\n")


class _Server(ThreadingHTTPServer):
    """ThreadingHTTPServer with a bound on connections, a deadline per connection, and quiet errors."""

    daemon_threads = True
    block_on_close = False
    request_queue_size = 64  # the listen backlog (5 by default: a burst of connects waits for SYN retries)

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._active: dict[socket.socket, float] = {}  # connection -> when it was accepted
        self._active_lock = threading.Lock()
        super().__init__(*args, **kwargs)

    def process_request(self, request: Any, client_address: Any) -> None:
        with self._active_lock:
            full = len(self._active) >= MAX_CONNECTIONS
            if not full:
                self._active[request] = time.monotonic()
        if full:
            _limited.log(logging.WARNING, "busy", "slider page: more than %d connections at once; refusing more",
                         MAX_CONNECTIONS)
            try:
                request.setblocking(False)
                request.send(_BUSY)
            except OSError:
                pass
            super().shutdown_request(request)
            return
        super().process_request(request, client_address)

    def shutdown_request(self, request: Any) -> None:
        with self._active_lock:
            self._active.pop(request, None)
        super().shutdown_request(request)

    def service_actions(self) -> None:
        """Between accepts (at least twice a second): end the connections past their deadline."""
        now = time.monotonic()
        with self._active_lock:
            late = [r for r, t in self._active.items() if now - t > CONNECTION_DEADLINE]
        for request in late:
            try:
                request.shutdown(socket.SHUT_RDWR)  # its thread's read or write returns at once
            except OSError:
                pass

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A client that reset, hung up or stalled is no event; anything else is one line, not a traceback."""
        exc = sys.exc_info()[1]
        if isinstance(exc, OSError):  # ConnectionResetError, BrokenPipeError, TimeoutError, shut down
            log.debug("slider page: connection ended: %s", exc)
            return
        _limited.log(logging.WARNING, type(exc).__name__, "slider page: request failed: %s: %s",
                     type(exc).__name__, str(exc))


class JointStateGui:
    """Serves the slider page for a JointStatePublisher until ``close()``."""

    def __init__(self, jsp: "JointStatePublisher", host: str = "127.0.0.1", port: int = 0) -> None:
        self.jsp = jsp
        gui = self

        class Handler(_Handler):
            owner = gui

        self._server = _Server((host, port), Handler)
        self.host, self.port = self._server.server_address[:2]
        self._allowed_hosts = {f"{self.host}:{self.port}", f"localhost:{self.port}"}
        self._thread = threading.Thread(target=self._server.serve_forever, name="joint-state-gui", daemon=True)
        self._thread.start()

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def state(self) -> dict[str, Any]:
        values = self.jsp.values()
        return {"robot": self.jsp.robot.name, "version": self.jsp.version,
                "joints": [{"name": j.name, "type": j.type, "lower": self.jsp.bounds[j.name][0],
                            "upper": self.jsp.bounds[j.name][1], "value": values[j.name]} for j in self.jsp.joints]}

    def close(self) -> None:
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(timeout=2.0)


class _Handler(BaseHTTPRequestHandler):
    owner: JointStateGui
    server_version = "zentf-joint-state-gui"
    timeout = READ_TIMEOUT  # (StreamRequestHandler: the socket's timeout)

    def log_message(self, fmt: str, *args: Any) -> None:  # http.server prints every request otherwise
        log.debug("%s " + fmt, self.address_string(), *args)

    def _host_ok(self) -> bool:
        if self.headers.get("Host", "") in self.owner._allowed_hosts:
            return True
        self._send(403, {"error": "wrong Host header"})
        return False

    def _send(self, code: int, body: Any, ctype: str = "application/json") -> None:
        data = body.encode() if isinstance(body, str) else json.dumps(body).encode()
        self.send_response(code)
        self.send_header("Content-Type", ctype + "; charset=utf-8")
        self.send_header("Content-Length", str(len(data)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.end_headers()
        self.wfile.write(data)

    def do_GET(self) -> None:  # noqa: N802 - http.server's name
        if not self._host_ok():
            return
        path = self.path.split("?", 1)[0]
        if path == "/":
            self._send(200, PAGE, "text/html")
        elif path == "/state":
            self._send(200, self.owner.state())
        else:
            self._send(404, {"error": "not found"})

    def do_POST(self) -> None:  # noqa: N802
        if not self._host_ok():
            return
        if not self.headers.get("Content-Type", "").startswith("application/json"):
            self._send(415, {"error": "send application/json"})
            return
        try:
            n = int(self.headers.get("Content-Length", "0"))
        except ValueError:
            n = -1
        if not 0 <= n <= _MAX_BODY:
            self._send(413, {"error": "body too large"})
            return
        path = self.path.split("?", 1)[0]
        jsp = self.owner.jsp
        try:
            data = self.rfile.read(n)
            if len(data) < n:
                return  # the client hung up mid-body
            body = json.loads(data or b"{}")
            if path == "/set":
                if not isinstance(body, dict):
                    raise ValueError("expected a JSON object {joint: value}")
                jsp.set_values(body)
            elif path == "/center":
                jsp.center()
            elif path == "/randomize":
                jsp.randomize()
            else:
                self._send(404, {"error": "not found"})
                return
        except (KeyError, ValueError) as e:  # (json's errors are ValueErrors)
            text = str(e.args[0]) if isinstance(e, KeyError) and e.args else str(e)
            self._send(400, {"error": text.splitlines()[0] if text.strip() else type(e).__name__})
            return
        except RecursionError:
            self._send(400, {"error": "JSON nested too deeply"})
            return
        self._send(200, self.owner.state())


PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<title>joint_state_publisher</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
 body { font-family: sans-serif; margin: 1em; max-width: 34em; background: #f4f4f4; color: #222; }
 h1 { font-size: 1.1em; margin: 0 0 .8em; }
 .joint { background: #fff; border: 1px solid #ccc; border-radius: 4px; padding: .4em .6em; margin: .4em 0; }
 .row { display: flex; justify-content: space-between; align-items: center; gap: .5em; }
 .name { font-size: .9em; overflow: hidden; text-overflow: ellipsis; }
 .value { width: 6em; text-align: right; font-family: monospace; }
 input[type=range] { width: 100%; }
 .limits { display: flex; justify-content: space-between; font-size: .7em; color: #777; }
 button { width: 100%; padding: .5em; margin: .3em 0; font-size: 1em; }
 #status { font-size: .8em; color: #777; }
</style></head>
<body>
<h1>joint_state_publisher: <span id="robot"></span></h1>
<div id="joints"></div>
<button id="randomize">Randomize</button>
<button id="center">Center</button>
<div id="status">connecting...</div>
<script>
"use strict";
const joints = document.getElementById("joints");
const status = document.getElementById("status");
let version = -1, dragging = null, built = false;

function fmt(v) { return Number(v).toFixed(2); }

async function post(path, body) {
  try {
    const r = await fetch(path, {method: "POST", headers: {"Content-Type": "application/json"},
                                 body: JSON.stringify(body || {})});
    const data = await r.json();
    if (!r.ok) { status.textContent = data.error || r.statusText; return; }
    show(data);
  } catch (e) { status.textContent = "publisher gone (" + e + ")"; }
}

// slider moves: one request in flight at a time, the latest values queued behind it (a fast drag
// does not pile up requests; the last position always arrives)
let inflight = false, queued = null;
function setJoints(values) {
  if (inflight) { queued = Object.assign(queued || {}, values); return; }
  inflight = true;
  post("/set", values).finally(() => {
    inflight = false;
    if (queued) { const q = queued; queued = null; setJoints(q); }
  });
}

function build(state) {
  document.getElementById("robot").textContent = state.robot;
  for (const j of state.joints) {
    const box = document.createElement("div");
    box.className = "joint";
    box.innerHTML = '<div class="row"><span class="name"></span><input class="value" type="number"></div>' +
      '<input type="range"><div class="limits"><span></span><span></span></div>';
    box.querySelector(".name").textContent = j.name;
    const slider = box.querySelector("input[type=range]");
    const value = box.querySelector(".value");
    slider.id = "slider-" + j.name; value.id = "value-" + j.name;
    slider.min = j.lower; slider.max = j.upper; slider.step = (j.upper - j.lower) / 1000;
    value.step = 0.01;
    const lim = box.querySelectorAll(".limits span");
    lim[0].textContent = fmt(j.lower); lim[1].textContent = fmt(j.upper);
    slider.addEventListener("input", () => { dragging = j.name; value.value = fmt(slider.value);
                                             setJoints({[j.name]: Number(slider.value)}); });
    slider.addEventListener("change", () => { dragging = null; });
    value.addEventListener("change", () => setJoints({[j.name]: Number(value.value)}));
    joints.appendChild(box);
  }
  built = true;
}

function show(state) {
  if (!built) build(state);
  version = state.version;
  for (const j of state.joints) {
    const slider = document.getElementById("slider-" + j.name);
    const value = document.getElementById("value-" + j.name);
    if (dragging !== j.name) slider.value = j.value;
    if (document.activeElement !== value) value.value = fmt(j.value);
  }
  status.textContent = state.joints.length + " movable joints, live";
}

async function poll() {
  try {
    const r = await fetch("/state");
    const s = await r.json();
    if (s.version !== version) show(s);
  } catch (e) { status.textContent = "publisher gone (" + e + ")"; }
  setTimeout(poll, 200);
}

document.getElementById("randomize").addEventListener("click", () => post("/randomize"));
document.getElementById("center").addEventListener("click", () => post("/center"));
poll();
</script>
</body></html>
"""
