"""The DDS bridge as a program (``zentf run dds_bridge``, launch files' ``run: dds_bridge``; ``zentf bridge dds`` on the command line): relays tf, tf_static, /clock,
joint_states and robot_description (and more topics) between a DDS ROS 2 domain and this zentf graph.

Parameters (``-p NAME:=VALUE`` or launch ``parameters:``): ``domain`` (ROS_DOMAIN_ID of the DDS side,
default the environment's ROS_DOMAIN_ID or 0), ``topics`` (a list, or a comma-separated string, of
``NAME[:TYPE]``), ``all`` (bridge every DDS topic of a type zentf knows, default false), ``dds_namespace``
(default ''), ``lan`` (the DDS side reaches the robot's network, default false: this machine only),
``dds_peers`` (addresses to discover by unicast), ``dds_interfaces`` (with ``lan``: network interfaces), ``clock`` (relay /clock, default true). Prints
``dds bridge: active`` / ``standby`` as it starts relaying or another bridge does (docs/ros2.md).
"""
from __future__ import annotations

import os
from typing import Any, Sequence

from ...transport import program as _common
from ...transport.options import NodeOptions, OptionsError

PROG = "dds_bridge"


def main(argv: Sequence[str] | None = None) -> int:
    return _common.main(PROG, argv, _run, __doc__)


def _names(value: Any, what: str) -> list[str]:
    if isinstance(value, str):
        return [x.strip() for x in value.split(",") if x.strip()]
    if isinstance(value, (list, tuple)) and all(isinstance(x, str) for x in value):
        return list(value)
    raise OptionsError(f"parameter {what} must be a list of names or a comma-separated string, got {value!r}")


def _run(opts: NodeOptions) -> None:
    try:
        from .bridge import DdsBridge
    except ImportError as e:
        raise OptionsError(f"the DDS bridge needs Cyclone DDS's Python binding: pip install 'zentf[dds]' ({e})") from e
    with _common.make_node(opts, PROG) as node:
        default_domain = opts.domain_id if "ROS_DOMAIN_ID" in os.environ else 0
        domain = _common.param(node, "domain", default_domain)
        if isinstance(domain, str) and domain.strip().isdigit():
            domain = int(domain)
        if isinstance(domain, bool) or not isinstance(domain, int) or not 0 <= domain <= 232:
            raise OptionsError(f"parameter domain must be a ROS_DOMAIN_ID 0-232, got {domain!r}")
        dds_ns = _common.param(node, "dds_namespace", "")
        if not isinstance(dds_ns, str):
            raise OptionsError(f"parameter dds_namespace must be a string, got {dds_ns!r}")

        def on_state(state: str, other: str | None) -> None:
            if state != "waiting":
                _common.say(f"dds bridge: {state}" + (f" (bridge {other} relays)" if state == "standby" and other else ""))

        bridge = DdsBridge(node, domain_id=domain, topics=_names(_common.param(node, "topics", []), "topics"),
                           all_topics=_common.param_bool(node, "all", False),
                           clock=_common.param_bool(node, "clock", True), dds_namespace=dds_ns or None,
                           lan=_common.param_bool(node, "lan", False),
                           peers=_names(_common.param(node, "dds_peers", []), "dds_peers"),
                           interfaces=_names(_common.param(node, "dds_interfaces", []), "dds_interfaces"),
                           on_state=on_state)
        try:
            node.spin()
        finally:
            bridge.close()


if __name__ == "__main__":
    _common.finish(main())
