"""`zentf bag record | play | info | convert | demo`: rosbag over Zenoh; zentf MCAP, ROS 1 and ROS 2 bags."""
from __future__ import annotations

import json
import os
import shutil
import signal
import sys
import threading
import time
from contextlib import contextmanager
from typing import Any, Iterator, Optional

import click

from .common import (CONTEXT_SETTINGS, CliError, CliOptions, finite_float, node_options, open_node, wire_profile,
                     with_options)
from .format import printable

__all__ = ["bag"]


@click.group("bag", context_settings=CONTEXT_SETTINGS)
def bag() -> None:
    """Record, inspect, play and convert bags: zentf MCAP, ROS 1 .bag, rosbag2 (.db3/.mcap/folder)."""


def _human_size(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} GiB"


def _err(line: str) -> None:
    """A line on stderr; topic names and problems read from a bag are printed escaped (printable)."""
    sys.stderr.write(printable(line) + "\n")
    sys.stderr.flush()


def _skip_line(topic: str, why: str) -> None:
    """One line per topic a command leaves out (a type it cannot carry)."""
    _err(f"zentf: skipping {topic}: {why}")


def _path_size(path: str) -> int:
    if os.path.isdir(path):
        return sum(os.path.getsize(os.path.join(path, f)) for f in os.listdir(path))
    return os.path.getsize(path) if os.path.exists(path) else 0


def _topic_list(values: tuple[str, ...]) -> Optional[list[str]]:
    """--topics given repeatedly and/or comma-separated; None when not given."""
    names = [t for v in values for t in v.split(",") if t.strip()]
    return [t.strip() for t in names] or None


