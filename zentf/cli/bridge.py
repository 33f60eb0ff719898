"""`zentf bridge ros2`: relay tf, tf_static, /clock (and named topics) between zentf and ROS 2 graphs."""
from __future__ import annotations

import sys
import time
from typing import Optional

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, finite_float, node_options, with_options

__all__ = ["bridge"]


@click.group("bridge", context_settings=CONTEXT_SETTINGS)
def bridge() -> None:
    """Relay between a zentf graph and another one."""


@bridge.command("ros2", context_settings=CONTEXT_SETTINGS)
@click.argument("topics", nargs=-1)
@click.option("--ros2-connect", multiple=True, metavar="EP",
              help="Router of the ROS 2 side (repeat); default: a ROS 2 machine's session "
                   "(peer, tcp/localhost:7447, no multicast).")
@click.option("--ros2-mode", type=click.Choice(["peer", "client"]), default=None,
              help="Zenoh mode of the ROS 2 side's session.")
@click.option("--ros2-namespace", default=None, metavar="NS", help="Namespace of the ROS 2 side (default: root).")
@click.option("--domain", type=click.IntRange(0, 232), default=None,
              help="ROS_DOMAIN_ID of the ROS 2 side. [env ROS_DOMAIN_ID]")
@click.option("--no-clock", is_flag=True, help="Do not relay /clock.")
@click.option("--duration", type=finite_float(min=0.0, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@with_options
def bridge_ros2(topics: tuple[str, ...], ros2_connect: tuple[str, ...], ros2_mode: Optional[str],
                ros2_namespace: Optional[str], domain: Optional[int], no_clock: bool, duration: Optional[float],
                *, opts: CliOptions) -> None:
    """Relay tf, tf_static, /clock and TOPICS both ways between this zentf graph (--connect, --namespace...)
    and a ROS 2 graph over rmw_zenoh (--ros2-connect, --domain), without echo loops; statics stay latched
    on both sides."""
    from zentf.transport.node import Node
    from zentf.transport.options import NodeOptions, OptionsError, ZenohOptions
    from zentf.tools.bridge import Ros2Bridge

    zopts = node_options(opts, "zentf_bridge")
    zopts.wire = "zentf"
    try:
        ropts = NodeOptions(name="zentf_bridge", namespace=ros2_namespace, wire="ros2",
                            domain_id=domain if domain is not None else zopts.domain_id,
                            zenoh=ZenohOptions.from_values(None, list(ros2_connect), None, ros2_mode, None, env={}))
        ropts._check()
    except OptionsError as exc:
        raise CliError(str(exc), code=2) from exc
    znode = rnode = None
    relay = None
    try:
        znode = Node(options=zopts)
        rnode = Node(options=ropts, check_unique=False)
        relay = Ros2Bridge(znode, rnode, topics, clock=not no_clock)
        relayed = ", ".join(["tf", "tf_static", *([] if no_clock else ["/clock"]), *topics])
        sys.stderr.write(f"bridging {relayed} between zentf ({znode.get_fully_qualified_name()}) and ROS 2 "
                         f"(domain {rnode.wire.domain_id}); Ctrl-C stops\n")
        sys.stderr.flush()
        deadline = None if duration is None else time.monotonic() + duration
        while znode.ok() and rnode.ok():
            left = 0.2 if deadline is None else min(0.2, deadline - time.monotonic())
            if left <= 0:
                break
            time.sleep(left)
        st = relay.stats
        sys.stderr.write(f"relayed to ROS 2: {sum(st.to_ros2.values())}, to zentf: {sum(st.to_zentf.values())}, "
                         f"echoes dropped: {st.echoes}, not relayable: {st.dropped}\n")
    except CliError:
        raise
    except ValueError as exc:
        raise CliError(str(exc)) from exc
    finally:
        if relay is not None:
            relay.close()
        for n in (rnode, znode):
            if n is not None:
                n.shutdown()
