"""`zentf tf echo | monitor | frames | doctor | why`: tf2_echo, tf2_monitor, view_frames and the tf doctor over Zenoh."""
from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any, Callable, Optional

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, StampSeconds, finite_float, status, with_options
from .tf_topics import TfToolCommand, TfTopics, open_tf_listeners, tf_topic_options
from .toolclock import ToolClock, use_sim_time_option

__all__ = ["tf"]


@click.group("tf", context_settings=CONTEXT_SETTINGS)
def tf() -> None:
    """Transforms: echo (tf2_echo), monitor (tf2_monitor), frames (view_frames), doctor, why.

    Every tf tool reads the namespace's tf and tf_static, or the topics --tf-topic /
    --tf-static-topic / --ros-args -r /tf:=TOPIC name, or every namespace's (--all-namespaces).
    """


def _listen(opts: CliOptions, tool: str, topics: Optional[TfTopics] = None) -> tuple[Any, Any, Any]:
    """Node + Buffer + TransformListeners (the namespace's tf and tf_static, or ``topics``)."""
    from zentf.transport.buffer import Buffer

    from .common import open_node

    node = open_node(opts, tool)
    try:
        buffer = Buffer()
        listeners = open_tf_listeners(buffer, node, topics or TfTopics())
    except ValueError as exc:  # a bad topic pattern
        node.shutdown()
        raise CliError(str(exc), code=2) from exc
    except BaseException:
        node.shutdown()
        raise
    return node, buffer, listeners


def _close(node: Any, listener: Any = None) -> None:
    listeners = listener if isinstance(listener, list) else [listener]
    calls = [(obj, "unregister") for obj in listeners] + [(node, "shutdown")]
    for obj, meth in calls:
        fn = getattr(obj, meth, None) if obj is not None else None
        if fn is not None:
            try:
                fn()
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass


@tf.command("echo", cls=TfToolCommand, context_settings=CONTEXT_SETTINGS)
@click.argument("source")
@click.argument("target")
@click.argument("rate_arg", metavar="[RATE]", required=False, type=finite_float(min=0.001, max=1e6))
@click.option("--rate", "-r", type=finite_float(min=0.001, max=1e6), default=1.0, show_default=True,
              help="Prints per second (tf2_echo's optional third argument does the same).")
@click.option("--precision", "-p", type=click.IntRange(0, 17), default=3, show_default=True,
              help="Digits after the decimal point.")
@click.option("--time", "-t", "at_time", type=StampSeconds(), default=None,
              help="Look up at this fixed time (s) instead of the latest.")
@click.option("--count", "-c", type=click.IntRange(min=1), default=None,
              help="Exit after this many prints (default: run until Ctrl-C).")
@click.option("--timeout", type=finite_float(min=0.0), default=None,
              help="Exit 1 if no transform arrives within this many seconds (default: wait).")
@click.option("--bag", "bag_file", type=click.Path(), default=None,
              help="Answer from this recording (any bag format zentf reads), no network: print once and exit.")
@click.option("--start", "start", type=StampSeconds(), default=None,
              help="With --bag: load only transforms stamped from this time (s) on (statics always).")
@click.option("--end", "end", type=StampSeconds(), default=None,
              help="With --bag: load only transforms stamped up to this time (s).")
