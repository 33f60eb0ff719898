"""The `zentf` command: tf echo/monitor/frames, topic/node introspection, graph, launch, clock.

Built on a lazy click group rather than typer: typer imports pydantic to coerce any non-bool
parameter, which alone costs more start-up time than the CLI's budget (docs/performance.md). Each
subcommand's module is imported only when it runs, and Zenoh only inside the command that needs it.
"""
from __future__ import annotations

import importlib
import os
import sys
from typing import Any, Optional, Sequence

import click

from .common import CONTEXT_SETTINGS, CliError, clean_error, global_options

__all__ = ["cli", "main", "LazyGroup"]


class LazyGroup(click.Group):
    """A click group whose subcommands live in modules imported on first use."""

    def __init__(self, *args: Any, lazy: Optional[dict[str, tuple[str, str]]] = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lazy = dict(lazy or {})  # name -> ("module:attr", short help)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self.lazy})

    def get_command(self, ctx: click.Context, name: str) -> Optional[click.Command]:
        cmd = super().get_command(ctx, name)
        if cmd is not None or name not in self.lazy:
            return cmd
        target, _ = self.lazy[name]
        module, attr = target.split(":")
        try:
            cmd = getattr(importlib.import_module(module), attr)
        except (ImportError, AttributeError) as exc:
            # A missing or broken optional part breaks only its own command.
            raise CliError(f"'zentf {name}' is not available: {clean_error(exc)}") from exc
        self.add_command(cmd, name)
        return cmd

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """List subcommands from the static help table, without importing their modules."""
        rows = []
        for name in self.list_commands(ctx):
            if name in self.commands:
                cmd = self.commands[name]
                if cmd.hidden:
                    continue
                rows.append((name, cmd.get_short_help_str(formatter.width - 6 - len(name))))
            else:
                rows.append((name, self.lazy[name][1]))
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


_COMMANDS: dict[str, tuple[str, str]] = {
    "tf": ("zentf.cli.tf:tf", "Transforms: echo, monitor, frames, doctor, why (tf2_echo, tf2_monitor, view_frames)."),
    "topic": ("zentf.cli.topic:topic", "Topics: list, info, type, find, echo, hz, bw, delay, pub."),
    "node": ("zentf.cli.node:node", "Nodes: list, info."),
    "graph": ("zentf.cli.graph:graph", "The node <-> topic graph (rqt_graph) as DOT + image + text."),
    "static-transform-publisher": ("zentf.cli.static:static_transform_publisher",
                                   "Publish a static transform (tf2_ros static_transform_publisher)."),
    "run": ("zentf.cli.run:run", "Start a program: zentf run NAME [ARGS] (--list names them)."),
    "launch": ("zentf.launch.cli:launch", "Start a node graph from a launch file."),
    "clock": ("zentf.launch.cli:clock", "Publish or inspect the /clock sim time."),
    "router": ("zentf.cli.extern:router", "Run a Zenoh router (multi-machine graphs)."),
    "view": ("zentf.cli.view:view", "Live 3D view of frames, markers and points (Rerun)."),
    "bag": ("zentf.cli.bag:bag", "Record, inspect and play MCAP bags (rosbag)."),
    "urdf": ("zentf.cli.urdf:urdf", "Robot models: check a URDF, graph its tree (check_urdf, urdf_to_graphiz)."),
    "robot-state-publisher": ("zentf.cli.robot:robot_state_publisher",
                              "Publish a URDF robot's frames from joint_states (robot_state_publisher)."),
    "joint-state-publisher": ("zentf.cli.robot:joint_state_publisher",
                              "Publish joint_states for a URDF: values, --sweep, --gui sliders."),
    "bridge": ("zentf.cli.bridge:bridge", "Relay tf, tf_static, /clock and topics to and from a ROS 2 graph."),
    "service": ("zentf.cli.service:service", "Services: list, type, call."),
    "param": ("zentf.cli.param:param", "Node parameters over the network: list, get, set, dump."),
    "interface": ("zentf.cli.interface:interface", "Message and service types: list, show, proto (ros2 interface)."),
}


@click.group("zentf", cls=LazyGroup, lazy=_COMMANDS, context_settings=CONTEXT_SETTINGS)
@global_options
@click.version_option("0.1.0", "--version", prog_name="zentf", message="%(prog)s %(version)s")
def cli(**_shared: object) -> None:
    """tf2's tools for robots whose processes talk over Zenoh.

    Every command takes the options below, before or after its name (`zentf -n robot1 tf frames`,
    `zentf tf frames -n robot1`; after it wins); the ZENTF_* environment variables give their
    defaults. Programs (`zentf run NAME`) take them too, plus --name, -p, --params-file and -r.
    """


def _error(msg: str) -> None:
    from .format import printable  # a frame or node name in the message must not drive the terminal

    sys.stderr.write(f"zentf: error: {printable(msg)}\n")
    sys.stderr.flush()


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Console entry point: run the command, turning every failure into one line and an exit code."""
    import logging

    from zentf.core.text import stderr_log_handler  # names from the network in a log line are escaped

    from .common import debug_requested

    args = list(sys.argv[1:] if argv is None else argv)
    try:
        debug = debug_requested(args)
    except CliError as exc:
        _error(str(exc))
        return exc.code

    logging.basicConfig(level=logging.DEBUG if debug else logging.WARNING,
                        handlers=[stderr_log_handler("[%(levelname)s] %(name)s: %(message)s")])
    try:
        rv = cli.main(args=args, prog_name="zentf", standalone_mode=False)
        return rv if isinstance(rv, int) else 0
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except (click.exceptions.Abort, KeyboardInterrupt):
        return 130
    except click.exceptions.NoArgsIsHelpError as exc:
        sys.stdout.write(exc.format_message().rstrip() + "\n")
        return 0
    except click.exceptions.UsageError as exc:
        cmd = exc.ctx.command_path if exc.ctx is not None else "zentf"
        _error(f"{' '.join(exc.format_message().split())} (see '{cmd} --help')")
        return exc.exit_code
    except click.exceptions.ClickException as exc:
        _error(" ".join(exc.format_message().split()))
        return exc.exit_code
    except CliError as exc:
        if debug:
            raise
        _error(clean_error(exc))
        return exc.code
    except BrokenPipeError:
        # stdout closed early (zentf topic echo | head): not an error.
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return 0
    except Exception as exc:  # noqa: BLE001 - the one place where crashes become one line
        if debug:
            raise
        return _report_crash(exc)


def _report_crash(exc: Exception) -> int:
    from zentf.core.exceptions import TransformException

    from zentf.transport.options import OptionsError
    if isinstance(exc, TransformException):
        _error(f"{type(exc).__name__}: {clean_error(exc)}")
        return 1
    if isinstance(exc, OptionsError):
        _error(clean_error(exc))
        return 2
    _error(f"{clean_error(exc)} ({type(exc).__name__}; rerun with --debug for the traceback)")
    return 1


def run() -> None:
    """`python -m zentf.cli` lands here."""
    sys.exit(main())
