"""`zentf launch` and `zentf clock` (click commands; zentf.cli delegates to launch_main / clock_main)."""
from __future__ import annotations

import json
import logging
import os
import sys
from pathlib import Path
from typing import Any, Optional, Sequence

import click

from zentf.cli.common import (CONTEXT_SETTINGS, CliError, CliOptions, NumberArgsCommand, clean_error, debug_requested,
                              finite_float, node_options, with_options)

from zentf.core.text import printable

from .errors import LaunchError

__all__ = ["launch", "clock", "launch_main", "clock_main", "format_description"]

log = logging.getLogger("zentf.launch")


class _LaunchFormatter(logging.Formatter):
    """``[launch] ...`` lines; names from the launch file or a child's exit escaped (``printable``)."""

    def format(self, record: logging.LogRecord) -> str:
        text = printable(record.getMessage())
        if record.levelno >= logging.ERROR:
            return f"[launch] ERROR: {text}"
        if record.levelno >= logging.WARNING:
            return f"[launch] WARNING: {text}"
        return f"[launch] {text}"


def _setup_logging(debug: bool) -> None:
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_LaunchFormatter())
    log.handlers[:] = [handler]
    log.setLevel(logging.DEBUG if debug else logging.INFO)
    log.propagate = False


def _use_color(choice: Optional[bool]) -> bool:
    if choice is not None:
        return choice
    if os.environ.get("NO_COLOR"):
        return False
    if os.environ.get("FORCE_COLOR"):
        return True
    return sys.stdout.isatty()


def format_description(desc: Any) -> str:
    """The resolved graph as YAML (what `zentf launch --print` shows)."""
    import yaml

    data: dict[str, Any] = {"file": desc.file}
    if desc.description:
        data["description"] = desc.description
    data["args"] = dict(desc.args)
    if desc.clock is not None:
        c = desc.clock
        data["clock"] = {"start": "now" if c.start is None else c.start, "rate": c.rate,
                         "frequency": c.frequency, "paused": c.paused}
    nodes = []
    for n in desc.nodes:
        item: dict[str, Any] = {"name": "/" + n.full_name, "namespace": "/" + n.namespace}
        if n.module is not None:
            item["module"] = n.module
            if len(n.cmd) > 3:
                item["arguments"] = n.cmd[3:]
        else:
            item["cmd"] = n.cmd
        item["parameters"] = n.parameters
        item["remappings"] = n.remappings
        if n.params_file:
            item["params_file"] = n.params_file
        if n.env:
            item["env"] = n.env
        if n.respawn:
            item["respawn"] = {"delay": n.respawn_delay, "max": n.respawn_max}
        if n.required:
            item["required"] = True
        item["output"] = n.output
        item["source"] = n.source
        nodes.append(item)
    data["nodes"] = nodes
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)


def _show_args(file: str) -> str:
    from .description import declared_args

    path, specs = declared_args(file)
    if not specs:
        return f"{path} declares no arguments\n"
    lines = [f"Arguments of {path} (give as name:=value):"]
    for a in specs:
        default = "(required)" if a.default is None else f"default: {a.default!r}"
        lines.append(f"  {a.name}  {default}" + (f"  - {a.description}" if a.description else ""))
    return "\n".join(lines) + "\n"


@click.command("launch", context_settings=CONTEXT_SETTINGS)
@click.argument("file")
@click.argument("args", nargs=-1, metavar="[NAME:=VALUE]...")
@click.option("--print", "print_only", is_flag=True, help="Show the resolved graph (nodes, namespaces, "
              "params, remaps) as YAML and exit without starting anything.")
@click.option("--show-args", is_flag=True, help="List the launch file's arguments and exit.")
@click.option("--log-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Directory for nodes with output: log. [env ZENTF_LOG_DIR; default ~/.zentf/log/...]")
@click.option("--color/--no-color", default=None, help="Colour the node name prefixes (default: on a TTY).")
@click.option("--stop-timeout", type=finite_float(0.1, 10.0), default=1.0, show_default=True,
              help="Seconds between SIGINT, SIGTERM and SIGKILL when stopping nodes.")
