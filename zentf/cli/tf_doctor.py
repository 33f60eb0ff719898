"""`zentf tf doctor` and `zentf tf why`: what is wrong with the tf tree, and why one lookup fails.

Both run on the live graph (listening ``--duration`` seconds) or on a recording (``--bag``); the
diagnostics themselves are the library's (zentf.tools.doctor), so a program gets the same answers.
"""
from __future__ import annotations

import json
import sys
import time
from typing import Any, Optional

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, StampSeconds, finite_float, status, with_options
from .tf_topics import TfToolCommand, TfTopics, tf_topic_options

__all__ = ["doctor", "why"]


def _print_text(text: str) -> None:
    from .format import printable

    for line in text.splitlines():
        print(printable(line))
    sys.stdout.flush()


def _open_doctor(opts: CliOptions, tool: str, topics: TfTopics, use_sim_time: bool, tolerance: float) -> tuple:
    from zentf.tools.doctor import TfDoctor, Thresholds
    from zentf.transport.node import Node

    from .common import _session_error, cli_node_name, node_options

    nopts = node_options(opts, cli_node_name(tool))
    nopts.params.update(topics.params)
    if use_sim_time:
        nopts.params["use_sim_time"] = True
    try:
        node = Node(options=nopts, check_unique=False)
    except Exception as exc:  # noqa: BLE001 - zenoh raises plain errors here
        if opts.debug:
            raise
        raise CliError(_session_error(exc, opts)) from exc
    try:
        doc = TfDoctor(node, tf_topics=topics.dynamic, tf_static_topics=topics.static,
                       thresholds=Thresholds(clock_tolerance=tolerance))
    except ValueError as exc:  # a bad topic pattern
        node.shutdown()
        raise CliError(str(exc), code=2) from exc
    except BaseException:
        node.shutdown()
        raise
    return node, doc


def _listen(node: Any, seconds: float, what: str) -> None:
    deadline = time.monotonic() + seconds
    with status(f"{what} for {seconds:g} s") as st:
        while (left := deadline - time.monotonic()) > 0 and node.ok():
            st.update(f"{what} for {seconds:g} s ({left:.1f} s left)")
            time.sleep(min(0.1, left))


def _check_window(bag: Optional[str], start: Optional[float], end: Optional[float]) -> None:
    if bag is None and (start is not None or end is not None):
        raise click.BadParameter("only with --bag", param_hint="'--start'/'--end'")
    if start is not None and end is not None and end < start:
        raise click.BadParameter(f"--end {end:g} is before --start {start:g}", param_hint="'--end'")


def _warn(line: str) -> None:
    from .format import printable

    sys.stderr.write(printable(f"zentf: warning: {line}") + "\n")


_COMMON = [
    click.option("--duration", "-d", type=finite_float(min=0.0, min_open=True), default=None,
                 help="Seconds to listen to the live graph [doctor: 5, why: 2]."),
    click.option("--bag", "bag_file", type=click.Path(), default=None,
                 help="Diagnose this recording (any bag format zentf reads) instead of the live graph."),
    click.option("--start", type=StampSeconds(), default=None, help="With --bag: from this time (s) on."),
    click.option("--end", type=StampSeconds(), default=None, help="With --bag: up to this time (s)."),
    click.option("--json", "as_json", is_flag=True, help="One JSON document on stdout, for machines."),
    click.option("--clock-tolerance", type=finite_float(min=0.0), default=1.0, show_default=True,
                 help="Seconds a publisher's stamps may sit from arrival before it is a clock problem."),
    click.option("--use-sim-time", is_flag=True, help="Compare stamps with /clock (sim time) instead of the wall "
                                                      "clock."),
]


def _common(func: Any) -> Any:
    for deco in reversed(_COMMON):
        func = deco(func)
    return func


