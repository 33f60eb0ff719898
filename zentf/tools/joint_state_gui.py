"""joint_state_publisher_gui without Qt: a web page served by the process itself.

One slider per movable joint within its limits (continuous joints: ±π), its live value beside it,
Randomize and Center buttons. The page polls ``GET /state`` and sends ``POST /set`` (JSON). Safe
by default: it listens on 127.0.0.1 only, answers only requests whose Host header is that address
(no DNS rebinding), and changes values only on JSON POSTs (a cross-site form cannot send those).
"""
from __future__ import annotations

import json
import logging
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the program (joint_state_publisher) imports this module
    from .joint_state_publisher import JointStatePublisher

__all__ = ["JointStateGui", "PAGE"]

log = logging.getLogger("zentf.joint_state_gui")
_MAX_BODY = 64 * 1024


class JointStateGui:
    """Serves the slider page for a JointStatePublisher until ``close()``."""

    def __init__(self, jsp: "JointStatePublisher", host: str = "127.0.0.1", port: int = 0) -> None:
        self.jsp = jsp
        gui = self

        class Handler(_Handler):
            owner = gui

        self._server = ThreadingHTTPServer((host, port), Handler)
        self._server.daemon_threads = True
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
            body = json.loads(self.rfile.read(n) or b"{}")
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
        except (KeyError, ValueError) as e:
            self._send(400, {"error": str(e.args[0]) if isinstance(e, KeyError) else str(e)})
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
