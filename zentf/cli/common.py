"""Shared CLI plumbing: Zenoh/node options on every command, one-line errors, spinners on a TTY."""
from __future__ import annotations

import functools
import math
import os
import re
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Optional, Sequence

import click

__all__ = ["CliError", "CliOptions", "CONTEXT_SETTINGS", "FiniteFloat", "FiniteFloatRange", "StampSeconds",
           "NumberArgsCommand", "finite_float", "liveliness_wait_option", "with_options", "open_node", "open_session",
           "open_graph_session",
           "node_options", "status", "cli_node_name", "clean_error", "wire_profile", "debug_requested", "global_options",
           "outer_argv", "cli_options"]


class CliError(Exception):
    """A user-facing failure: printed as one line, exit code `code`, no traceback."""

    def __init__(self, message: str, code: int = 1) -> None:
        super().__init__(message)
        self.code = code


CONTEXT_SETTINGS = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


#: The largest magnitude a float option takes (~31 years in seconds): beyond it, sleeps, waits and
#: Zenoh timeouts overflow ("timestamp out of range", "negative timeout").
FLOAT_LIMIT = 1e9


def _refuse_non_finite(value: float, ptype: click.ParamType, param: Any, ctx: Any,
                       limit: Optional[float] = FLOAT_LIMIT) -> float:
    if not math.isfinite(value):
        ptype.fail(f"{value!r} is not finite", param, ctx)
    if limit is not None and abs(value) > limit:
        ptype.fail(f"{value:g} is too large (at most {limit:g})", param, ctx)
    return value


class FiniteFloat(click.types.FloatParamType):
    """A float that refuses NaN, ±inf and absurd magnitudes: a NaN timeout would wait (or loop) forever."""

    limit: Optional[float] = FLOAT_LIMIT

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        return _refuse_non_finite(super().convert(value, param, ctx), self, param, ctx, self.limit)


class FiniteFloatRange(click.FloatRange):
    """click.FloatRange that refuses NaN and ±inf first (NaN compares false, so a range alone lets it in)."""

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        rv = click.types.FloatParamType.convert(self, value, param, ctx)
        return super().convert(_refuse_non_finite(rv, self, param, ctx), param, ctx)


class StampSeconds(FiniteFloat):
    """A time stamp in seconds: finite and representable (0 to 2^63-1 ns), else one line naming the option."""

    name = "seconds"
    MAX = (2 ** 63 - 1) / 1e9
    limit = None  # its own range below

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        rv = super().convert(value, param, ctx)
        if not 0.0 <= rv <= self.MAX:
            self.fail(f"{rv:g} is not a time stamp (0 to {int(self.MAX)} s)", param, ctx)
        return rv


_NEGATIVE_NUMBER = re.compile(r"-(?:(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|inf|infinity|nan)\Z", re.I)


