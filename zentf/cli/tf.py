"""`zentf tf echo | monitor | frames`: tf2_echo, tf2_monitor and view_frames over Zenoh."""
from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any, Optional

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, status, with_options

__all__ = ["tf"]


@click.group("tf", context_settings=CONTEXT_SETTINGS)
def tf() -> None:
    """Transforms: echo (tf2_echo), monitor (tf2_monitor), frames (view_frames)."""


def _listen(opts: CliOptions, tool: str) -> tuple[Any, Any, Any]:
    """Node + Buffer + TransformListener (tf and tf_static of the namespace)."""
    from zentf.buffer import Buffer
    from zentf.listener import TransformListener

    from .common import open_node

    node = open_node(opts, tool)
    try:
        buffer = Buffer()
        listener = TransformListener(buffer, node)
    except BaseException:
        node.shutdown()
        raise
    return node, buffer, listener


def _close(node: Any, listener: Any = None) -> None:
    for obj, meth in ((listener, "unregister"), (node, "shutdown")):
        fn = getattr(obj, meth, None) if obj is not None else None
        if fn is not None:
            try:
                fn()
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass


@tf.command("echo", context_settings=CONTEXT_SETTINGS)
@click.argument("source")
@click.argument("target")
@click.option("--rate", "-r", type=click.FloatRange(min=0.001), default=1.0, show_default=True,
              help="Prints per second.")
@click.option("--precision", "-p", type=click.IntRange(0, 17), default=3, show_default=True,
              help="Digits after the decimal point.")
@click.option("--time", "-t", "at_time", type=float, default=None,
              help="Look up at this fixed time (s) instead of the latest.")
@click.option("--count", "-c", type=click.IntRange(min=0), default=0,
              help="Exit after this many prints (default: run until Ctrl-C).")
@click.option("--timeout", type=click.FloatRange(min=0.0), default=None,
              help="Exit 1 if no transform arrives within this many seconds (default: wait).")
@with_options
def echo(source: str, target: str, rate: float, precision: int, at_time: Optional[float], count: int,
         timeout: Optional[float], *, opts: CliOptions) -> None:
    """Print the pose of TARGET in SOURCE at a fixed rate, like tf2_echo.

    As in tf2_echo the first argument is the frame the result is expressed in
    (lookup_transform(SOURCE, TARGET)). While the frames are unavailable the reason is printed
    on stderr once a second and the tool keeps waiting.
    """
    from zentf.exceptions import TransformException
    from zentf.time import Duration, Time

    from .format import format_echo

    node, buffer, listener = _listen(opts, "tf_echo")
    try:
        when = Time() if at_time is None else Time.from_sec(at_time)
        period = 1.0 / rate
        started = time.monotonic()
        printed = 0
        last_reason = ""
        last_reason_at = 0.0
        next_tick = started
        while True:
            now = time.monotonic()
            if timeout is not None and printed == 0:
                left = started + timeout - now
                step = max(0.0, min(1.0, left))
            else:
                left = None
                step = 1.0
            try:
                if printed == 0:
                    with status(f"Waiting for transform {source} -> {target}"):
                        ts = buffer.lookup_transform(source, target, when, timeout=Duration.from_sec(step))
                else:
                    ts = buffer.lookup_transform(source, target, when)
            except TransformException as exc:
                reason = " ".join(str(exc).split())
                if left is not None and left <= 0:
                    raise CliError(f"no transform {source} -> {target} after {timeout:g} s: {reason}") from exc
                now = time.monotonic()
                if printed:
                    sys.stderr.write(f"Failure at {time.time():.6f}: {reason}\n")
                    sys.stderr.flush()
                    next_tick += period
                    time.sleep(max(0.0, next_tick - time.monotonic()))
                elif reason != last_reason or now - last_reason_at >= 1.0:
                    sys.stderr.write(f"Waiting for transform {source} -> {target}: {reason}\n")
                    sys.stderr.flush()
                    last_reason, last_reason_at = reason, now
                continue
            tr, rot = ts.transform.translation, ts.transform.rotation
            stamp = ts.header.stamp
            stamp_ns = stamp.nanoseconds if hasattr(stamp, "nanoseconds") else int(stamp)
            sys.stdout.write(format_echo(stamp_ns, (tr.x, tr.y, tr.z), (rot.x, rot.y, rot.z, rot.w), precision) + "\n")
            sys.stdout.flush()
            printed += 1
            if count and printed >= count:
                return
            next_tick = max(next_tick + period, time.monotonic() - period) if printed > 1 else time.monotonic() + period
            time.sleep(max(0.0, next_tick - time.monotonic()))
    finally:
        _close(node, listener)