@click.command("doctor", cls=TfToolCommand, context_settings=CONTEXT_SETTINGS)
@_common
@click.option("--verbose", "-v", is_flag=True, help="Also print every edge's rate, jitter, largest gap and delay.")
@tf_topic_options
@with_options
def doctor(duration: Optional[float], bag_file: Optional[str], start: Optional[float], end: Optional[float],
           as_json: bool, clock_tolerance: float, use_sim_time: bool, verbose: bool, *, tf_topics: TfTopics,
           opts: CliOptions) -> None:
    """Diagnose the tf tree: one section per problem (what, evidence, what to do), then a summary line.

    Checks several publishers of one frame, frames that change parent, static frames sent on /tf
    (and moving ones on /tf_static), dead frames and publishers that left the graph, trees that do
    not connect, loops, publishers whose stamps sit ahead of or behind this machine's clock, and what
    a listener refuses (TF_OLD_DATA, TF_REPEATED_DATA, TF_FUTURE_DATA...) per sender. Exit code 0
    when nothing is wrong, 1 when something is.
    """
    from zentf.tools.doctor import Thresholds

    _check_window(bag_file, start, end)
    if bag_file is not None:
        from zentf.tools.bag import BagError
        from zentf.tools.doctor import diagnose_bag

        try:
            report = diagnose_bag(bag_file, start=start, end=end, thresholds=Thresholds(clock_tolerance=clock_tolerance),
                                  on_problem=_warn)
        except BagError as exc:
            raise CliError(str(exc)) from exc
    else:
        node, doc = _open_doctor(opts, "tf_doctor", tf_topics, use_sim_time, clock_tolerance)
        try:
            _listen(node, 5.0 if duration is None else duration, "Listening to tf")
            interrupted = not node.ok()
            report = doc.report()
        finally:
            doc.close()
            node.shutdown()
        if interrupted and not report.messages:
            raise CliError("stopped before any tf data was received", code=130)
    if as_json:
        print(json.dumps(report.to_dict(), indent=1, default=str))
    else:
        _print_text(report.text(verbose=verbose))
    if not report.healthy:
        click.get_current_context().exit(1)


@click.command("why", cls=TfToolCommand, context_settings=CONTEXT_SETTINGS)
@click.argument("target")
@click.argument("source")
@click.option("--time", "-t", "at_time", type=StampSeconds(), default=None,
              help="Explain the lookup at this time (s). Default: at now and at Time(0).")
@_common
@tf_topic_options
@with_options
def why(target: str, source: str, at_time: Optional[float], duration: Optional[float], bag_file: Optional[str],
        start: Optional[float], end: Optional[float], as_json: bool, clock_tolerance: float, use_sim_time: bool, *,
        tf_topics: TfTopics, opts: CliOptions) -> None:
    """Explain lookup_transform(TARGET, SOURCE): the chain, each edge's publisher, time range, rate and age,
    whether the lookup answers (at --time, or now and Time(0)), every edge that makes it fail, and the fix.

    Exit code 0 when the lookup answers, 1 when it does not.
    """
    from zentf.core.time import Time

    for value, what in ((target, "TARGET"), (source, "SOURCE")):
        if not value.strip():
            raise click.BadParameter("a frame id cannot be empty", param_hint=f"'{what}'")
    _check_window(bag_file, start, end)
    when = None if at_time is None else Time.from_sec(at_time)
    if bag_file is not None:
        ex = _why_bag(bag_file, target, source, when, start, end, clock_tolerance)
    else:
        node, doc = _open_doctor(opts, "tf_why", tf_topics, use_sim_time, clock_tolerance)
        try:
            _listen(node, 2.0 if duration is None else duration, f"Listening to tf for {target} -> {source}")
            ex = doc.why(target, source, when)
            heard = doc.evidence.messages
        finally:
            doc.close()
            node.shutdown()
        if not heard and ex.problem:
            ex.fixes.append(f"no tf data arrived on {tf_topics.describe(node.get_namespace())}: check the "
                            "namespace, --tf-topic/--all-namespaces and --wire")
    if as_json:
        print(json.dumps(ex.to_dict(), indent=1, default=str))
    else:
        _print_text(ex.text())
    if not ex.ok:
        click.get_current_context().exit(1)


def _why_bag(path: str, target: str, source: str, when: Any, start: Optional[float], end: Optional[float],
             tolerance: float) -> Any:
    from zentf.core.time import Time
    from zentf.tools.bag import BagError, load_buffer, load_buffer_at
    from zentf.tools.doctor import explain_lookup

    try:
        if when is not None and start is None and end is None:
            buffer = load_buffer_at(path, when, (target, source), on_problem=_warn)
        else:
            buffer = load_buffer(path, on_problem=_warn, start=None if start is None else Time.from_sec(start),
                                 end=None if end is None else Time.from_sec(end))
    except BagError as exc:
        raise CliError(str(exc)) from exc
    infos = [i for i in buffer.frame_info() if not i["static"]]
    # "now" in a recording: its end (the newest stamp), or the asked time
    end_ns = max((i["most_recent_transform"].nanoseconds for i in infos), default=0)
    now = end_ns if when is None else max(end_ns, when.nanoseconds)
    return explain_lookup(buffer, target, source, when, now=now, clock_tolerance=tolerance)
