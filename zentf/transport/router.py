"""A Zenoh router started from Python: the hub that nodes connect to (``python -m zentf.transport.router``)."""
from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from typing import Any, NoReturn

from ..core.text import printable
from .options import OptionsError, ZenohOptions, add_zenoh_arguments

__all__ = ["open_router", "main", "DEFAULT_ENDPOINT"]

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
LAN_ENDPOINT = "tcp/0.0.0.0:7447"


def open_router(listen: Sequence[str] = (DEFAULT_ENDPOINT,), *, no_multicast: bool = True,
                zenoh_config: str | None = None, connect: Sequence[str] = ()) -> Any:
    """An in-process Zenoh session in router mode listening on ``listen``; close it to stop."""
    opts = ZenohOptions.from_values(zenoh_config=zenoh_config, connect=list(connect), listen=list(listen),
                                    mode="router", no_multicast=no_multicast, env={})
    return opts.open_session()


class _OneLineParser(argparse.ArgumentParser):
    """Bad arguments are one line and exit 2, as every other zentf command says them (not usage + error)."""

    def error(self, message: str) -> "NoReturn":  # type: ignore[override]
        if message.startswith("unrecognized arguments: "):  # click's wording, as the other commands
            message = f"No such option '{message.split(': ', 1)[1].split()[0]}'."
        self.exit(2, f"{_who(self.prog)}: error: {message} (see '{self.prog} --help')\n")


def _who(prog: str) -> str:
    return "zentf" if prog.startswith("zentf") else prog


def main(argv: Sequence[str] | None = None, prog: str = "python -m zentf.transport.router") -> int:
    parser = _OneLineParser(prog=prog, description="Run a Zenoh router for zentf nodes.")
    add_zenoh_arguments(parser)
    parser.add_argument("--config", dest="zenoh_config", metavar="FILE", help="same as --zenoh-config")
    args = parser.parse_args(argv)
    try:
        # A config file's own listen endpoints win over the default one (not over --listen).
        listen = args.listen or ([] if args.zenoh_config else [LAN_ENDPOINT if args.lan else DEFAULT_ENDPOINT])
        opts = ZenohOptions.from_values(args.zenoh_config, args.connect, listen, "router", args.no_multicast,
                                        env={}, lan=args.lan)
        cfg = opts.config()
        endpoints = opts.listen or _listen_endpoints(cfg) or [DEFAULT_ENDPOINT]
    except OptionsError as e:  # a bad flag or config file: a usage error
        print(f"{_who(prog)}: error: {printable(str(e))}", file=sys.stderr)  # it may quote the config file
        return 2
    try:
        session = opts.open_session()
    except OptionsError as e:  # e.g. the port is taken
        print(f"{_who(prog)}: error: {printable(str(e))}", file=sys.stderr)
        return 1
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    print(f"zentf router {session.zid()} listening on {', '.join(endpoints)}", flush=True)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        session.close()
    return 0


def _listen_endpoints(cfg: Any) -> list[str]:
    """The listen endpoints a config holds (a list, or a per-mode mapping)."""
    import json

    try:
        value = json.loads(cfg.get_json("listen/endpoints"))
    except Exception:
        return []
    if isinstance(value, dict):
        value = value.get("router", [])
    return [str(v) for v in value] if isinstance(value, list) else []


if __name__ == "__main__":
    from ..core.text import stderr_log_handler

    logging.basicConfig(level=logging.WARNING, handlers=[stderr_log_handler(logging.BASIC_FORMAT)])
    sys.exit(main())
