"""`zentf view`: the live 3D view (frames, markers, points) in Rerun: native window, browser or .rrd file."""
from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any, Optional
from urllib.parse import quote

import click

from .bag import _stop_on_signals
from .common import CONTEXT_SETTINGS, CliError, CliOptions, finite_float, node_options, with_options
from .tf_topics import TfToolCommand, TfTopics, tf_topic_options

__all__ = ["view"]


@click.command("view", cls=TfToolCommand, context_settings=CONTEXT_SETTINGS)
@click.option("--fixed-frame", "-f", default=None,
              help="Frame the scene is drawn in, like RViz's Fixed Frame [default: world, map or odom if there, "
                   "else the root of the largest tree].")
@click.option("--labels/--no-labels", "labels", default=None,
              help="Draw frame names [default: while at most 30 frames are shown].")
@click.option("--web", is_flag=True, help="Serve the web viewer (open the printed URL in a browser).")
@click.option("--web-port", type=click.IntRange(1, 65535), default=9090, show_default=True)
@click.option("--grpc-port", type=click.IntRange(1, 65535), default=9876, show_default=True,
              help="Port of the Rerun data server the web viewer connects to.")
@click.option("--bind", default="127.0.0.1", show_default=True, help="Address the --web servers listen on.")
@click.option("--save", "save", type=click.Path(dir_okay=False, writable=True), default=None,
              help="Write the recording to this .rrd file (open later with `rerun FILE.rrd`).")
@click.option("--rate", type=finite_float(min=0.5, max=200), default=20.0, show_default=True,
              help="Scene refreshes per second.")