@tf_topic_options
@use_sim_time_option
@with_options
def echo(source: str, target: str, rate_arg: Optional[float], rate: float, precision: int,
         at_time: Optional[float], count: Optional[int], timeout: Optional[float], bag_file: Optional[str],
         start: Optional[float], end: Optional[float], use_sim_time: bool, *, tf_topics: TfTopics, opts: CliOptions) -> None:
    """Print the pose of TARGET in SOURCE at a fixed rate, like tf2_echo.

    As in tf2_echo the first argument is the frame the result is expressed in
    (lookup_transform(SOURCE, TARGET)). While the frames are unavailable the reason is printed
    on stderr once a second and the tool keeps waiting.
    """
    from zentf.core.exceptions import InvalidArgumentException, TransformException
    from zentf.core.time import Duration, Time

    from .format import format_echo, printable

    for value, what in ((source, "SOURCE"), (target, "TARGET")):
        if not value.strip():  # tf2 refuses it on every lookup: say so once, not every second
            raise click.BadParameter("a frame id cannot be empty", param_hint=f"'{what}'")
    if bag_file is not None:
        _echo_bag(bag_file, source, target, at_time, precision, start, end)
        return
    if start is not None or end is not None:
        raise click.BadParameter("only with --bag", param_hint="'--start'/'--end'")
    node, buffer, listener = _listen(opts, "tf_echo", tf_topics)
    clock = None
    try:
        clock = ToolClock(node, use_sim_time)
        when = Time() if at_time is None else Time.from_sec(at_time)
        period = 1.0 / (rate_arg if rate_arg is not None else rate)

        def show(ts: Any) -> None:
            tr, rot = ts.transform.translation, ts.transform.rotation
            xyzw = (rot.x, rot.y, rot.z, rot.w)
            sys.stdout.write(format_echo(ts.header.stamp.nanoseconds, (tr.x, tr.y, tr.z), xyzw, precision) + "\n")
            sys.stdout.flush()

        # Phase 1: wait for the first transform (woken by every insert), saying why once a second.
        started = time.monotonic()
        deadline = None if timeout is None else started + timeout
        last_reason_at = float("-inf")
        first = None
        with status(f"Waiting for transform {source} -> {target}") as st:
            while first is None and node.ok():
                step = 0.2 if deadline is None else max(0.0, min(0.2, deadline - time.monotonic()))
                try:
                    first = buffer.lookup_transform(source, target, when, timeout=Duration.from_sec(step))
                except InvalidArgumentException as exc:  # will never succeed: no point waiting
                    raise CliError(" ".join(str(exc).split()), code=2) from exc
                except TransformException as exc:
                    reason = " ".join(str(exc).split())
                    now = time.monotonic()
                    if deadline is not None and now >= deadline:
                        raise CliError(f"no transform {source} -> {target} after {timeout:g} s: {reason}") from exc
                    if now - last_reason_at >= 1.0:  # at most once a second, even as the reason changes
                        sys.stderr.write(printable(f"Waiting for transform {source} -> {target}: {reason}") + "\n")
                        sys.stderr.flush()
                        last_reason_at = now
                    left = "" if deadline is None else f" ({max(0.0, deadline - now):.1f} s left)"
                    st.update(printable(f"Waiting for transform {source} -> {target}{left}: {reason}"))
        if first is None:  # Ctrl-C / SIGTERM while waiting
            return
        show(first)
        printed = 1
        # Phase 2: one lookup per tick; failures are reported and the ticking goes on.
        next_tick = time.monotonic() + period
        while not count or printed < count:
            if not _sleep_until(node, next_tick):
                return
            next_tick += period
            if next_tick < time.monotonic():  # fell behind (slow terminal): do not burst
                next_tick = time.monotonic() + period
            try:
                show(buffer.lookup_transform(source, target, when))
                printed += 1
            except TransformException as exc:
                now_ns = clock.now_ns()  # tf2_echo prints its node's now(): /clock time under sim time
                at = f"{now_ns / 1e9:.6f}" if now_ns is not None else "sim time 0 (no /clock yet)"
                sys.stderr.write(printable(f"Failure at {at}: {' '.join(str(exc).split())}") + "\n")
                sys.stderr.flush()
    finally:
        if clock is not None:
            clock.close()
        _close(node, listener)