def _render(dot_path: Path, fmt: str, out_path: Path) -> Optional[str]:
    """Render DOT with graphviz; returns a one-line problem instead of raising."""
    import shutil
    import subprocess

    exe = shutil.which("dot")
    if exe is None:
        return "graphviz 'dot' not found; wrote the DOT file only (apt-get install graphviz)"
    proc = subprocess.run([exe, f"-T{fmt}", str(dot_path), "-o", str(out_path)], capture_output=True,
                          text=True, timeout=120)
    if proc.returncode != 0:
        first = (proc.stderr.strip().splitlines() or ["failed"])[0]
        return f"dot could not render {dot_path}: {first}"
    return None


def write_graph(dot_text: str, output: Optional[str], default_stem: str) -> tuple[Path, Optional[Path], Optional[str]]:
    """Write NAME.gv and render NAME.pdf/.svg/.png; a suffix on -o picks the image format."""
    fmt = "pdf"
    if output:
        p = Path(output)
        if p.suffix.lower() in (".pdf", ".svg", ".png"):
            fmt = p.suffix.lower()[1:]
            stem = p.with_suffix("")
        elif p.suffix.lower() in (".gv", ".dot"):
            stem = p.with_suffix("")
        else:
            stem = p
    else:
        stem = Path(default_stem)
    if stem.parent and not stem.parent.exists():
        raise CliError(f"output directory does not exist: {stem.parent}")
    dot_path = stem.with_name(stem.name + ".gv")
    img_path = stem.with_name(stem.name + "." + fmt)
    try:
        dot_path.write_text(dot_text, encoding="utf-8")
    except OSError as exc:
        raise CliError(f"cannot write {dot_path}: {exc.strerror}") from exc
    problem = _render(dot_path, fmt, img_path)
    return dot_path, (None if problem else img_path), problem


def _frame_stats(buffer: Any) -> list:
    from .format import parse_frames_yaml

    core = getattr(buffer, "core", buffer)
    return parse_frames_yaml(core.all_frames_as_yaml())


@tf.command("frames", context_settings=CONTEXT_SETTINGS)
@click.option("--output", "-o", default=None, metavar="NAME",
              help="Write NAME.gv and NAME.pdf (a .svg/.png suffix picks that format). Default: frames_<date>.")
@click.option("--wait", "-w", "--wait-time", type=click.FloatRange(min=0.0), default=5.0, show_default=True,
              help="Seconds to listen before writing.")
@click.option("--print", "-P", "print_tree", is_flag=True, help="Also print the frame tree as text.")
@with_options
def frames(output: Optional[str], wait: float, print_tree: bool, *, opts: CliOptions) -> None:
    """Listen for a while, then write the frame tree as Graphviz DOT and an image, like view_frames.

    Every edge is labelled with its broadcaster, average rate, most recent and oldest transform
    and buffer length; disconnected trees are drawn as separate clusters.
    """
    from .format import format_frame_tree, frames_dot

    node, buffer, listener = _listen(opts, "view_frames")
    try:
        deadline = time.monotonic() + wait
        with status(f"Listening to tf for {wait:g} s") as st:
            while (left := deadline - time.monotonic()) > 0:
                st.update(f"Listening to tf for {wait:g} s ({left:.1f} s left)")
                time.sleep(min(0.1, left))
        stats = _frame_stats(buffer)
        recorded = _now_sec(node)
    finally:
        _close(node, listener)
    if not stats:
        raise CliError(f"no tf data received in {wait:g} s (is anything publishing on "
                       f"{_tf_topics(opts)}?)")
    stem = time.strftime("frames_%Y-%m-%d_%H.%M.%S")
    dot_path, img_path, problem = write_graph(frames_dot(stats, recorded), output, stem)
    if print_tree:
        print(format_frame_tree(stats))
    print(f"Wrote {dot_path}" + (f" and {img_path}" if img_path else ""))
    if problem:
        sys.stderr.write(f"zentf: warning: {problem}\n")


def _now_sec(node: Any) -> float:
    try:
        return node.get_clock().now().nanoseconds / 1e9
    except Exception:  # noqa: BLE001
        return time.time()


def _tf_topics(opts: CliOptions) -> str:
    import os

    ns = (opts.namespace if opts.namespace is not None else os.environ.get("ZENTF_NAMESPACE", "")).strip("/")
    return f"/{ns}/tf and /{ns}/tf_static" if ns else "/tf and /tf_static"
