"""`zentf bag record | play | info | demo`: rosbag over Zenoh, in MCAP files."""
from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from contextlib import contextmanager
from typing import Any, Iterator, Optional

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, node_options, open_node, wire_profile, with_options

__all__ = ["bag"]


@click.group("bag", context_settings=CONTEXT_SETTINGS)
def bag() -> None:
    """Record topics to MCAP, inspect and play bags (rosbag record/info/play)."""


def _human_size(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} GiB"


def _err(line: str) -> None:
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


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


def _resolve_keys(opts: CliOptions, topics: tuple[str, ...], all_topics: bool) -> tuple[list[str], str]:
    from zentf.names import resolve_topic, topic_to_key

    ns = (node_options(opts, "_zentf_bag").namespace or "").strip("/")
    if all_topics:
        if topics:
            raise CliError("give topics or --all, not both", code=2)
        return [f"{ns}/**" if ns else "**"], ns
    if not topics:
        raise CliError("nothing to record: give topic names or --all", code=2)
    keys = []
    for name in topics:
        try:
            keys.append(topic_to_key(resolve_topic(name, ns)))
        except ValueError as exc:
            raise CliError(str(exc), code=2) from exc
    return keys, ns


@bag.command("record", context_settings=CONTEXT_SETTINGS)
@click.argument("topics", nargs=-1)
@click.option("--all", "-a", "all_topics", is_flag=True,
              help="Record every topic (of --namespace if one is set, else of the whole network).")
@click.option("--output", "-o", type=click.Path(dir_okay=False, writable=True), default=None,
              help="Output file [default: zentf_<date>_<time>.mcap].")
@click.option("--duration", type=click.FloatRange(min=0.0, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@click.option("--compression", type=click.Choice(["zstd", "lz4", "none"]), default="zstd", show_default=True)
@with_options
def bag_record(topics: tuple[str, ...], all_topics: bool, output: Optional[str], duration: Optional[float],
               compression: str, *, opts: CliOptions) -> None:
    """Record TOPICS (relative to --namespace) or --all into an MCAP file; Ctrl-C stops and closes it."""
    from zentf.tools.bag import BagError, BagWriter, Recorder

    keys, ns = _resolve_keys(opts, topics, all_topics)
    path = output or time.strftime("zentf_%Y%m%d_%H%M%S.mcap")
    profile = wire_profile(opts)
    try:
        if profile.name == "ros2":  # a ROS 2 graph: CDR as it came, in a rosbag2-style MCAP (docs/ros2.md)
            from zentf.tools.ros2_bag import Ros2BagWriter

            keys = [f"{profile.domain_id}/{k}" if k.endswith("**") else profile.data_key("/" + k, None)
                    for k in keys]
            writer = Ros2BagWriter(path, profile, compression=compression)
        else:
            writer = BagWriter(path, namespace=ns, compression=compression)
    except BagError as exc:
        raise CliError(str(exc)) from exc
    try:
        node = open_node(opts, "bag")
    except BaseException:
        writer.close()
        os.unlink(path)
        raise
    try:
        with _stop_on_signals() as stop:
            recorder = Recorder(node.session, writer, keys,
                                declare_token=lambda k: node._declare_entity("sub", "", k))
            progress = _Progress()
            started = time.monotonic()
            shown = "all topics" if all_topics else ", ".join(keys)
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
            size = os.path.getsize(path) if os.path.exists(path) else 0
            progress.done(f"recorded {writer.messages} msgs, {_human_size(size)}, "
                          f"{writer.duration:.1f} s of messages in {path}")
    finally:
        node.shutdown()


@bag.command("info", context_settings=CONTEXT_SETTINGS)
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def bag_info(file: str, as_json: bool) -> None:
    """Topics, types, counts, rates and time span of a bag (rosbag info)."""
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

    lines = [f"path:       {info['path']}",
             f"size:       {_human_size(info['size'])}",
             f"duration:   {info['duration']:.3f} s",
             f"start:      {stamp(info['start'])}",
             f"end:        {stamp(info['end'])}",
             f"messages:   {info['messages']}",
             f"complete:   {'yes' if info['complete'] else 'no (' + str(info['problem']) + ')'}",
             "topics:"]
    width = max((len(t["key"]) for t in info["topics"]), default=0)
    for t in info["topics"]:
        rate = f"{t['frequency']:8.2f} Hz" if t["frequency"] else " " * 11
        extra = " (latched)" if t["latched"] else ""
        lines.append(f"  {t['key']:<{width}}  {t['count']:7d} msgs {rate}  {t['type'] or '?'}{extra}")
    return "\n".join(lines)


@bag.command("play", context_settings=CONTEXT_SETTINGS)
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--clock", is_flag=True, help="Publish /clock with the bag time (for use_sim_time nodes).")
@click.option("--hz", "clock_hz", type=click.FloatRange(min=1.0), default=100.0, show_default=True,
              help="/clock publish rate with --clock.")
@click.option("--rate", "-r", type=click.FloatRange(min=0.0, min_open=True), default=1.0, show_default=True,
              help="Playback speed factor.")
@click.option("--loop", "-l", is_flag=True, help="Start again at the end.")
@click.option("--start", "-s", type=click.FloatRange(min=0.0), default=0.0, show_default=True,
              help="Seconds into the bag to start at (latched topics before it are still sent).")
@click.option("--delay", "-d", type=click.FloatRange(min=0.0), default=0.0,
              help="Seconds to wait after advertising, before playing.")
@with_options
def bag_play(file: str, clock: bool, clock_hz: float, rate: float, loop: bool, start: float, delay: float,
             *, opts: CliOptions) -> None:
    """Republish a bag's messages with their original timing (rosbag play)."""
    from zentf.tools.bag import BagError, Player

    ns = (node_options(opts, "_zentf_bag").namespace or "").strip("/")
    node = open_node(opts, "bag_play")
    try:
        with _stop_on_signals() as stop:
            try:
                player = Player(node.session, file, namespace=ns, rate=rate, clock_hz=clock_hz if clock else 0.0,
                                loop=loop, start=start, stop=stop,
                                declare_token=lambda tn, k: node._declare_entity("pub", tn, k))
            except BagError as exc:
                raise CliError(str(exc)) from exc
            progress = _Progress()
            _err(f"playing {file} at rate {rate:g}{' with /clock' if clock else ''}{' in a loop' if loop else ''}"
                 " (Ctrl-C to stop)")
            if delay:
                stop.wait(delay)

            def show(st: Any) -> None:
                t = (st.bag_time - st.bag_start) / 1e9 if st.bag_time and st.bag_start else 0.0
                progress.show(f"playing: t = {t:.1f} s, {st.messages} msgs sent")

            try:
                stats = player.play(show)
            finally:
                player.close()
            progress.done(f"played {stats.messages} msgs from {file}")
            if stats.problem:
                _err(f"zentf: warning: {file}: {stats.problem}; played the readable part")
    finally:
        node.shutdown()


@bag.command("demo", context_settings=CONTEXT_SETTINGS)
@click.option("--output", "-o", type=click.Path(dir_okay=False), default="drones.mcap", show_default=True)
@click.option("--duration", type=click.FloatRange(min=0.1, max=3600), default=10.0, show_default=True,
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