@with_options
def launch(file: str, args: tuple[str, ...], print_only: bool, show_args: bool, log_dir: Optional[Path],
           color: Optional[bool], stop_timeout: float, opts: CliOptions) -> int:
    """Start the node graph of a launch file: FILE is a path or a name in configs/ (e.g. `drones`).

    \b
    Examples:
      zentf launch drones
      zentf launch configs/drones.yaml static:=true
      zentf launch multi_robot --print
    Ctrl-C stops every node (SIGINT, then SIGTERM, then SIGKILL). The --namespace option puts the whole
    graph under a namespace. The file format is described in docs/launch.md.
    """
    try:
        code = _launch(file, args, print_only, show_args, log_dir, color, stop_timeout, opts)
    except LaunchError as exc:  # `FILE:LINE: what` alone on a line, whoever runs this command
        if opts.debug:
            raise
        _say_error(str(exc) if exc.file else f"zentf launch: error: {exc}")
        raise click.exceptions.Exit(2) from None
    if code:
        raise click.exceptions.Exit(code)
    return 0


def _launch(file: str, args: tuple[str, ...], print_only: bool, show_args: bool, log_dir: Optional[Path],
            color: Optional[bool], stop_timeout: float, opts: CliOptions) -> int:
    from .description import load_launch

    if show_args:
        click.echo(_show_args(file), nl=False)
        return 0
    _setup_logging(opts.debug)
    nopts = node_options(opts, "launch")  # flags > ZENTF_* env > defaults; CliError on bad values
    namespace = opts.namespace if opts.namespace is not None else os.environ.get("ZENTF_NAMESPACE", "")
    desc = load_launch(file, list(args), namespace=namespace)
    if print_only:
        click.echo(format_description(desc), nl=False)
        return 0
    if not desc.nodes and desc.clock is None:
        log.warning("%s starts no nodes (all conditions false?)", desc.file)
    return _run(desc, nopts, log_dir, _use_color(color), stop_timeout)


def _default_log_dir(desc: Any) -> Path:
    import time

    base = os.environ.get("ZENTF_LOG_DIR")
    if base:
        return Path(base)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    return Path.home() / ".zentf" / "log" / f"{Path(desc.file).stem}-{stamp}-{os.getpid()}"


def _run(desc: Any, nopts: Any, log_dir: Optional[Path], color: bool, stop_timeout: float) -> int:
    """Start the clock and the nodes; ``nopts``: the launcher's node options (Zenoh, wire, domain)."""
    from .supervisor import StopTimes, Supervisor

    zopts = nopts.zenoh
    clock = None
    if desc.clock is not None:
        from .sim_clock import SimClockPublisher

        try:
            clock = SimClockPublisher(desc.clock, zopts, wire=nopts.wire, domain_id=nopts.domain_id)
        except Exception as exc:
            raise CliError(f"cannot start the sim clock: {clean_error(exc)}") from exc
    env = dict(os.environ)
    env.update(zopts.to_env())
    env.update(ZENTF_WIRE=nopts.wire, ROS_DOMAIN_ID=str(nopts.domain_id))  # every node on the launcher's wire
    if env.pop("ZENTF_LISTEN", None):  # N nodes cannot all listen on one endpoint
        log.info("--listen/ZENTF_LISTEN is for the launcher's own session only; nodes do not get it")
    times = StopTimes(sigint=stop_timeout, sigterm=stop_timeout, sigkill=0.8)
    sup = Supervisor(desc.nodes, base_env=env, log_dir=log_dir or _default_log_dir(desc), color=color,
                     stop_times=times, keep_alive=clock is not None and not desc.nodes)
    log.info("launching %s: %d node(s)", desc.file, len(desc.nodes))
    try:
        return sup.run()
    finally:
        if clock is not None:
            clock.close()


@click.command("clock", cls=NumberArgsCommand, context_settings=CONTEXT_SETTINGS)
@click.argument("command", type=click.Choice(["status", "pause", "resume", "rate"]), default="status")
@click.argument("factor", required=False, type=finite_float())
@click.option("--timeout", type=finite_float(0.1, 60.0), default=3.0, show_default=True,
              help="Seconds to wait for a launcher's clock to answer.")