class _Progress:
    """One status line on stderr: rewritten in place on a TTY, else printed once per period."""

    def __init__(self, period: float = 1.0) -> None:
        self.tty = sys.stderr.isatty()
        self.period = period
        self._last = 0.0

    def show(self, text: str, force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self._last < (0.1 if self.tty else self.period):
            return
        self._last = now
        if self.tty:
            sys.stderr.write("\r\x1b[K" + text)
        else:
            sys.stderr.write(text + "\n")
        sys.stderr.flush()

    def done(self, text: str) -> None:
        if self.tty:
            sys.stderr.write("\r\x1b[K")
        _err(text)


@contextmanager
def _stop_on_signals() -> Iterator[threading.Event]:
    """SIGINT/SIGTERM set an event (the command then closes its file cleanly) instead of killing."""
    stop = threading.Event()
    old = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            old[sig] = signal.signal(sig, lambda *_: stop.set())
        except (ValueError, OSError):
            pass
    try:
        yield stop
    finally:
        for sig, h in old.items():
            try:
                signal.signal(sig, h)
            except (ValueError, OSError, TypeError):
                pass


def _resolve_topics(opts: CliOptions, topics: tuple[str, ...], all_topics: bool) -> tuple[list[str], str]:
    """(fully qualified topics, or the namespace's pattern with --all; the namespace)."""
    from zentf.transport.names import resolve_topic

    ns = (node_options(opts, "_zentf_bag").namespace or "").strip("/")
    if all_topics:
        if topics:
            raise CliError("give topics or --all, not both", code=2)
        return [f"/{ns}/**" if ns else "/**"], ns
    if not topics:
        raise CliError("nothing to record: give topic names or --all", code=2)
    names = []
    for name in topics:
        try:
            names.append(resolve_topic(name, ns))
        except ValueError as exc:
            raise CliError(str(exc), code=2) from exc
    return names, ns


@bag.command("record", context_settings=CONTEXT_SETTINGS)
@click.argument("topics", nargs=-1)
@click.option("--all", "-a", "all_topics", is_flag=True,
              help="Record every topic (of --namespace if one is set, else of the whole network).")
@click.option("--output", "-o", type=click.Path(writable=True), default=None,
              help="Output file [default: zentf_<date>_<time>.mcap; with --format ros2 a rosbag2 folder "
                   "rosbag2_<date>_<time>, or a single file if the name ends in .mcap].")
@click.option("--format", "fmt", type=click.Choice(["zentf", "ros2"]), default="zentf", show_default=True,
              help="zentf: MCAP with msgpack payloads; ros2: rosbag2 MCAP with CDR payloads (ROS 2 tools open it).")
@click.option("--duration", type=finite_float(min=0.0, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@click.option("--compression", type=click.Choice(["zstd", "lz4", "none"]), default="zstd", show_default=True)
@with_options
def bag_record(topics: tuple[str, ...], all_topics: bool, output: Optional[str], fmt: str,
               duration: Optional[float], compression: str, *, opts: CliOptions) -> None:
    """Record TOPICS (relative to --namespace) or --all into a bag; Ctrl-C stops and closes it."""
    from zentf.tools.bag import BagError, BagWriter, Recorder

    names, ns = _resolve_topics(opts, topics, all_topics)
    writer: Any
    profile = wire_profile(opts)
    try:
        if profile.payload_format == "cdr":  # a ROS 2 graph: CDR as it came, in a rosbag2-style MCAP (docs/ros2.md)
            from zentf.tools.bag import Ros2BagWriter

            path = output or time.strftime("zentf_%Y%m%d_%H%M%S.mcap")
            writer = Ros2BagWriter(path, profile, compression=compression)
        elif fmt == "ros2":
            from zentf.tools.bag import Ros2Writer

            path = output or time.strftime("rosbag2_%Y_%m_%d-%H_%M_%S")
            writer = Ros2Writer(path, namespace=ns, on_skip=_skip_line)
        else:
            path = output or time.strftime("zentf_%Y%m%d_%H%M%S.mcap")
            writer = BagWriter(path, namespace=ns, compression=compression)
    except BagError as exc:
        raise CliError(str(exc)) from exc
    try:
        node = open_node(opts, "bag")
    except BaseException:
        writer.close()
        shutil.rmtree(path, ignore_errors=True) if os.path.isdir(path) else os.unlink(path)
        raise
    try:
        with _stop_on_signals() as stop:
            recorder = Recorder(node, writer, names)
            progress = _Progress()
            started = time.monotonic()
            shown = "all topics" if all_topics else ", ".join(names)
            _err(f"recording {shown} to {path} (Ctrl-C to stop)")
            last_flush = started
            try:
                while not stop.is_set():
                    now = time.monotonic()
                    if duration is not None and now - started >= duration:
                        break
                    if now - last_flush >= 1.0:
                        writer.flush()
                        last_flush = now
                    progress.show(f"recording: {writer.messages} msgs, {_human_size(writer.file_size)}, "
                                  f"{now - started:.1f} s")
                    stop.wait(0.1)
            finally:
                recorder.close()
                writer.close()
            size = _path_size(path)
            progress.done(f"recorded {writer.messages} msgs, {_human_size(size)}, "
                          f"{writer.duration:.1f} s of messages in {path}")
    finally:
        node.shutdown()


@bag.command("info", context_settings=CONTEXT_SETTINGS)
@click.argument("file", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def bag_info(file: str, as_json: bool) -> None:
    """Format, time span, topics (types, counts, rates) and tf frames of a bag of any format (rosbag info)."""
    from zentf.tools.bag import BagError, bag_info as info_of

    try:
        info = info_of(file)
    except BagError as exc:
        raise CliError(str(exc)) from exc
    if as_json:
        print(json.dumps(info))
        return
    print(_format_info(info))
    if info["problem"]:
        _err(f"zentf: warning: {file}: {info['problem']}; counts are of the readable part")


def _format_info(info: dict[str, Any]) -> str:
    def stamp(t: Optional[float]) -> str:
        if t is None:
            return "-"
        return time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(t)) + f".{int(t * 1000) % 1000:03d} UTC ({t:.3f})"

    lines = [f"path:       {printable(info['path'])}",
             f"format:     {info['format']}",
             f"encoding:   {info['encoding']}",
             f"size:       {_human_size(info['size'])}",
             f"duration:   {info['duration']:.3f} s",
             f"start:      {stamp(info['start'])}",
             f"end:        {stamp(info['end'])}",
             f"messages:   {info['messages']}",
             f"complete:   {'yes' if info['complete'] else 'no (' + printable(info['problem']) + ')'}",
             "topics:"]
    keys = [printable(t["topic"]) for t in info["topics"]]  # named as `topic list` names them
    width = max((len(k) for k in keys), default=0)
    for key, t in zip(keys, info["topics"]):
        rate = f"{t['frequency']:8.2f} Hz" if t["frequency"] else " " * 11
        extra = " (latched)" if t["latched"] else ""
        lines.append(f"  {key:<{width}}  {t['count']:7d} msgs {rate}  {printable(t['type'] or '?')}{extra}")
    for topic, edges in info["tf_edges"].items():
        if edges:
            frames = len({f for e in edges for f in e})
            lines.append(f"/{topic}: {len(edges)} transform{'s' * (len(edges) != 1)} between {frames} frames")
            lines.extend(f"  {printable(parent)} -> {printable(child)}" for parent, child in edges)
    return "\n".join(lines)


@bag.command("play", context_settings=CONTEXT_SETTINGS)
@click.argument("file", type=click.Path())
@click.option("--clock", is_flag=True, help="Publish /clock with the bag time (for use_sim_time nodes).")
@click.option("--hz", "clock_hz", type=finite_float(min=1.0, max=1e6), default=100.0, show_default=True,
              help="/clock publish rate with --clock.")
@click.option("--rate", "-r", type=finite_float(min=1e-6, max=1e6), default=1.0, show_default=True,
              help="Playback speed factor.")
@click.option("--loop", "-l", is_flag=True, help="Start again at the end.")
@click.option("--start", "-s", type=finite_float(min=0.0), default=0.0, show_default=True,
              help="Seconds into the bag to start at (latched topics before it are still sent).")
@click.option("--delay", "-d", type=finite_float(min=0.0), default=0.0,
              help="Seconds to wait after advertising, before playing.")
@click.option("--topics", "topics", multiple=True, metavar="NAMES",
              help="Only these topics (comma-separated or repeated; '/odom' and 'odom' are the same).")
@with_options
def bag_play(file: str, clock: bool, clock_hz: float, rate: float, loop: bool, start: float, delay: float,
             topics: tuple[str, ...], *, opts: CliOptions) -> None:
    """Republish a bag (zentf, ROS 1 or ROS 2) with its original timing (rosbag play).

    ROS topic names become zentf topics (/odom -> odom, under --namespace); ROS payloads are
    re-encoded to zentf's wire form; a type that cannot be carried is skipped with one line.
    """
    from zentf.tools.bag import BagError, Player

    ns = (node_options(opts, "_zentf_bag").namespace or "").strip("/")
    node = open_node(opts, "bag_play")
    try:
        with _stop_on_signals() as stop:
            try:
                player = Player(node, file, namespace=ns, rate=rate, clock_hz=clock_hz if clock else 0.0,
                                loop=loop, start=start, stop=stop, topics=_topic_list(topics), on_skip=_skip_line)
            except BagError as exc:
                raise CliError(str(exc)) from exc
            progress = _Progress()
            _err(f"playing {file} at rate {rate:g}{' with /clock' if clock else ''}{' in a loop' if loop else ''}"
                 " (Ctrl-C to stop)")
            if player.clock_offset:
                _err(f"/clock follows the recording's tf stamps, {player.clock_offset / 1e9:+.0f} s from its log "
                     "times (a sim-time graph recorded with a wall clock)")
            if delay:
                stop.wait(delay)

            def show(st: Any) -> None:
                t = (st.bag_time - st.bag_start) / 1e9 if st.bag_time and st.bag_start else 0.0
                progress.show(f"playing: t = {t:.1f} s, {st.messages} msgs sent")

            try:
                stats = player.play(show)
            except BagError as exc:
                raise CliError(str(exc)) from exc
            finally:
                player.close()
            progress.done(f"played {stats.messages} msgs from {file}")
            if stats.problem:
                _err(f"zentf: warning: {file}: {stats.problem}; played the readable part")
    finally:
        node.shutdown()


@bag.command("convert", context_settings=CONTEXT_SETTINGS)
@click.argument("src", metavar="IN", type=click.Path())
@click.argument("dst", metavar="OUT", type=click.Path())
@click.option("--to", "to", type=click.Choice(["zentf", "ros2"]), default=None,
              help="Output format [default: zentf for a ROS bag, ros2 for a zentf bag].")
@click.option("--topics", "topics", multiple=True, metavar="NAMES",
              help="Only these topics (comma-separated or repeated).")
def bag_convert(src: str, dst: str, to: Optional[str], topics: tuple[str, ...]) -> None:
    """Convert IN to OUT: ROS 1 / ROS 2 bags to zentf MCAP, zentf MCAP to ROS 2 MCAP.

    A ROS 2 OUT ending in .mcap is one MCAP file; any other name a rosbag2 folder.
    """
    from zentf.tools.bag import BagError, convert

    if os.path.exists(dst):
        raise CliError(f"{dst} exists already, not overwriting", code=2)
    try:
        res = convert(src, dst, to=to, topics=_topic_list(topics), on_skip=_skip_line)
    except BagError as exc:
        raise CliError(str(exc)) from exc
    print(f"wrote {dst}: {res['messages']} msgs as {res['format']}, {_human_size(_path_size(dst))}")
    if res["problem"]:
        _err(f"zentf: warning: {src}: {res['problem']}; converted the readable part")


@bag.command("demo", context_settings=CONTEXT_SETTINGS)
@click.option("--output", "-o", type=click.Path(dir_okay=False), default="drones.mcap", show_default=True)
@click.option("--duration", type=finite_float(min=0.1, max=3600), default=10.0, show_default=True,
              help="Seconds of flight.")
def bag_demo(output: str, duration: float) -> None:
    """Write a recording of the drones demo (tf, tf_static, visual_markers) to replay with `bag play`."""
    from zentf.tools.bag import BagError, write_drones_demo

    try:
        info = write_drones_demo(output, duration)
    except BagError as exc:
        raise CliError(str(exc)) from exc
    print(f"wrote {output}: {info['messages']} msgs, {info['duration']:.1f} s, {_human_size(info['size'])}")
    print(f"replay it:  zentf bag play {output} --clock --loop")
