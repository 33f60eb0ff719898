"""`zentf topic list | info | type | find | echo | hz | bw | delay | pub`: ros2 topic over Zenoh."""
from __future__ import annotations

import json
import queue
import sys
import time
from typing import Any, Optional

import click

from .common import (CONTEXT_SETTINGS, liveliness_wait_option, CliError, CliOptions, finite_float, node_options,
                     status, with_options)
from .toolclock import use_sim_time_option

__all__ = ["topic", "resolve_type_name", "render_sample", "message_type_arg"]


@click.group("topic", context_settings=CONTEXT_SETTINGS)
def topic() -> None:
    """Topics: list, info, type, find, echo, hz, bw, delay, pub."""


def _resolve(opts: CliOptions, name: str) -> str:
    """The fully qualified topic of a topic name in the command's namespace (CliError if not a name)."""
    from zentf.transport.names import resolve_topic

    ns = node_options(opts, "_zentf_cli").namespace or ""
    try:
        return resolve_topic(name, ns)
    except ValueError as exc:
        raise CliError(str(exc), code=2) from exc


@topic.command("list", context_settings=CONTEXT_SETTINGS)
@click.option("--verbose", "-v", is_flag=True, help="Show types, publishers and subscribers.")
@click.option("--show-types", "-t", is_flag=True, help="Show each topic's type.")
@liveliness_wait_option
@with_options
def topic_list(verbose: bool, show_types: bool, wait: float, *, opts: CliOptions) -> None:
    """List the topics that live nodes publish or subscribe (from liveliness; no master)."""
    from .introspect import graph_namespace, graph_snapshot

    from .format import printable as p

    _, topics = graph_snapshot(opts, wait, graph_namespace(opts))
    for _, t in sorted(topics.items()):
        types = p(", ".join(t.types) or "?")
        if verbose:
            print(f"{p(t.name)} [{types}]")
            print(f"  publishers ({len(t.publishers)}): {p(', '.join(t.publishers))}")
            print(f"  subscribers ({len(t.subscribers)}): {p(', '.join(t.subscribers))}")
        elif show_types:
            print(f"{p(t.name)} [{types}]")
        else:
            print(p(t.name))