class NumberArgsCommand(click.Command):
    """A command whose arguments may be negative numbers (`zentf clock rate -1`), as argparse allows;
    click alone reads '-1' as an unknown option."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if "--" not in args and any(_NEGATIVE_NUMBER.match(a) for a in args):
            with_value = {o for p in self.get_params(ctx) if isinstance(p, click.Option)
                          and not p.is_flag and not p.count for o in p.opts}
            options: list[str] = []
            positional: list[str] = []
            i = 0
            while i < len(args):
                a = args[i]
                if a.startswith("-") and not _NEGATIVE_NUMBER.match(a):
                    options.append(a)
                    if a in with_value and i + 1 < len(args):  # its value, even if it looks negative
                        i += 1
                        options.append(args[i])
                else:
                    positional.append(a)
                i += 1
            args = [*options, "--", *positional]
        return super().parse_args(ctx, args)


def finite_float(min: Optional[float] = None, max: Optional[float] = None, *, min_open: bool = False,
                 max_open: bool = False) -> click.ParamType:
    """The one float type of every CLI option and argument: finite, optionally within a range."""
    if min is None and max is None:
        return FiniteFloat()
    return FiniteFloatRange(min, max, min_open=min_open, max_open=max_open)

#: `--wait` of the one-shot graph listings (node list/info, topic list/info, graph).
liveliness_wait_option = click.option("--wait", type=finite_float(min=0.0), default=2.0, show_default=True,
                                      help="Seconds to wait for liveliness replies.")


@dataclass
class CliOptions:
    """The namespace + Zenoh options every command accepts (flags win over ZENTF_* env vars)."""

    namespace: Optional[str] = None
    zenoh_config: Optional[str] = None
    connect: list[str] = field(default_factory=list)
    listen: list[str] = field(default_factory=list)
    mode: Optional[str] = None
    no_multicast: bool = False
    debug: bool = False
    lan: bool = False
    wire: Optional[str] = None

    def argv(self, groups: tuple[str, ...] = ("node", "zenoh")) -> list[str]:
        """The same options as a node program's command line, for the programs the CLI starts (``groups``:
        of SHARED_OPTIONS, e.g. ("zenoh",) for the router)."""
        out: list[str] = []
        for opt in cli_options():
            if opt.group not in groups:
                continue
            value = getattr(self, opt.dest)
            if opt.kind == "flag":
                out += [opt.flags[0]] if value else []
            elif opt.kind == "repeat":
                for v in value:
                    out += [opt.flags[0], v]
            elif value is not None:
                out += [opt.flags[0], str(value)]
        return out


def cli_options() -> tuple[Any, ...]:
    """The shared options the CLI takes (zentf.transport.options.SHARED_OPTIONS minus a node's identity)."""
    from zentf.transport.shared_options import SHARED_OPTIONS

    return tuple(o for o in SHARED_OPTIONS if not o.programs_only)


def _click_option(opt: Any) -> Callable[[Any], Any]:
    """A click option from a SharedOption: the flags, metavar, choices and help of the programs' argparse."""
    kw: dict[str, Any] = {"help": opt.help_text}
    if opt.kind == "flag":
        kw.update(is_flag=True, default=False)
    else:
        kw.update(default=None, metavar=opt.metavar)
        if opt.kind == "repeat":
            kw["multiple"] = True
        if opt.choices:
            kw["type"] = click.Choice(opt.choices)
    return click.option(*opt.flags, opt.dest, **kw)


def _shared_values(kwargs: dict[str, Any]) -> CliOptions:
    """CliOptions from a command's parsed values, each one not given there taken from before the
    subcommand (`zentf -n robot1 tf frames`: the root group holds the same options)."""
    ctx = click.get_current_context(silent=True)
    outer = ctx.find_root().params if ctx is not None else {}
    values: dict[str, Any] = {}
    for opt in cli_options():
        value = kwargs.pop(opt.dest, None)
        if value in (None, False, ()):
            value = outer.get(opt.dest, value)
        values[opt.dest] = list(value or ()) if opt.kind == "repeat" else (bool(value) if opt.kind == "flag"
                                                                             else value)
    return CliOptions(**values)


def global_options(func: Callable[..., Any]) -> Callable[..., Any]:
    """The shared options on the root group, so they may come before the subcommand; the commands read
    them from there (``with_options``), a value given after the subcommand wins."""
    for opt in reversed(cli_options()):
        func = _click_option(opt)(func)
    return func


def with_options(func: Callable[..., Any]) -> Callable[..., Any]:
    """Add the shared namespace/Zenoh/--debug options to a click command; it receives `opts`."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        opts = _shared_values(kwargs)
        if opts.debug:
            _enable_debug()
        return func(*args, opts=opts, **kwargs)

    for opt in reversed(cli_options()):
        wrapper = _click_option(opt)(wrapper)
    return wrapper


def outer_argv(groups: tuple[str, ...] = ("node", "zenoh")) -> list[str]:
    """The shared options given before the subcommand, as a node program's command line (for the commands
    that hand their arguments to a program: run, static-transform-publisher, ...)."""
    return _shared_values({}).argv(groups)


def debug_requested(argv: Sequence[str]) -> bool:
    """--debug among the arguments, or ZENTF_DEBUG a yes word (parse_bool); another word is a CliError."""
    from zentf.core.text import parse_bool

    if "--debug" in argv:
        return True
    try:
        return parse_bool(os.environ.get("ZENTF_DEBUG", ""), "ZENTF_DEBUG")
    except ValueError as exc:
        raise CliError(str(exc), code=2) from None


def _enable_debug() -> None:
    import logging

    os.environ["ZENTF_DEBUG"] = "1"
    logging.getLogger().setLevel(logging.DEBUG)


def cli_node_name(tool: str) -> str:
    """Hidden ('_' prefix, like ros2cli) unique node name for a CLI tool process."""
    return f"_zentf_{tool}_{os.getpid()}"


def node_options(opts: CliOptions, name: str) -> Any:
    """Resolve flags > ZENTF_* env > defaults through the one shared options helper (zentf.transport.options)."""
    from zentf.transport.options import NodeOptions, OptionsError, ZenohOptions

    try:
        base = NodeOptions.from_env()
        base.name = name
        if opts.namespace is not None:
            base.namespace = opts.namespace
        base.zenoh = ZenohOptions.from_values(
            opts.zenoh_config, opts.connect, opts.listen, opts.mode, opts.no_multicast, lan=opts.lan)
        if opts.wire:
            base.wire = opts.wire
        base._check()
    except OptionsError as exc:
        raise CliError(str(exc), code=2) from exc
    return base


def open_node(opts: CliOptions, tool: str) -> Any:
    """A (hidden) Node for a CLI tool; an unreachable endpoint or bad config is one CliError line."""
    from zentf.transport.node import Node

    node_opts = node_options(opts, cli_node_name(tool))
    try:
        return Node(options=node_opts, check_unique=False)
    except CliError:
        raise
    except Exception as exc:  # zenoh raises plain ZError / Exception here
        if opts.debug:
            raise
        raise CliError(_session_error(exc, opts)) from exc


def wire_profile(opts: CliOptions) -> Any:
    """The wire profile (zentf.transport.wire.profiles) the options pick: zentf's own, or ros2 for a ROS 2 graph."""
    from zentf.transport.wire.profiles import make_profile

    node_opts = node_options(opts, "_zentf_cli")
    return make_profile(node_opts.wire, node_opts.domain_id)


