"""What every demo node program shares: option parsing, node creation, parameters, clean exits."""
from __future__ import annotations

import argparse
import logging
import math
import os
import signal
import sys
from typing import Any, Callable, NoReturn, Sequence

from ..core.text import parse_bool, printable
from .options import NodeOptions, OptionsError, add_node_arguments, env_flag

__all__ = ["OptionsError", "main", "run", "split_node_options", "make_node", "say", "error_line", "param",
           "param_float", "param_positive", "param_bool", "param_rate", "check_rate"]

log = logging.getLogger("zentf.program")
_started = False  # a Node exists: it owns SIGINT/SIGTERM until it shuts down
_stdout_gone = False
_node: Any = None  # the program's node, stopped when stdout's reader goes away


def say(line: str) -> None:
    """One human-facing result line on stdout, flushed at once (tests and pipes read it live). Names in it
    may come from the network or a file: the line is escaped (``printable``), so it stays one line."""
    global _stdout_gone
    if _stdout_gone:
        return
    try:
        print(printable(line), flush=True)
    except (BrokenPipeError, ValueError):  # the reader went away (| head): stop quietly, like SIGPIPE
        _stdout_gone = True
        try:
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115  (lives as long as the process)
        except OSError:
            pass
        if _node is not None:
            _node.request_shutdown()


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad flag as one line (no usage dump); --help still shows everything."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise OptionsError(f"{message} (see --help)")


def _parser(prog: str, description: str | None, *, add_help: bool = True) -> argparse.ArgumentParser:
    parser = _Parser(prog=prog, description=description, allow_abbrev=False, add_help=add_help,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_node_arguments(parser)
    return parser


def _debug(args: argparse.Namespace) -> bool:
    """--debug, or ZENTF_DEBUG a yes word (the CLI passes its --debug on so)."""
    return bool(args.debug) or env_flag(os.environ, "ZENTF_DEBUG")


def split_node_options(prog: str, argv: Sequence[str]) -> tuple[NodeOptions, bool, list[str]]:
    """Shared node/Zenoh options out of argv: (options, --debug given, the program's own arguments)."""
    args, rest = _parser(prog, None, add_help=False).parse_known_args(list(argv))
    return NodeOptions.from_args(args), _debug(args), rest


def main(prog: str, argv: Sequence[str] | None, body: Callable[[NodeOptions], None],
         description: str | None = None) -> int:
    """Parse the shared options strictly and run body(opts) as a node program (exit 2 on bad flags)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = _parser(prog, description).parse_args(argv)
        opts = NodeOptions.from_args(args)
        debug = _debug(args)
    except OptionsError as e:
        error_line(prog, str(e))
        return 2
    return run(lambda: body(opts), prog, debug)


def error_line(prog: str, text: str, kind: str = "error: ") -> None:
    """``PROG: error: TEXT`` on stderr, the text escaped: it may quote a file or a peer."""
    print(f"{prog}: {kind}{printable(text)}", file=sys.stderr, flush=True)


def _setup_logging(debug: bool) -> None:
    from .node import init_logging

    init_logging(logging.DEBUG if debug else logging.INFO)


def run(body: Callable[[], None], prog: str, debug: bool = False) -> int:
    """Run a node body: SIGTERM/SIGINT stop it cleanly, errors become one line (traceback with --debug)."""
    _setup_logging(debug)

    def on_signal(signum: int, _frame: object) -> None:
        # Before the node exists a signal aborts start-up; while it lives the Node handles signals;
        # once it is shutting down a repeated signal must not cut its (bounded) clean-up short.
        if not _started:
            raise KeyboardInterrupt
        log.debug("signal %d while shutting down: ignored", signum)

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    try:
        body()
    except KeyboardInterrupt:
        return 0
    except (OptionsError, ValueError) as e:  # bad options/parameters, duplicate node name, ...
        if debug:
            raise
        error_line(prog, str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__)
        return 1
    except Exception as e:  # a user sees one line, a developer asks for --debug
        if debug:
            raise
        text = str(e).strip().splitlines()[0] if str(e).strip() else ""
        error_line(prog, text, f"{type(e).__name__}: ")
        return 1
    finally:
        if _started:  # from here on a late signal would only kill the interpreter's own teardown
            for sig in (signal.SIGINT, signal.SIGTERM):
                signal.signal(sig, signal.SIG_IGN)
    return 0


def finish(code: int) -> NoReturn:
    """End a node program with ``code`` once main() has returned (its node shut down, its session
    closed), without the interpreter's teardown.

    zenoh-python's threads may still be about to call into Python (a callback, a liveliness event):
    during finalization CPython ends such a thread with pthread_exit, whose unwinding through their
    Rust frames aborts the process ("FATAL: exception not rethrown", exit -6: CI saw it once when
    turtlesim got SIGTERM). The listener's thread is stopped before that for the same reason
    (zentf.transport.listener); here no thread is left to meet it. Logs and output are flushed first."""
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 - a closed pipe must not change the exit code
            pass
    os._exit(code)


def make_node(opts: NodeOptions, default_name: str) -> Any:
    """A Node with the identity and Zenoh options from the command line / environment."""
    global _started, _node
    from .node import Node

    node = Node(default_name, options=opts)
    _started = True
    _node = node
    return node


def param(node: Any, name: str, default: Any) -> Any:
    """A parameter's value, or default when it was not given."""
    return node.declare_parameter(name, default).value


def param_float(node: Any, name: str, default: float) -> float:
    """A finite number parameter; OptionsError names the parameter otherwise."""
    value = param(node, name, default)
    if isinstance(value, str):  # e.g. a launch substitution that stayed text
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise OptionsError(f"parameter {name} must be a finite number, got {value!r}")
    return float(value)


def param_positive(node: Any, name: str, default: float) -> float:
    value = param_float(node, name, default)
    if value <= 0:
        raise OptionsError(f"parameter {name} must be positive, got {value!r}")
    return value


def check_rate(what: str, value: Any, *, period: bool = False) -> float:
    """``value`` as a rate in Hz (a period in s with ``period``) a timer can serve; OptionsError naming
    ``what`` (an option such as ``--rate``, or ``parameter rate``) otherwise."""
    from .clock import rate_problem

    problem = rate_problem(what, value, period=period)
    if problem is not None:
        raise OptionsError(problem)
    return float(value)


def param_rate(node: Any, name: str, default: float, *, period: bool = False) -> float:
    """A rate (Hz) or, with ``period``, a period (s) parameter within what a timer serves: out of it,
    OptionsError names it at start, and a set at run time (``zentf param set``) is refused with the same line."""
    from .clock import rate_problem

    value = check_rate(f"parameter {name}", param_float(node, name, default), period=period)

    def refuse_out_of_range(params: list[Any]) -> Any:
        from ..core.parameters import SetParametersResult

        for p in params:
            if p.name == name:
                problem = rate_problem(f"parameter {name}", p.value, period=period)
                if problem is not None:
                    return SetParametersResult(False, problem)
        return SetParametersResult(True, "")

    node.add_on_set_parameters_callback(refuse_out_of_range)
    return value


def param_bool(node: Any, name: str, default: bool) -> bool:
    """A yes/no parameter (``parse_bool``'s words, e.g. from a launch substitution); OptionsError otherwise."""
    try:
        return parse_bool(param(node, name, default), f"parameter {name}")
    except ValueError as e:
        raise OptionsError(str(e)) from None
