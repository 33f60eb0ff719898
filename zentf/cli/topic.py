"""`zentf topic list | info | echo | hz | pub`: rostopic/ros2 topic over Zenoh."""
from __future__ import annotations

import json
import queue
import sys
import time
from typing import Any, Optional

import click

from .common import (CONTEXT_SETTINGS, liveliness_wait_option, CliError, CliOptions, finite_float, node_options,
                     open_session, status, wire_profile, with_options)

__all__ = ["topic", "resolve_type_name", "render_sample"]


@click.group("topic", context_settings=CONTEXT_SETTINGS)
def topic() -> None:
    """Topics: list, info, type, find, echo, hz, pub."""


def _resolve(opts: CliOptions, name: str) -> tuple[str, str]:
    """(fully qualified topic, key expression of any type on it) of a topic name in the command's namespace."""
    from zentf.transport.names import resolve_topic

    ns = node_options(opts, "_zentf_cli").namespace or ""
    try:
        fq = resolve_topic(name, ns)
    except ValueError as exc:
        raise CliError(str(exc), code=2) from exc
    return fq, wire_profile(opts).data_key(fq, None)


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

    fq, _ = _resolve(opts, name)
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

    fq, _ = _resolve(opts, name)
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


def render_sample(payload: bytes, encoding: str, as_json: bool, key: str = "", profile: Any = None) -> str:
    """One received sample as YAML (ros2 topic echo style) or one JSON line; raw bytes if unknown.
    The wire ``profile`` (zentf's by default) decodes it: by the carried encoding, or (ros2) the key's type."""
    from zentf.transport.wire.profiles import WireProfile

    data: Any
    try:
        type_name, value, known = (profile or WireProfile()).decode_any(payload, encoding, key)
        data = value.to_dict() if hasattr(value, "to_dict") else value
    except ValueError:
        known = False
    from .format import printable

    if not known:
        if as_json:
            return json.dumps({"encoding": str(encoding), "size": len(payload), "raw_hex": payload.hex()})
        return f"# raw payload: {len(payload)} bytes, encoding {printable(encoding)}\n{payload!r}\n---"
    if as_json:  # (json.dumps escapes every control and non-ASCII character)
        return json.dumps(data, default=_json_default, separators=(",", ":"))
    import yaml

    # YAML keeps NEL, bidi overrides and other format characters raw under allow_unicode: each line escaped
    text = yaml.safe_dump(data, sort_keys=False, default_flow_style=False, allow_unicode=True).rstrip()
    return "\n".join(printable(line) for line in text.split("\n")) + "\n---"


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (bytes, bytearray, memoryview)):
        return bytes(obj).hex()
    if hasattr(obj, "to_dict"):
        return obj.to_dict()
    return str(obj)


def _subscribe(session: Any, key: str, history: bool) -> tuple[Any, "queue.Queue[tuple[bytes, str, float, str]]"]:
    """Subscriber whose Zenoh-thread callback only copies the sample into a queue."""
    inbox: "queue.Queue[tuple[bytes, str, float, str]]" = queue.Queue(maxsize=100_000)

    def on_sample(sample: Any) -> None:
        try:
            inbox.put_nowait((sample.payload.to_bytes(), str(sample.encoding), time.monotonic(),
                              str(sample.key_expr)))
        except Exception:  # noqa: BLE001 - full queue or odd sample: drop, never raise in Zenoh's thread
            pass

    if history:
        import zenoh.ext as zx

        sub = zx.declare_advanced_subscriber(session, key, on_sample,
                                             history=zx.HistoryConfig(detect_late_publishers=True))
    else:
        sub = session.declare_subscriber(key, on_sample)
    return sub, inbox


@topic.command("echo", context_settings=CONTEXT_SETTINGS)
@click.argument("name")
@click.option("--once", is_flag=True, help="Print one message and exit.")
@click.option("--count", "-c", type=click.IntRange(min=1), default=None,
              help="Exit after this many messages (default: run until Ctrl-C).")
@click.option("--json", "as_json", is_flag=True, help="One JSON object per line instead of YAML.")
@click.option("--timeout", type=finite_float(min=0.0), default=None,
              help="Exit 1 if nothing arrives within this many seconds (default: wait).")
@click.option("--no-history", is_flag=True, help="Do not fetch latched samples (e.g. of tf_static).")
@with_options
def topic_echo(name: str, once: bool, count: Optional[int], as_json: bool, timeout: Optional[float], no_history: bool,
               *, opts: CliOptions) -> None:
    """Print messages on a topic, decoded by their carried type (raw bytes when unknown)."""
    from .common import open_node

    fq, key = _resolve(opts, name)
    limit = 1 if once else count
    node = open_node(opts, "topic_echo")
    token = None
    try:
        sub, inbox = _subscribe(node.session, key, history=not no_history)
        declare = getattr(node, "_declare_entity", None)
        if declare is not None:  # show up as a subscriber, so `topic pub` and `graph` see us
            token = declare("sub", "", key)
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
            sys.stdout.write(render_sample(payload, enc, as_json, got, node.wire) + "\n")
            sys.stdout.flush()
            shown += 1
        sub.undeclare()
    finally:
        for obj in (token,):
            if obj is not None:
                try:
                    obj.undeclare()
                except Exception:  # noqa: BLE001
                    pass
        node.shutdown()


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

    fq, key = _resolve(opts, name)
    session = open_session(opts)
    try:
        sub, inbox = _subscribe(session, key, history=False)
        arrivals: deque[float] = deque(maxlen=window)
        started = time.monotonic()
        end = None if duration is None else started + duration
        next_report = started + period
        with status(f"Measuring the rate of {fq}") as st:
            while True:
                now = time.monotonic()
                stop_at = next_report if end is None else min(next_report, end)
                try:
                    _, _, t, _ = inbox.get(timeout=max(0.0, stop_at - now))
                    arrivals.append(t)
                    continue
                except queue.Empty:
                    pass
                now = time.monotonic()
                if now >= next_report:
                    text = format_hz(list(arrivals))
                    if text:
                        sys.stdout.write(text + "\n")
                        sys.stdout.flush()
                    else:
                        st.update(f"Measuring the rate of {fq}: no messages yet")
                    next_report += period
                if end is not None and now >= end:
                    break
        sub.undeclare()
        if len(arrivals) < 2:
            raise CliError(f"nothing published on {fq} in {duration:g} s" if not arrivals else
                           f"only one message on {fq} in {duration:g} s: no rate")
    finally:
        session.close()


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
    import yaml

    from zentf.core.messages import message_type
    from zentf.core.safe_yaml import YamlRefused, load

    try:
        plain = load(data, limit=DATA_LIMIT) if data.strip() else {}
    except YamlRefused as exc:
        raise CliError(f"DATA refused: {exc}", code=2) from None
    except yaml.YAMLError as exc:
        raise CliError(f"DATA is not valid YAML/JSON: {' '.join(str(exc).split())}", code=2) from exc
    if plain is None:
        plain = {}
    try:
        msg = message_type(type_name).from_dict(plain)
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