def _echo_bag(path: str, source: str, target: str, at_time: Optional[float], precision: int,
              start: Optional[float] = None, end: Optional[float] = None) -> None:
    """tf echo --bag: one lookup in the recording (latest common time unless --time). With --time alone
    only the chunks around that time are read (the window widens until the lookup answers as the whole
    recording would); --start/--end load that window."""
    from zentf.core.exceptions import TransformException
    from zentf.core.time import Time
    from zentf.tools.bag import BagError, load_buffer, load_buffer_at

    from .format import format_echo, printable

    if start is not None and end is not None and end < start:
        raise click.BadParameter(f"--end {end:g} is before --start {start:g}", param_hint="'--end'")

    def warn(line: str) -> None:
        sys.stderr.write(printable(f"zentf: warning: {line}") + "\n")

    try:
        if at_time is not None and start is None and end is None:
            buffer = load_buffer_at(path, Time.from_sec(at_time), (source, target), on_problem=warn)
        else:
            buffer = load_buffer(path, on_problem=warn,
                                 start=None if start is None else Time.from_sec(start),
                                 end=None if end is None else Time.from_sec(end))
    except BagError as exc:
        raise CliError(str(exc)) from exc
    try:
        ts = buffer.lookup_transform(source, target, Time() if at_time is None else Time.from_sec(at_time))
    except TransformException as exc:
        raise CliError(f"no transform {source} -> {target} in {path}: {' '.join(str(exc).split())}") from exc
    tr, rot = ts.transform.translation, ts.transform.rotation
    print(format_echo(ts.header.stamp.nanoseconds, (tr.x, tr.y, tr.z), (rot.x, rot.y, rot.z, rot.w), precision))


def _sleep_until(node: Any, when: float) -> bool:
    """Sleep until monotonic time `when` in short steps; False as soon as the node is asked to stop."""
    while node.ok():
        left = when - time.monotonic()
        if left <= 0:
            return True
        time.sleep(min(0.1, left))
    return False


