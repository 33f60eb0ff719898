"""The options every node program and every ``zentf`` command take, declared once: flags, environment
variable, help, kind. ``zentf.transport.options`` builds the programs' argparse groups from this table and
parses the values; ``zentf.cli.common`` builds the click options from it. It imports nothing heavy, so
the CLI reads it at start-up cheaply."""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SharedOption", "SHARED_OPTIONS", "WIRES", "MODES"]

#: Wire profiles (zentf.transport.wire.profiles): zentf's own format, or rmw_zenoh's to talk to ROS 2 (docs/ros2.md).
WIRES = ("zentf", "ros2")
MODES = ("peer", "client", "router")


@dataclass(frozen=True)
class SharedOption:
    """One option every node program and every ``zentf`` command takes the same way: the argparse
    parsers of the programs and the click options of the CLI are both built from ``SHARED_OPTIONS``."""

    dest: str                       # the parsed value's name
    flags: tuple[str, ...]
    help: str
    group: str                      # "node" or "zenoh" (argparse's groups in a program's --help)
    env: str | None = None          # the environment variable that gives its default
    env_form: str = ""              # how that variable is written, when not as the flag's value
    metavar: str | None = None
    kind: str = "value"             # "value", "repeat" (may be given several times) or "flag"
    choices: tuple[str, ...] = ()
    programs_only: bool = False     # a node's identity: CLI tools are hidden nodes with names of their own

    @property
    def help_text(self) -> str:
        """The help line, with the environment variable: the same in every --help."""
        return f"{self.help} [env {self.env}{self.env_form}]" if self.env else self.help


SHARED_OPTIONS: tuple[SharedOption, ...] = (
    SharedOption("node_name", ("--name",), "Node name.", "node", "ZENTF_NODE_NAME", metavar="NAME",
                 programs_only=True),
    SharedOption("namespace", ("--namespace", "-n"), "Namespace of the graph (topic 'tf' is key 'NS/tf').", "node",
                 "ZENTF_NAMESPACE", metavar="NS"),
    SharedOption("params", ("-p", "--param"), "Parameter NAME:=VALUE, VALUE read as YAML (repeat).", "node",
                 "ZENTF_PARAMS", " as a JSON object", metavar="NAME:=VALUE", kind="repeat", programs_only=True),
    SharedOption("params_file", ("--params-file",), "YAML parameters file (ROS 2 style or flat; docs/launch.md).",
                 "node", "ZENTF_PARAMS_FILE", metavar="FILE", programs_only=True),
    SharedOption("remap", ("-r", "--remap"), "Topic remapping FROM:=TO (repeat).", "node", "ZENTF_REMAP",
                 " as a JSON object", metavar="FROM:=TO", kind="repeat", programs_only=True),
    SharedOption("wire", ("--wire",), "Wire format: zentf, or ros2 to work on a ROS 2 (rmw_zenoh) graph; "
                 "ROS_DOMAIN_ID picks the domain.", "node", "ZENTF_WIRE", choices=WIRES),
    SharedOption("zenoh_config", ("--zenoh-config",), "Zenoh JSON5 config file.", "zenoh", "ZENTF_ZENOH_CONFIG",
                 metavar="FILE"),
    SharedOption("connect", ("--connect",), "Endpoint to connect to, e.g. tcp/10.0.0.2:7447 (repeat).", "zenoh",
                 "ZENTF_CONNECT", "=EP,EP", metavar="EP", kind="repeat"),
    SharedOption("listen", ("--listen",), "Endpoint to listen on (repeat).", "zenoh", "ZENTF_LISTEN", "=EP,EP",
                 metavar="EP", kind="repeat"),
    SharedOption("mode", ("--mode",), "Zenoh mode.", "zenoh", "ZENTF_MODE", choices=MODES),
    SharedOption("no_multicast", ("--no-multicast",), "Turn multicast scouting off.", "zenoh", "ZENTF_NO_MULTICAST",
                 "=1", kind="flag"),
    SharedOption("lan", ("--lan",), "Reach other machines (every interface, multicast scouting; unauthenticated). "
                 "Default: this machine only.", "zenoh", "ZENTF_LAN", "=1", kind="flag"),
    SharedOption("debug", ("--debug",), "Show tracebacks and debug logs.", "node", "ZENTF_DEBUG", "=1", kind="flag"),
)