@click.option("--axis-length", type=finite_float(min=0.0, min_open=True), default=0.3, show_default=True)
@click.option("--duration", type=finite_float(min=0.0, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@click.option("--use-sim-time", is_flag=True, help="Time line from /clock (e.g. with `zentf bag play --clock`).")
@click.option("--robot-description", default="robot_description", show_default=True, metavar="TOPIC",
              help="Draw the robot model (URDF text) latched on this topic; '' to draw none.")
@click.option("--frame-prefix", default="", metavar="PREFIX", help="The robot's frames are PREFIX + link name.")
@tf_topic_options
@with_options
def view(fixed_frame: Optional[str], labels: Optional[bool], web: bool, web_port: int, grpc_port: int, bind: str, save: Optional[str], rate: float,
         axis_length: float, duration: Optional[float], use_sim_time: bool, robot_description: str,
         frame_prefix: str, *, tf_topics: TfTopics, opts: CliOptions) -> None:
    """Live 3D view of every tf frame (axes + names), marker arrays, points and the robot model, like RViz."""
    from zentf.tools.view import require_rerun

    try:
        rr = require_rerun()
    except ImportError as exc:
        raise CliError(str(exc)) from exc
    if not web and not save and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise CliError("no display for the native viewer: use --web (browser) or --save FILE.rrd", code=2)

    from zentf.transport.node import Node
    from zentf.tools.view import Viewer

    nopts = node_options(opts, f"_zentf_view_{os.getpid()}")
    nopts.params.update(tf_topics.params)
    if use_sim_time:
        nopts.params["use_sim_time"] = True
    try:
        node = Node(options=nopts, check_unique=False)
    except Exception as exc:  # noqa: BLE001
        raise CliError(f"cannot open a Zenoh session: {exc}".splitlines()[0]) from exc
    rec = rr.RecordingStream("zentf_view")
    stack = contextlib.ExitStack()
    native: Optional[subprocess.Popen] = None
    try:
        sinks = []
        if save:
            sinks.append(rr.FileSink(save))
        if web:
            sinks.append(rr.GrpcServerSink(bind_ip=bind, port=grpc_port))
        try:
            if sinks:
                rec.set_sinks(*sinks)
            else:
                native = stack.enter_context(_native_viewer(rec, grpc_port))
        except CliError:
            raise
        except Exception as exc:  # noqa: BLE001 - port in use, no viewer binary, unwritable file
            raise CliError(f"cannot start the Rerun viewer: {exc}".splitlines()[0]) from exc
        if web:
            grpc_url = f"rerun+http://{'127.0.0.1' if bind in ('0.0.0.0', '::') else bind}:{grpc_port}/proxy"
            stack.enter_context(_web_viewer(bind, web_port, grpc_url))
            print(f"web viewer: http://{'localhost' if bind in ('127.0.0.1', '0.0.0.0') else bind}:{web_port}"
                  f"/?url={quote(grpc_url, safe='')}", flush=True)
        if save:
            print(f"saving to {save}", flush=True)
        viewer = Viewer(node, rec, fixed_frame=fixed_frame, axis_length=axis_length, label_frames=labels,
                        robot_description=robot_description or None, frame_prefix=frame_prefix,
                        tf_topics=[(d, s or d + "_static") if d else (None, s) for d, s in tf_topics.pairs()])
        viewer.send_blueprint()  # one 3D view with a ground grid, before the first data
        from .format import printable

        where = (f"fixed frame '{printable(fixed_frame)}'" if fixed_frame
                 else "fixed frame world, map or odom, else the root of the largest tree")
        print(f"viewing {node.get_namespace()} in {where} (Ctrl-C to stop)", flush=True)
        with _stop_on_signals() as stop:
            if native is not None:  # closing the viewer window ends the view too
                threading.Thread(target=lambda: (native.wait(), stop.set()), daemon=True).start()
            try:
                viewer.run(stop, rate=rate, duration=duration)
            finally:
                viewer.close()
        if native is not None and native.poll():
            raise CliError(f"the Rerun viewer exited with code {native.returncode} (see its messages above)")
        sys.stderr.write(f"view: {viewer.ticks} refreshes, {len(viewer._shown_frames)} frames shown, "
                         f"{viewer.problems} bad messages dropped\n")
    finally:
        try:
            rec.flush()
            rec.disconnect()
        except Exception:  # noqa: BLE001
            pass
        stack.close()
        node.shutdown()


def _rerun_child(args: list[str], what: str, host: str, port: int, env: Optional[dict] = None) -> subprocess.Popen:
    """The Rerun binary as our own child (it dies with us: parent-death signal), once `port` accepts."""
    try:
        import rerun_cli
    except ImportError as exc:
        raise CliError("the Rerun viewer binary is missing: pip install 'zentf[view]'") from exc
    exe = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")
    setpriv = shutil.which("setpriv")  # no Python between fork and exec: Zenoh threads are running
    argv = [setpriv, "--pdeathsig", "TERM", "--"] if setpriv else []
    proc = subprocess.Popen([*argv, exe, *args], stdin=subprocess.DEVNULL, env=env)
    try:
        deadline = time.monotonic() + 10.0
        while True:  # ready once its port accepts
            if proc.poll() is not None:
                raise CliError(f"the Rerun {what} exited at start (code {proc.returncode})")
            with contextlib.suppress(OSError), socket.create_connection((host, port), timeout=0.2):
                break
            if time.monotonic() > deadline:
                raise CliError(f"the Rerun {what} did not open port {port} within 10 s")
            time.sleep(0.05)
    except BaseException:
        _end(proc)
        raise
    return proc


def _end(proc: subprocess.Popen) -> None:
    proc.terminate()
    try:
        proc.wait(3.0)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


@contextlib.contextmanager
def _native_viewer(rec: Any, port: int) -> Iterator[subprocess.Popen]:
    """Rerun's desktop viewer; its data port listens on loopback only (Rerun's default is every interface)."""
    proc = _rerun_child(["--bind", "127.0.0.1", "--port", str(port)], "viewer", "127.0.0.1", port)
    try:
        rec.connect_grpc(f"rerun+http://127.0.0.1:{port}/proxy")
        yield proc
    finally:
        _end(proc)


@contextlib.contextmanager
def _web_viewer(bind: str, port: int, grpc_url: str) -> Iterator[subprocess.Popen]:
    """The web viewer's page, served on `bind` only (the SDK's own web server listens on every interface)."""
    host = "127.0.0.1" if bind in ("0.0.0.0", "::") else bind
    env = {**os.environ, "RUST_LOG": os.environ.get("RUST_LOG", "warn")}  # we print the URL ourselves
    proc = _rerun_child(["--serve-web", "--bind", bind, "--web-viewer-port", str(port), grpc_url],
                        "web viewer", host, port, env)
    try:
        yield proc
    finally:
        _end(proc)