@topic.command("info", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@liveliness_wait_option
@with_options
def topic_info(name: str, wait: float, *, opts: CliOptions) -> None:
    """Type, publishers and subscribers of one topic."""
    from .introspect import graph_snapshot

    fq = _resolve(opts, name)
    _, topics = graph_snapshot(opts, wait, None)
    t = topics.get(fq)
    if t is None:
        raise CliError(f"unknown topic {fq}: no live node publishes or subscribes it")
    from .format import printable as p

    print(f"Topic: {p(t.name)}")
    print(f"Type: {p(', '.join(t.types) or '?')}")
    print(f"Publisher count: {len(t.publishers)}")
    for n in t.publishers:
        print(f"  {p(n)}")
    print(f"Subscription count: {len(t.subscribers)}")
    for n in t.subscribers:
        print(f"  {p(n)}")


@topic.command("type", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@liveliness_wait_option
@with_options
def topic_type(name: str, wait: float, *, opts: CliOptions) -> None:
    """The type of topic NAME, as its live publishers and subscribers declare it (ros2 topic type)."""
    from .format import printable
    from .introspect import graph_snapshot

    fq = _resolve(opts, name)
    t = graph_snapshot(opts, wait, None)[1].get(fq)
    if t is None:
        raise CliError(f"unknown topic {fq}: no live node publishes or subscribes it")
    for type_name in sorted(t.types) or ["?"]:
        print(printable(type_name))


@topic.command("find", context_settings=CONTEXT_SETTINGS)
@click.argument("type_name", metavar="TYPE")
@liveliness_wait_option
@with_options
def topic_find(type_name: str, wait: float, *, opts: CliOptions) -> None:
    """The topics of type TYPE ('geometry_msgs/msg/Point' or 'geometry_msgs/Point'; ros2 topic find)."""
    from .format import printable
    from .introspect import graph_namespace, graph_snapshot

    parts = type_name.strip().split("/")
    want = {type_name.strip()} | ({f"{parts[0]}/msg/{parts[1]}"} if len(parts) == 2 else set())
    for t in sorted(graph_snapshot(opts, wait, graph_namespace(opts))[1].values(), key=lambda t: t.name):
        if want & set(t.types):
            print(printable(t.name))


def render_sample(payload: bytes, encoding: str, as_json: bool, key: str = "", profile: Any = None,
                  view: Any = None) -> str:
    """One received sample as YAML (ros2 topic echo style), CSV or one JSON line; raw bytes if unknown.
    The wire ``profile`` (zentf's by default) decodes it: by the carried encoding, or (ros2) the key's type;
    ``view`` (zentf.cli.msgview.View) carries echo's --field/--csv/--no-arr/... choices."""
    from zentf.transport.wire.profiles import ZentfProfile

    from .msgview import FieldError, View

    view = view or View(as_json=as_json, truncate=None)
    data: Any
    type_name = None
    try:
        type_name, value, known = (profile or ZentfProfile()).decode_any(payload, encoding, key)
        data = value.to_dict() if hasattr(value, "to_dict") else value
    except ValueError:
        known = False
    from .format import printable

    if known and not _shallow(data, MAX_DEPTH):
        known = False  # no ROS type nests this deep: shown raw, not walked (a crafted payload)
    if not known:
        if view.field:
            raise FieldError(f"cannot select field {'.'.join(view.field)!r}: the payload is not a message zentf "
                             f"can decode (encoding {printable(encoding)}, type {printable(type_name or '?')})")
        if as_json:
            return json.dumps({"encoding": str(encoding), "size": len(payload), "raw_hex": payload.hex()})
        return f"# raw payload: {len(payload)} bytes, encoding {printable(encoding)}\n{payload!r}\n---"
    data, type_name = view.select(data, type_name)
    return view.render(data, type_name)


#: Nesting beyond which a decoded payload is shown raw: ROS types are a few levels deep, and the views walk
#: values recursively.
MAX_DEPTH = 64


def _shallow(value: Any, limit: int) -> bool:
    """Whether ``value`` nests no deeper than ``limit`` dicts/lists (walked without recursion)."""
    todo = [(value, 0)]
    while todo:
        v, depth = todo.pop()
        if isinstance(v, dict):
            v = list(v.values())
        elif not isinstance(v, (list, tuple)):
            continue
        if depth >= limit:
            return False
        todo.extend((x, depth + 1) for x in v if isinstance(x, (dict, list, tuple)))
    return True


def message_type_arg(text: str) -> str:
    """TYPE of `topic echo` ('pkg/msg/Name' or 'pkg/Name') -> the full name of a type zentf can decode."""
    from zentf.core.messages import MESSAGE_TYPES
    from zentf.ros import message_types

    from .format import printable

    known = set(MESSAGE_TYPES) | set(message_types())
    name = text.strip()
    parts = name.split("/")
    if len(parts) == 2:
        name = f"{parts[0]}/msg/{parts[1]}"
    if name not in known:
        raise CliError(f"unknown message type {printable(text)!r} (see 'zentf interface list -m')", code=2)
    return name


def _check_type_in_graph(opts: CliOptions, fq: str, type_name: str) -> None:
    """A TYPE that the graph's publishers and subscribers of the topic do not declare is one line (exit 2)."""
    from .format import printable
    from .introspect import PRESENCE_WAIT, graph_snapshot

    t = graph_snapshot(opts, PRESENCE_WAIT, None)[1].get(fq)
    if t is not None and t.types and type_name not in t.types:
        raise CliError(f"topic {printable(fq)} has type {printable(', '.join(sorted(t.types)))}, not {type_name}",
                       code=2)


def _subscribe(node: Any, fq: str, history: bool, type_name: Optional[str] = None,
               stamp: Any = None) -> tuple[Any, "queue.Queue[tuple[bytes, str, Any, str]]"]:
    """A raw subscription on the node's wire (of ``type_name``, any type with None) whose callback (Zenoh's
    thread) only queues (payload, encoding, ``stamp()``'s value on arrival (time.monotonic() by default),
    key); it shows in the graph, so `topic pub` and `graph` see the command."""
    inbox: "queue.Queue[tuple[bytes, str, Any, str]]" = queue.Queue(maxsize=100_000)
    when = stamp or time.monotonic

    def on_sample(sample: Any) -> None:
        try:
            inbox.put_nowait((sample.payload, sample.encoding, when(), sample.key))
        except queue.Full:  # the printer is behind: drop
            pass

    return node.create_raw_subscription(fq, on_sample, type_name=type_name, latched=history), inbox


@topic.command("echo", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@click.argument("type_name", metavar="[TYPE]", required=False)
@click.option("--once", is_flag=True, help="Print one message and exit.")
@click.option("--count", "-c", type=click.IntRange(min=1), default=None,
              help="Exit after this many messages (default: run until Ctrl-C).")
@click.option("--field", default=None, help="Print only this field ('.' between levels, e.g. 'pose.position').")
@click.option("--csv", "as_csv", is_flag=True, help="One line per message: every field, comma separated.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object per line instead of YAML (never truncated).")
@click.option("--no-arr", is_flag=True, help="Show arrays as their type and length, not their values.")
@click.option("--no-str", is_flag=True, help="Show strings as their length, not their text.")
@click.option("--truncate-length", "-l", type=click.IntRange(min=0), default=128, show_default=True,
              help="Cut arrays, bytes and strings after this many elements (shown as '...').")
@click.option("--full-length", "-f", is_flag=True, help="Do not cut arrays, bytes and strings.")
@click.option("--timeout", type=finite_float(min=0.0), default=None,
              help="Exit 1 if nothing arrives within this many seconds (default: wait).")
@click.option("--no-history", is_flag=True, help="Do not fetch latched samples (e.g. of tf_static).")
@with_options
def topic_echo(name: str, type_name: Optional[str], once: bool, count: Optional[int], field: Optional[str],
               as_csv: bool, as_json: bool, no_arr: bool, no_str: bool, truncate_length: int, full_length: bool,
               timeout: Optional[float], no_history: bool, *, opts: CliOptions) -> None:
    """Print messages on a topic (ros2 topic echo), decoded by their carried type (raw bytes when unknown).

    TYPE, when given, must be the topic's type in the graph; only messages of that type are shown.
    """
    from .common import open_node
    from .msgview import FieldError, View, field_type, parse_field

    if as_csv and as_json:
        raise click.UsageError("--csv and --json exclude each other")
    try:
        path = parse_field(field)
    except FieldError as exc:
        raise CliError(str(exc), code=2) from exc
    fq = _resolve(opts, name)
    want = message_type_arg(type_name) if type_name else None
    if want is not None:
        if path:
            try:
                field_type(want, path)
            except FieldError as exc:
                raise CliError(str(exc), code=2) from exc
        _check_type_in_graph(opts, fq, want)
    view = View(csv=as_csv, as_json=as_json, no_arr=no_arr, no_str=no_str,
                truncate=None if full_length or as_json else truncate_length, field=path)
    limit = 1 if once else count
    node = open_node(opts, "topic_echo")
    try:
        try:  # ros2: the type is in the key; zentf: the same key
            _, inbox = _subscribe(node, fq, history=not no_history, type_name=want)
        except ValueError:  # no ROS 2 definition of TYPE: every type's key, filtered below
            _, inbox = _subscribe(node, fq, history=not no_history)
        started = time.monotonic()
        shown = 0
        while (not limit or shown < limit) and node.ok():
            wait = 0.5
            if timeout is not None and shown == 0:
                wait = started + timeout - time.monotonic()
                if wait <= 0:
                    raise CliError(f"nothing published on {fq} within {timeout:g} s")
            try:
                if shown == 0:
                    with status(f"Waiting for messages on {fq}"):
                        payload, enc, _, got = inbox.get(timeout=min(wait, 0.5))
                else:
                    payload, enc, _, got = inbox.get(timeout=wait)
            except queue.Empty:
                continue
            if want is not None and node.wire.sample_type(got, enc) not in (None, want):
                continue  # another type on the same name: TYPE picks
            try:
                text = render_sample(payload, enc, as_json, got, node.wire, view)
            except FieldError as exc:
                raise CliError(str(exc), code=2) from exc
            sys.stdout.write(text + "\n")
            sys.stdout.flush()
            shown += 1
    finally:
        node.shutdown()  # the subscription with it


@topic.command("hz", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@click.option("--window", "-w", type=click.IntRange(min=2), default=1000, show_default=True,
              help="Messages in the moving window.")
@click.option("--duration", "-d", type=finite_float(min=0.0), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@click.option("--period", type=finite_float(min=0.05, max=1e6), default=1.0, show_default=True,
              help="Seconds between reports.")
@with_options
def topic_hz(name: str, window: int, duration: Optional[float], period: float, *, opts: CliOptions) -> None:
    """Print the publishing rate of a topic (average, min/max period, std dev)."""
    from collections import deque

    from .format import format_hz

    from .common import open_node

    fq = _resolve(opts, name)
    node = open_node(opts, "topic_hz")
    try:
        _, inbox = _subscribe(node, fq, history=False)
        arrivals: deque[float] = deque(maxlen=window)
        _report_loop(inbox, lambda item: arrivals.append(item[2]), lambda: format_hz(list(arrivals)),
                     duration, period, f"Measuring the rate of {fq}", node.ok)
        if duration is not None and len(arrivals) < 2:
            raise CliError(f"nothing published on {fq} in {duration:g} s" if not arrivals else
                           f"only one message on {fq} in {duration:g} s: no rate")
    finally:
        node.shutdown()


@topic.command("bw", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@click.option("--window", "-w", type=click.IntRange(min=1), default=100, show_default=True,
              help="Messages in the moving window.")
@click.option("--duration", "-d", type=finite_float(min=0.0, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@click.option("--period", type=finite_float(min=0.05), default=1.0, show_default=True,
              help="Seconds between reports.")
@with_options
def topic_bw(name: str, window: int, duration: Optional[float], period: float, *, opts: CliOptions) -> None:
    """Print the bandwidth a topic uses (ros2 topic bw): bytes per second as received, message sizes."""
    from .common import open_node
    from .topic_stats import BandwidthWindow

    fq = _resolve(opts, name)
    node = open_node(opts, "topic_bw")
    try:
        _, inbox = _subscribe(node, fq, history=False)
        print(f"Subscribed to [{fq}]", flush=True)
        stats = BandwidthWindow(window)
        _report_loop(inbox, lambda item: stats.add(item[2], len(item[0])), lambda: stats.report(time.monotonic()),
                     duration, period, f"Measuring the bandwidth of {fq}", node.ok)
        if duration is not None and len(stats.times) < 2:
            raise CliError(f"nothing published on {fq} in {duration:g} s" if not stats.times else
                           f"only one message on {fq} in {duration:g} s: no bandwidth")
    finally:
        node.shutdown()


def _report_loop(inbox: "queue.Queue", take: Any, report: Any, duration: Optional[float], period: float,
                 what: str, ok: Any = lambda: True) -> None:
    """Feed arrivals to ``take`` and print ``report()`` every ``period`` s, until ``duration`` s, Ctrl-C or
    not ``ok()`` (a node's shutdown)."""
    started = time.monotonic()
    end = None if duration is None else started + duration
    next_report = started + period
    with status(what) as st:
        while ok():
            now = time.monotonic()
            stop_at = min(next_report, now + 0.5) if end is None else min(next_report, end, now + 0.5)
            try:
                take(inbox.get(timeout=max(0.0, stop_at - now)))
                continue
            except queue.Empty:
                pass
            now = time.monotonic()
            if now >= next_report:
                text = report()
                if text:
                    sys.stdout.write(text + "\n")
                    sys.stdout.flush()
                else:
                    st.update(f"{what}: no messages yet")
                next_report += period
            if end is not None and now >= end:
                break


@topic.command("delay", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@click.option("--window", "-w", type=click.IntRange(min=1), default=10000, show_default=True,
              help="Messages in the moving window.")
@click.option("--duration", "-d", type=finite_float(min=0.0, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@click.option("--period", type=finite_float(min=0.05), default=1.0, show_default=True,
              help="Seconds between reports.")
@use_sim_time_option
@with_options
def topic_delay(name: str, window: int, duration: Optional[float], period: float, use_sim_time: bool, *,
                opts: CliOptions) -> None:
    """Print how late a topic's messages arrive (ros2 topic delay): now minus header.stamp, in /clock time
    under sim time."""
    from .common import open_node
    from .format import printable
    from .toolclock import ToolClock
    from .topic_stats import DelayWindow, header_stamp_ns

    fq = _resolve(opts, name)
    node = open_node(opts, "topic_delay")
    clock = None
    try:
        stats = DelayWindow(window)
        clock = ToolClock(node, use_sim_time)
        _, inbox = _subscribe(node, fq, history=False, stamp=lambda: (clock.is_sim, clock.now_ns()))
        seen = {"sim": clock.is_sim, "last": None, "count": 0}

        def take(item: tuple) -> None:
            payload, enc, (sim, now), got = item
            if sim != seen["sim"]:  # /clock started: delays against the wall clock mean nothing now
                seen["sim"], seen["last"] = sim, None
                if stats.delays:
                    print("now in /clock time (sim time), resetting counters", flush=True)
                stats.clear()
            if now is None or now == 0:  # sim time before the first /clock
                return
            if seen["last"] is not None and now < seen["last"]:
                print("time has reset, resetting counters", flush=True)
                stats.clear()
            seen["last"] = now
            try:
                type_name, value, known = node.wire.decode_any(payload, enc, got)
            except ValueError as exc:
                raise CliError(f"a message on {fq} could not be decoded: {printable(str(exc))}") from exc
            if not known:
                raise CliError(f"{fq} carries {printable(type_name or enc)}, which zentf cannot decode: no header "
                               "stamp to measure a delay from", code=2)
            stamp = header_stamp_ns(value.to_dict() if hasattr(value, "to_dict") else value)
            if stamp is None:
                raise CliError(f"{fq} carries {printable(type_name or '?')}, which has no header: no stamp to "
                               "measure a delay from", code=2)
            seen["count"] += 1
            stats.add(now - stamp)

        _report_loop(inbox, take, stats.report, duration, period, f"Measuring the delay of {fq}", node.ok)
        if duration is not None and not stats.delays:
            why = " (no /clock yet: sim time)" if seen["count"] == 0 and clock.is_sim and clock.now_ns() is None else ""
            raise CliError(f"nothing published on {fq} in {duration:g} s{why}")
    finally:
        if clock is not None:
            clock.close()
        node.shutdown()


def resolve_type_name(text: str) -> str:
    """'geometry_msgs/msg/Point', 'geometry_msgs/Point' or 'Point' -> the registered type name."""
    from zentf.core.messages import MESSAGE_TYPES

    if text in MESSAGE_TYPES:
        return text
    parts = text.split("/")
    if len(parts) == 2 and f"{parts[0]}/msg/{parts[1]}" in MESSAGE_TYPES:
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 1:
        hits = [t for t in MESSAGE_TYPES if t.rsplit("/", 1)[-1] == text]
        if len(hits) == 1:
            return hits[0]
        if len(hits) > 1:
            raise CliError(f"ambiguous type {text!r}: one of {', '.join(sorted(hits))}", code=2)
    known = ", ".join(sorted(MESSAGE_TYPES))
    raise CliError(f"unknown message type {text!r} (known: {known})", code=2)


#: Longest DATA of `topic pub` / `service call` (characters).
DATA_LIMIT = 1024 * 1024


def parse_message(type_name: str, data: str) -> Any:
    """DATA (YAML or JSON) -> message of the type; one-line CliError naming the bad field."""
    from zentf.core.messages import message_type

    return parse_message_as(message_type(type_name), data)


def parse_message_as(cls: Any, data: str) -> Any:
    """DATA (YAML or JSON) -> a ``cls`` message; one-line CliError naming the bad field."""
    import yaml

    from zentf.core.safe_yaml import YamlRefused, load

    type_name = cls.TYPE_NAME
    try:
        plain = load(data, limit=DATA_LIMIT) if data.strip() else {}
    except YamlRefused as exc:
        raise CliError(f"DATA refused: {exc}", code=2) from None
    except yaml.YAMLError as exc:
        raise CliError(f"DATA is not valid YAML/JSON: {' '.join(str(exc).split())}", code=2) from exc
    if plain is None:
        plain = {}
    try:
        msg = cls.from_dict(plain)
    except (ValueError, TypeError) as exc:
        raise CliError(f"bad DATA for {type_name}: {exc}", code=2) from exc
    where = _out_of_range(msg.to_dict() if hasattr(msg, "to_dict") else plain)
    if where:  # msgpack would raise a bare OverflowError at the first publish
        raise CliError(f"bad DATA for {type_name}: {where[0]}: {where[1]} is out of range "
                       f"(at most 64-bit integers)", code=2)
    return msg


def _out_of_range(value: Any, path: str = "") -> Optional[tuple[str, int]]:
    """(field path, value) of the first integer that no 64-bit field can hold, else None."""
    if isinstance(value, dict):
        for k, v in value.items():
            hit = _out_of_range(v, f"{path}.{k}" if path else str(k))
            if hit:
                return hit
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            hit = _out_of_range(v, f"{path}[{i}]")
            if hit:
                return hit
    elif isinstance(value, int) and not isinstance(value, bool) and not -2 ** 63 <= value < 2 ** 64:
        return path, value
    return None


@topic.command("pub", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@click.argument("type_name", metavar="TYPE")
@click.argument("data", default="{}", required=False)
@click.option("--rate", "-r", type=finite_float(min=0.001, max=1e6), default=1.0, show_default=True,
              help="Messages per second.")
@click.option("--once", "-1", is_flag=True, help="Publish one message and exit.")
@click.option("--times", "-t", type=click.IntRange(min=1), default=None,
              help="Publish this many messages and exit (default: until Ctrl-C; ROS 2's 0 is refused).")
@click.option("--wait-matching", type=finite_float(min=0.0), default=1.0, show_default=True,
              help="Before the first message, wait up to this long for a subscriber.")
@with_options
def topic_pub(name: str, type_name: str, data: str, rate: float, once: bool, times: Optional[int], wait_matching: float,
              *, opts: CliOptions) -> None:
    """Publish DATA (YAML or JSON, e.g. '{x: 1.0}') as a TYPE message on a topic."""
    from .common import open_node

    tname = resolve_type_name(type_name)
    msg = parse_message(tname, data)
    _resolve(opts, name)  # validate the name before opening anything
    limit = 1 if once else times
    node = open_node(opts, "topic_pub")
    try:
        pub = node.create_publisher(name, type(msg))
        _wait_for_subscriber(node, pub.topic_name, wait_matching)
        sent = 0
        next_t = time.monotonic()
        from .tf import _sleep_until

        while (not limit or sent < limit) and node.ok():
            pub.publish(msg)
            sent += 1
            print(f"publishing #{sent}: {type(msg).__name__} on {pub.topic_name}", flush=True)
            if limit and sent >= limit:
                break
            next_t += 1.0 / rate
            if not _sleep_until(node, next_t):
                break
    finally:
        node.shutdown()


def _wait_for_subscriber(node: Any, topic: str, timeout: float) -> bool:
    """Block until some live node subscribes `topic` (liveliness), at most `timeout` s."""
    if timeout <= 0:
        return False
    from zentf.transport.graph import GraphWatcher

    watcher = GraphWatcher(node.session, profile=node.wire)
    try:
        with status("Waiting for a subscriber"):
            return watcher.wait_for(
                lambda entries: any(e.kind == "sub" and e.topic == topic for e in entries), timeout)
    finally:
        watcher.close()