def _render(dot_path: Path, fmt: str, out_path: Path) -> Optional[str]:
    """Render DOT with graphviz; returns a one-line problem instead of raising."""
    import shutil
    import subprocess

    exe = shutil.which("dot")
    if exe is None:
        return "graphviz 'dot' not found; wrote the DOT file only (apt-get install graphviz)"
    try:  # absolute paths: a name starting with '-' is never read as an option
        proc = subprocess.run([exe, f"-T{fmt}", str(dot_path.absolute()), f"-o{out_path.absolute()}"],
                              capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return f"dot took longer than 120 s to render {dot_path}; wrote the DOT file only"
    except OSError as exc:
        return f"cannot run dot: {exc.strerror or exc}"
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


@tf.command("frames", cls=TfToolCommand, context_settings=CONTEXT_SETTINGS)
@click.option("--output", "-o", default=None, metavar="NAME",
              help="Write NAME.gv and NAME.pdf (a .svg/.png suffix picks that format). Default: frames_<date>.")
@click.option("--wait", "-w", "--wait-time", type=finite_float(min=0.0), default=5.0, show_default=True,
              help="Seconds to listen before writing.")
@click.option("--print", "-P", "print_tree", is_flag=True, help="Also print the frame tree as text.")
@tf_topic_options
@use_sim_time_option
@with_options
def frames(output: Optional[str], wait: float, print_tree: bool, use_sim_time: bool, *, tf_topics: TfTopics, opts: CliOptions) -> None:
    """Listen for a while, then write the frame tree as Graphviz DOT and an image, like view_frames.

    Every edge is labelled with its broadcaster, average rate, most recent and oldest transform
    and buffer length; disconnected trees are drawn as separate clusters.
    """
    from .format import format_frame_tree, frames_dot, printable, stats_from_frame_info

    node, buffer, listener = _listen(opts, "view_frames", tf_topics)
    clock = None
    try:
        clock = ToolClock(node, use_sim_time)
        deadline = time.monotonic() + wait
        with status(f"Listening to tf for {wait:g} s") as st:
            while (left := deadline - time.monotonic()) > 0 and node.ok():
                st.update(f"Listening to tf for {wait:g} s ({left:.1f} s left)")
                time.sleep(min(0.1, left))
        stats = stats_from_frame_info(buffer.frame_info())  # view_frames' per-edge figures
        now_ns = clock.now_ns()  # the ages' "now": /clock time once a clock is published
        recorded = None if now_ns is None else now_ns / 1e9
        clock_label = clock.label()
        interrupted = not node.ok()
    finally:
        if clock is not None:
            clock.close()
        _close(node, listener)
    if not stats:
        if interrupted:
            raise CliError("stopped before any tf data was received", code=130)
        raise CliError(f"no tf data received in {wait:g} s on {_tf_topics(opts, tf_topics)}{_other_tf_topics(opts)}")
    stem = time.strftime("frames_%Y-%m-%d_%H.%M.%S")
    dot_path, img_path, problem = write_graph(frames_dot(stats, recorded, clock_label), output, stem)
    if print_tree:
        print(format_frame_tree(stats))
    print(f"Wrote {dot_path}" + (f" and {img_path}" if img_path else ""))
    if problem:
        sys.stderr.write(f"zentf: warning: {printable(problem)}\n")


def _tf_topics(opts: CliOptions, topics: Optional[TfTopics] = None) -> str:
    import os

    ns = (opts.namespace if opts.namespace is not None else os.environ.get("ZENTF_NAMESPACE", "")).strip("/")
    return (topics or TfTopics()).describe(ns)


def _other_tf_topics(opts: CliOptions, shown: int = 6) -> str:
    """Where tf is published instead (e.g. under robot namespaces), from the graph: the hint a user
    needs when nothing is on the topics listened to."""
    import os

    from zentf.transport.names import normalize_namespace

    from .format import printable
    from .introspect import graph_snapshot

    try:
        _, topics = graph_snapshot(opts, 1.0, None)
    except CliError:
        return ""
    ns = normalize_namespace(opts.namespace if opts.namespace is not None
                             else os.environ.get("ZENTF_NAMESPACE", ""))
    ns = "/" + ns if ns else ""
    listened = {f"{ns}/tf", f"{ns}/tf_static"}
    found = sorted((not name.startswith(ns + "/"), name) for name, info in topics.items()
                   if name.rsplit("/", 1)[-1] in ("tf", "tf_static") and info.publishers and name not in listened)
    if not found:
        return " (nothing in the graph publishes tf)"
    names = [name for _, name in found]
    more = f" and {len(names) - shown} more" if len(names) > shown else ""
    example = names[0].rsplit("/", 1)[0].strip("/")
    return (f"; tf is published on {', '.join(printable(n) for n in names[:shown])}{more} "
            f"(e.g. zentf -n {printable(example)} tf frames)")


# --------------------------------------------------------------------------------------------
# tf monitor
# --------------------------------------------------------------------------------------------

class _FrameFigures:
    """Arrivals and delays of one child frame (last 1000, as tf2_monitor keeps)."""

    __slots__ = ("parent", "authority", "static", "arrivals", "delays")

    def __init__(self) -> None:
        from collections import deque

        self.parent = ""
        self.authority = ""
        self.static = False
        self.arrivals: Any = deque(maxlen=1000)
        self.delays: Any = deque(maxlen=1000)


class MonitorStats:
    """A BufferCore stand-in for wire.ingest_tf: records per-frame and per-node figures, then forwards.

    Delay = receive time - header stamp (0 for tf_static, as in ROS 1 tf_monitor), the receive time read
    from ``clock`` (ns, or None while a sim clock has not ticked yet: no delay is recorded then).
    """

    def __init__(self, forward: Any = None, window: float = 10.0,
                 clock: Callable[[], Optional[int]] = time.time_ns) -> None:
        import threading

        self.forward = forward
        self.window = window
        self.clock = clock
        self.lock = threading.Lock()
        self.frames: dict[str, _FrameFigures] = {}
        self.nodes: dict[str, _FrameFigures] = {}
        self.messages = 0

    def reset_delays(self) -> None:
        """Forget the delays gathered so far (they were against another clock)."""
        with self.lock:
            for figures in (*self.frames.values(), *self.nodes.values()):
                figures.delays.clear()

    def set_transforms_raw(self, samples: list, authority: str, is_static: bool) -> int:
        mono = time.monotonic()
        with self.lock:  # the clock read under the lock: a switch's reset_delays never misses a wall delay
            now_ns = self.clock()
            self.messages += 1
            total = 0.0
            timed = is_static or now_ns is not None
            for s in samples:
                parent, child, stamp = s[0], s[1], s[2]
                f = self.frames.get(child)
                if f is None:
                    f = self.frames[child] = _FrameFigures()
                f.parent, f.authority, f.static = parent, authority, is_static
                f.arrivals.append(mono)
                if timed:
                    delay = 0.0 if is_static else (now_ns - stamp) / 1e9
                    f.delays.append(delay)
                    total += delay
            n = self.nodes.get(authority)
            if n is None:
                n = self.nodes[authority] = _FrameFigures()
            n.static = is_static
            n.arrivals.append(mono)
            if timed:
                n.delays.append(total / max(1, len(samples)))
        if self.forward is not None:
            return self.forward.set_transforms_raw(samples, authority, is_static)
        return len(samples)

    def set_transform_raw(self, *args: Any) -> bool:
        return bool(self.set_transforms_raw([args[:10]], args[10], args[11]))

    def _rate(self, arrivals: Any, now: float) -> Optional[float]:
        recent = [t for t in arrivals if now - t <= self.window]
        if len(recent) < 2 or recent[-1] <= recent[0]:
            return None
        return (len(recent) - 1) / (recent[-1] - recent[0])

    def rows(self, only: Optional[list[str]] = None) -> list[tuple[str, str, str, Optional[float], float, float, bool]]:
        """(frame, parent, broadcaster, rate Hz, avg delay s, max delay s, static), sorted by frame."""
        now = time.monotonic()
        out = []
        with self.lock:
            for child in sorted(self.frames):
                if only is not None and child not in only:
                    continue
                f = self.frames[child]
                d = list(f.delays)
                out.append((child, f.parent, f.authority, None if f.static else self._rate(f.arrivals, now),
                            sum(d) / len(d) if d else 0.0, max(d) if d else 0.0, f.static))
        return out

    def node_rows(self) -> list[tuple[str, Optional[float], float, float, bool]]:
        now = time.monotonic()
        with self.lock:
            return [(name, None if n.static else self._rate(n.arrivals, now),
                     sum(n.delays) / len(n.delays) if n.delays else 0.0, max(n.delays, default=0.0), n.static)
                    for name, n in sorted(self.nodes.items())]


def _fmt_rate(rate: Optional[float], static: bool) -> str:
    if static:
        return "static"
    return "-" if rate is None else f"{rate:.1f}"


def format_monitor_text(stats: MonitorStats, title: str, chain: Optional[list[str]] = None,
                        net: Optional[tuple[float, float]] = None, clock: str = "") -> str:
    """The plain-text tf2_monitor report (used when stdout is not a terminal); ``clock`` says which
    clock the delays are in."""
    from .format import printable

    lines = [f"RESULTS: {printable(title)}"]
    if clock:
        lines.append(f"Clock: {clock}")
    if chain is not None:
        lines.append("Chain is: " + " -> ".join(printable(f) for f in chain))
        if net is not None:
            lines.append(f"Net delay     avg = {net[0] * 1e3:.3f} ms: max = {net[1] * 1e3:.3f} ms")
        else:
            lines.append("Net delay     n/a (static chain)")
    rows = stats.rows(chain)
    table = [("frame", "parent", "broadcaster", "rate_hz", "avg_delay_ms", "max_delay_ms")]
    table += [(printable(r[0]), printable(r[1]), printable(r[2]), _fmt_rate(r[3], r[6]), f"{r[4] * 1e3:.3f}",
               f"{r[5] * 1e3:.3f}") for r in rows]
    widths = [max(len(row[i]) for row in table) for i in range(6)]
    lines.append("")
    lines.append("Frames:")
    for row in table:
        lines.append("  ".join(cell.ljust(widths[i]) for i, cell in enumerate(row)).rstrip())
    lines.append("")
    lines.append("All Broadcasters:")
    for name, rate, avg, mx, static in stats.node_rows():
        freq = "static" if static else f"{_fmt_rate(rate, static)} Hz"
        lines.append(f"Node: {printable(name)} {freq}, Average Delay: {avg * 1e3:.3f} ms, Max Delay: {mx * 1e3:.3f} ms")
    return "\n".join(lines)


def _monitor_table(stats: MonitorStats, title: str, chain: Optional[list[str]],
                   net: Optional[tuple[float, float]], clock: str = "") -> Any:
    """The live rich view: frames table (+ chain/net delay caption)."""
    from rich.markup import escape
    from rich.table import Table
    from rich.text import Text

    from .format import printable

    caption = None
    if chain is not None:
        caption = escape("Chain: " + " -> ".join(printable(f) for f in chain))
        caption += (f"   net delay avg {net[0] * 1e3:.3f} ms, max {net[1] * 1e3:.3f} ms" if net
                    else "   net delay n/a (static chain)")
    heading = f"zentf tf monitor: {printable(title)}" + (f"\ndelays in {clock}" if clock else "")
    table = Table(title=escape(heading), caption=caption, expand=False)
    for col, justify in (("Frame", "left"), ("Parent", "left"), ("Broadcaster", "left"), ("Rate (Hz)", "right"),
                         ("Avg delay (ms)", "right"), ("Max delay (ms)", "right")):
        table.add_column(col, justify=justify)  # type: ignore[arg-type]
    for r in stats.rows(chain):
        table.add_row(Text(printable(r[0])), Text(printable(r[1])), Text(printable(r[2])),  # no markup from names
                      _fmt_rate(r[3], r[6]), f"{r[4] * 1e3:.3f}", f"{r[5] * 1e3:.3f}")
    return table


def _subscribe_tf(node: Any, stats: MonitorStats, topics: Optional[TfTopics] = None) -> list:
    """Subscribe the tf topics and tf_static ones (latched history) through the node's wire; each message
    into `stats`."""
    from zentf.core.messages import TFMessage

    profile = node.wire  # zentf's format or ROS 2's (--wire ros2)
    topics = topics or TfTopics()
    subs = []
    authority = profile.authority
    if profile.fixed_authority is not None:
        # the wire's authorities name no sender (ROS 2): name each publisher by its node, through the tokens
        import threading

        from zentf.tools.doctor import GraphTap
        from zentf.tools.doctor.evidence import GraphView

        names = GraphTap(node.session, profile, GraphView(), threading.Lock())
        subs.append(names)
        authority = lambda att, key: names.publisher(att)  # noqa: E731
    for topic, is_static in [*((t, True) for t in topics.static), *((t, False) for t in topics.dynamic)]:
        def on_sample(sample: Any, is_static: bool = is_static) -> None:
            try:
                profile.ingest_tf(sample.payload, stats, authority(sample.attachment, sample.key), is_static)
            except ValueError:  # not a TFMessage: the publisher's problem, never ours
                pass

        subs.append(node.create_raw_subscription(topic, on_sample, type_name=TFMessage, latched=is_static))
    return subs


@tf.command("monitor", cls=TfToolCommand, context_settings=CONTEXT_SETTINGS)
@click.argument("frame_a", required=False)
@click.argument("frame_b", required=False)
@click.option("--duration", "-d", type=finite_float(min=0.0, min_open=True), default=None,
              help="Gather this many seconds, print one report and exit (default: run until Ctrl-C).")
@click.option("--period", type=finite_float(min=0.1, max=1e6), default=2.0, show_default=True,
              help="Seconds between reports when stdout is not a terminal.")
@click.option("--window", type=finite_float(min=0.5), default=10.0, show_default=True,
              help="Seconds of arrivals used for the rates.")
@tf_topic_options
@use_sim_time_option
@with_options
def monitor(frame_a: Optional[str], frame_b: Optional[str], duration: Optional[float], period: float,
            window: float, use_sim_time: bool, *, tf_topics: TfTopics, opts: CliOptions) -> None:
    """Live table of every frame: parent, broadcaster, rate, average and max delay, like tf2_monitor.

    With FRAME_A FRAME_B it also shows the chain between them and its net delay (now - stamp of
    the latest lookup_transform(FRAME_A, FRAME_B)).
    """
    from .common import open_node

    if (frame_a is None) != (frame_b is None):
        raise click.UsageError("give both FRAME_A and FRAME_B, or neither")
    pair = (frame_a, frame_b) if frame_a and frame_b else None
    node = open_node(opts, "tf_monitor")
    subs: list = []
    clock = None
    try:
        buffer = None
        if pair:
            from zentf.transport.buffer import Buffer

            buffer = Buffer()
        stats = MonitorStats(buffer, window)
        clock = ToolClock(node, use_sim_time, on_switch=stats.reset_delays)
        stats.clock = clock.now_ns
        try:
            subs = _subscribe_tf(node, stats, tf_topics)
        except ValueError as exc:  # a bad topic pattern
            raise CliError(str(exc), code=2) from exc
        _run_monitor(stats, buffer, pair, duration, period, node.ok, clock)
    finally:
        for s in subs:
            (s.close if hasattr(s, "publisher") else s.destroy)()  # a GraphTap, or a raw subscription
        if clock is not None:
            clock.close()
        _close(node)


def _run_monitor(stats: MonitorStats, buffer: Any, pair: Optional[tuple[str, str]], duration: Optional[float],
                 period: float, ok: Any = lambda: True, clock: Any = None) -> None:
    from collections import deque

    from rich.markup import escape

    from zentf.core.exceptions import TransformException

    from .format import printable

    title = f"for {pair[0]} to {pair[1]}" if pair else "for all Frames"
    started = time.monotonic()
    end = None if duration is None else started + duration
    net: deque = deque(maxlen=1000)
    chain: Optional[list[str]] = None
    reason = ""

    def sample_chain() -> None:
        nonlocal chain, reason
        if buffer is None or pair is None:
            return
        try:
            ts = buffer.lookup_transform(pair[0], pair[1], 0)
            chain = buffer.chain_as_vector(pair[0], 0, pair[1], 0, pair[0])
            stamp = ts.header.stamp.nanoseconds
            now = stats.clock()
            if stamp and now is not None:
                net.append((now - stamp) / 1e9)
            reason = ""
        except TransformException as exc:
            reason = " ".join(str(exc).split())

    def net_figures() -> Optional[tuple[float, float]]:
        return (sum(net) / len(net), max(net)) if net else None

    def report() -> str:
        return format_monitor_text(stats, title, chain, net_figures(), clock.label() if clock is not None else "")

    was_sim = clock is not None and clock.is_sim

    live_tty = sys.stdout.isatty()
    if live_tty:
        from rich.console import Console
        from rich.live import Live

        console = Console()
        with Live(console=console, refresh_per_second=4, transient=False) as live:
            while (end is None or time.monotonic() < end) and ok():
                if clock is not None and clock.is_sim != was_sim:  # /clock appeared: the chain's delays too
                    was_sim = True
                    net.clear()
                sample_chain()
                if pair and chain is None:
                    live.update(escape(printable(f"Waiting for transform {pair[0]} -> {pair[1]}: "
                                                 f"{reason or 'no data yet'}")))
                elif not stats.frames:
                    live.update("Waiting for tf data...")
                else:
                    live.update(_monitor_table(stats, title, chain, net_figures(),
                                               clock.label() if clock is not None else ""))
                time.sleep(0.1)
    else:
        next_report = started + period
        last_wait_msg = 0.0
        while (end is None or time.monotonic() < end) and ok():
            if clock is not None and clock.is_sim != was_sim:  # /clock appeared: the chain's delays too
                was_sim = True
                net.clear()
            sample_chain()
            now = time.monotonic()
            if pair and chain is None and reason and now - last_wait_msg >= 1.0:
                sys.stderr.write(printable(f"Waiting for transform {pair[0]} -> {pair[1]}: {reason}") + "\n")
                sys.stderr.flush()
                last_wait_msg = now
            if end is None and now >= next_report:
                if stats.frames:
                    print(report() + "\n", flush=True)
                next_report += period
            time.sleep(0.05)
    if not ok():  # stopped by Ctrl-C / SIGTERM: a last report if there is anything to report
        if stats.frames and not live_tty:
            print(report(), flush=True)
        return
    if not stats.frames:
        raise CliError(f"no tf data received in {duration:g} s" if duration else "no tf data received")
    if pair and chain is None:
        raise CliError(f"no transform {pair[0]} -> {pair[1]}: {reason or 'frames never connected'}")
    if not live_tty:
        print(report(), flush=True)


def _add_doctor() -> None:
    from .tf_doctor import doctor, why

    tf.add_command(doctor)
    tf.add_command(why)


_add_doctor()
