"""A Zenoh router started from Python: the hub that nodes connect to (``python -m zentf.router``)."""
from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from typing import Any

from .options import OptionsError, ZenohOptions, add_zenoh_arguments

__all__ = ["open_router", "main", "DEFAULT_ENDPOINT"]

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"


def open_router(listen: Sequence[str] = (DEFAULT_ENDPOINT,), *, no_multicast: bool = True,
                zenoh_config: str | None = None, connect: Sequence[str] = ()) -> Any:
    """An in-process Zenoh session in router mode listening on ``listen``; close it to stop."""
    opts = ZenohOptions.from_values(zenoh_config=zenoh_config, connect=list(connect), listen=list(listen),
                                    mode="router", no_multicast=no_multicast, env={})
    return opts.open_session()


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m zentf.router",
                                     description="Run a Zenoh router for zentf nodes.")
    add_zenoh_arguments(parser)
    args = parser.parse_args(argv)
    try:
        opts = ZenohOptions.from_values(args.zenoh_config, args.connect, args.listen or [DEFAULT_ENDPOINT],
                                        "router", args.no_multicast, env={})
        session = opts.open_session()
    except OptionsError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    print(f"zentf router {session.zid()} listening on {', '.join(opts.listen)}", flush=True)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        session.close()
    return 0


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING)
    sys.exit(main())