def open_session(opts: CliOptions) -> Any:
    """A bare Zenoh session (no node token) for tools that only look at the graph."""
    node_opts = node_options(opts, cli_node_name("graph"))
    try:
        return wire_profile(opts).session_defaults(node_opts.zenoh).open_session()
    except Exception as exc:
        if opts.debug:
            raise
        raise CliError(_session_error(exc, opts)) from exc


def open_graph_session(opts: CliOptions) -> tuple[Any, str]:
    """(session, mode) for a one-shot graph listing: in the local profile a client of the rendezvous,
    which answers for every local node at once (ZenohOptions.open_query_session)."""
    node_opts = node_options(opts, cli_node_name("graph"))
    try:
        return wire_profile(opts).session_defaults(node_opts.zenoh).open_query_session()
    except Exception as exc:
        if opts.debug:
            raise
        raise CliError(_session_error(exc, opts)) from exc


def _session_error(exc: BaseException, opts: CliOptions) -> str:
    text = clean_error(exc)
    if "zenoh session" not in text.lower():
        text = f"cannot open Zenoh session: {text}"
    return text + _where(opts, " (endpoint ")


def _where(opts: CliOptions, prefix: str = " to ") -> str:
    eps = ", ".join(opts.connect) or os.environ.get("ZENTF_CONNECT", "")
    if not eps:
        return ""
    return f"{prefix}{eps})" if prefix.endswith("(endpoint ") else f"{prefix}{eps}"


_RS_LOCATION = re.compile(r"\s+at\s+\S+\.rs:\d+\.?\s*$")


def clean_error(exc: BaseException) -> str:
    """First line of an error, without zenoh's Rust source location suffix."""
    text = str(exc).strip() or type(exc).__name__
    first = next((ln for ln in text.splitlines() if ln.strip()), text)
    return _RS_LOCATION.sub("", " ".join(first.split()))


class _Status:
    """Handle to update a spinner's text (no-op when stderr is not a terminal)."""

    def __init__(self, live: Any) -> None:
        self._live = live

    def update(self, text: str) -> None:
        if self._live is not None:
            from rich.markup import escape

            from .format import printable

            self._live.update(escape(printable(text)))  # names are text: no escape codes, no rich markup


@contextmanager
def status(text: str) -> Iterator[_Status]:
    """A rich spinner on stderr while a long wait runs, only when stderr is a TTY."""
    if not sys.stderr.isatty():
        yield _Status(None)
        return
    from rich.console import Console
    from rich.markup import escape

    from .format import printable

    with Console(stderr=True).status(escape(printable(text))) as live:
        yield _Status(live)