@click.option("--json", "as_json", is_flag=True, help="Print the clock state as JSON.")
@with_options
def clock(command: str, factor: Optional[float], timeout: float, as_json: bool, opts: CliOptions) -> int:
    """Control the sim clock of a running `zentf launch` (a launch file with a clock: section).

    \b
    zentf clock              show sim time, rate and whether it is paused
    zentf clock pause        freeze /clock
    zentf clock resume       let it run again
    zentf clock rate 2.0     sim seconds per wall second
    """
    from .sim_clock import query_clock

    if command == "rate":
        if factor is None:
            raise click.UsageError("rate needs a FACTOR, e.g. `zentf clock rate 2.0`")
        from zentf.transport.clock import MAX_RATE, MIN_RATE

        if not MIN_RATE <= factor <= MAX_RATE:
            raise click.UsageError(f"rate FACTOR must be between {MIN_RATE:g} and {MAX_RATE:g}, got {factor}")
        payload = f"rate {factor!r}"
    else:
        if factor is not None:
            raise click.UsageError(f"'{command}' takes no value")
        payload = command
    _require_clock(opts)  # none in the graph: say so now, the timeout is for a clock that is there
    zopts = node_options(opts, "clock").zenoh
    try:  # a one-shot query, as the graph listings make (zentf.cli.common.open_graph_session)
        session, _ = zopts.open_query_session()
    except Exception as exc:
        raise CliError(clean_error(exc)) from exc
    try:
        state = query_clock(session, payload, timeout)
    except (RuntimeError, ValueError) as exc:
        raise CliError(str(exc)) from exc
    finally:
        session.close()
    if as_json:
        click.echo(json.dumps(state))
    else:
        click.echo(f"sim time {state['time']:.3f} s, rate {state['rate']:g}x, "
                   f"{'paused' if state['paused'] else 'running'}")
    return 0


def _require_clock(opts: CliOptions) -> None:
    """CliError at once when no launcher's sim clock is in the graph, naming who publishes /clock if anyone
    (a bag player's clock takes no pause/resume/rate)."""
    from zentf.cli.introspect import PRESENCE_WAIT, graph_snapshot, name_list

    from .sim_clock import CLOCK_NODE_PREFIX

    nodes, topics = graph_snapshot(opts, PRESENCE_WAIT, None)
    if any(fq.rsplit("/", 1)[-1].startswith(CLOCK_NODE_PREFIX) for fq in nodes):
        return
    publishers = topics["/clock"].publishers if "/clock" in topics else []
    who = (f"/clock is published by {name_list(publishers)}, which takes no pause/resume/rate" if publishers
           else "nothing publishes /clock")
    raise CliError(f"no sim clock to control: no `zentf launch` with a clock: section is running ({who})")


def _say_error(line: str) -> None:
    """One error line on stderr; what it quotes from a file or a child is escaped (``printable``)."""
    sys.stderr.write(printable(line) + "\n")


def _main(cmd: click.Command, argv: Optional[Sequence[str]], prog: str) -> int:
    """Run a command turning every failure into one line on stderr and an exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        debug = debug_requested(args)
    except CliError as exc:
        _say_error(f"{prog}: error: {exc}")
        return exc.code
    try:
        rv = cmd.main(args=args, prog_name=prog, standalone_mode=False)
        return rv if isinstance(rv, int) else 0
    except LaunchError as exc:
        if debug:
            raise
        _say_error(str(exc) if exc.file else f"{prog}: error: {exc}")
        return 2
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.exceptions.Abort:
        return 130
    except click.exceptions.UsageError as exc:
        _say_error(f"{prog}: error: {' '.join(exc.format_message().split())} (see '{prog} --help')")
        return exc.exit_code
    except click.exceptions.ClickException as exc:
        _say_error(f"{prog}: error: {' '.join(exc.format_message().split())}")
        return exc.exit_code
    except CliError as exc:
        if debug:
            raise
        _say_error(f"{prog}: error: {clean_error(exc)}")
        return exc.code
    except KeyboardInterrupt:
        return 130
    except Exception as exc:  # noqa: BLE001 - one line, never a traceback unless --debug
        if debug:
            raise
        _say_error(f"{prog}: error: {clean_error(exc)} ({type(exc).__name__}; rerun with --debug)")
        return 1


def launch_main(argv: Optional[Sequence[str]] = None) -> int:
    return _main(launch, argv, "zentf launch")


def clock_main(argv: Optional[Sequence[str]] = None) -> int:
    return _main(clock, argv, "zentf clock")
