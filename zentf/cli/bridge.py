"""`zentf bridge ros2`: relay tf, tf_static, /clock (and named topics) between zentf and ROS 2 graphs."""
from __future__ import annotations

import sys
import time
from typing import Callable, Optional

import click

from .common import CONTEXT_SETTINGS, CliError, CliOptions, finite_float, node_options, with_options

__all__ = ["bridge"]


def _relay_until(duration: Optional[float], ok: Callable[[], bool]) -> None:
    """Let a bridge relay until ``duration`` s have passed (forever if None) or ``ok()`` turns false (Ctrl-C)."""
    deadline = None if duration is None else time.monotonic() + duration
    while ok():
        left = 0.2 if deadline is None else min(0.2, deadline - time.monotonic())
        if left <= 0:
            break
        time.sleep(left)


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
        _relay_until(duration, lambda: znode.ok() and rnode.ok())
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


@bridge.command("dds", context_settings=CONTEXT_SETTINGS)
@click.option("--topic", "topics", multiple=True, metavar="NAME[:TYPE]",
              help="Also bridge this topic (repeat); TYPE (e.g. geometry_msgs/msg/Twist) may be left out when "
                   "the DDS side publishes or subscribes it.")
@click.option("--all", "all_topics", is_flag=True,
              help="Bridge every topic the DDS side has, of a type zentf knows.")
@click.option("--domain", type=click.IntRange(0, 232), default=None,
              help="ROS_DOMAIN_ID of the DDS side (and of the zentf side with --wire ros2). [env ROS_DOMAIN_ID]")
@click.option("--dds-namespace", default=None, metavar="NS",
              help="Namespace of the DDS side: relative topics are under it, --all bridges only what is.")
@click.option("--dds-peer", "dds_peers", multiple=True, metavar="ADDR",
              help="Address of a DDS machine to discover by unicast (repeat), e.g. the robot's when "
                   "multicast does not reach it.")
@click.option("--dds-interface", "dds_interfaces", multiple=True, metavar="NAME",
              help="With --lan: the network interface(s) of the DDS side (e.g. eth0; default: Cyclone DDS picks one).")
@click.option("--no-clock", is_flag=True, help="Do not relay /clock.")
@click.option("--name", default="zentf_bridge_dds", show_default=True,
              help="Node name of the bridge (on both sides).")
@click.option("--duration", type=finite_float(min=0.0, min_open=True), default=None,
              help="Stop after this many seconds (default: until Ctrl-C).")
@with_options
def bridge_dds(topics: tuple[str, ...], all_topics: bool, domain: Optional[int], dds_namespace: Optional[str],
               dds_peers: tuple[str, ...], dds_interfaces: tuple[str, ...], no_clock: bool, name: str,
               duration: Optional[float], *,
               opts: CliOptions) -> None:
    """Relay tf, tf_static, /clock, joint_states, robot_description (and --topic, --all) both ways between
    a DDS ROS 2 domain (Fast DDS or Cyclone DDS robots) and this zentf graph (either --wire), without echo
    loops; the bridge is a ROS 2 node on the DDS side. DDS stays on this machine unless --lan (which opens
    the DDS side only: the zentf side follows its own options, ZENTF_LAN, --listen)."""
    try:
        from zentf.tools.dds.bridge import DdsBridge, parse_topic_spec
    except ImportError as exc:
        raise CliError(f"zentf bridge dds needs Cyclone DDS's Python binding: pip install 'zentf[dds]' ({exc})") from exc
    from zentf.transport.node import Node

    for spec in topics:
        try:
            parse_topic_spec(spec)
        except ValueError as exc:
            raise CliError(str(exc), code=2) from exc
    dds_lan = opts.lan
    opts.lan = False  # --lan is the DDS side's here
    remote = [p for p in dds_peers if not (p.startswith("127.") or p in ("localhost", "::1"))]
    if dds_interfaces and not dds_lan:
        raise CliError("--dds-interface needs --lan (without it the DDS side is this machine's loopback only)", code=2)
    if remote and not dds_lan:
        raise CliError(f"--dds-peer {remote[0]} is another machine: add --lan (without it the DDS side is this "
                       "machine only)", code=2)
    zopts = node_options(opts, name)
    if domain is None:
        domain = zopts.domain_id
    zopts.domain_id = domain
    node = relay = None
    state = {"last": None}

    def on_state(st: str, other: Optional[str]) -> None:
        if st == state["last"] or st == "waiting":
            return
        state["last"] = st
        text = f"dds bridge: {st}" + (f" (bridge {other} relays)" if st == "standby" and other else "")
        sys.stderr.write(text + "\n")
        sys.stderr.flush()

    try:
        node = Node(options=zopts)
        named = ", ".join(["tf", "tf_static", *([] if no_clock else ["/clock"]), "joint_states", "robot_description",
                           *(parse_topic_spec(t)[0] for t in topics), *(["every known type (--all)"] if all_topics else [])])
        sys.stderr.write(f"bridging {named} between zentf ({node.get_fully_qualified_name()}, wire {node.wire.name}) "
                         f"and DDS domain {domain} ({'LAN' if dds_lan else 'this machine only'}); Ctrl-C stops\n")
        sys.stderr.flush()
        relay = DdsBridge(node, domain_id=domain, topics=topics, all_topics=all_topics, clock=not no_clock,
                          dds_namespace=dds_namespace, lan=dds_lan, peers=dds_peers,
                          interfaces=dds_interfaces, on_state=on_state)
        _relay_until(duration, node.ok)
        st = relay.stats
        sys.stderr.write(f"relayed to DDS: {sum(st.to_dds.values())}, to zentf: {sum(st.to_zentf.values())}, "
                         f"echoes dropped: {st.echoes}, not relayable: {st.dropped}\n")
    except CliError:
        raise
    except ValueError as exc:
        raise CliError(str(exc)) from exc
    except Exception as exc:  # DDS or Zenoh failing to start: one line
        if opts.debug:
            raise
        raise CliError(f"cannot start the DDS bridge: {exc}") from exc
    finally:
        if relay is not None:
            relay.close()
        if node is not None:
            node.shutdown()
