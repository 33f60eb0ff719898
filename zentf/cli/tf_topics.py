"""Which tf topics a tf tool reads: ``--tf-topic``, ``--tf-static-topic``, ``--all-namespaces`` and ROS 2's
``--ros-args -r /tf:=/robot1/tf`` habit, for every tf tool (echo, monitor, frames, doctor, why, view).

A fleet runs one tf tree per robot namespace (``/robot1/tf``, ``/robot2/tf``); a tool looks at one of
them by name, at several (repeat the option), or at all (``--all-namespaces``: the pattern ``/**/tf``,
which Zenoh matches in every namespace, the root one included), as ``TransformListener(tf_topic=...)``
does from Python.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import click

from .common import NumberArgsCommand

__all__ = ["TfTopics", "tf_topic_options", "TfToolCommand", "split_ros_args", "open_tf_listeners"]

ALL_TF = "/**/tf"
ALL_TF_STATIC = "/**/tf_static"
_TF_NAMES = {"tf": "tf", "/tf": "tf", "tf_static": "tf_static", "/tf_static": "tf_static"}


@dataclass
class TfTopics:
    """The dynamic and static tf topics a tool reads (names or '*'/'**' patterns)."""

    dynamic: list[str] = field(default_factory=lambda: ["tf"])
    static: list[str] = field(default_factory=lambda: ["tf_static"])
    params: dict[str, Any] = field(default_factory=dict)   # -p NAME:=VALUE from --ros-args

    @property
    def default(self) -> bool:
        return self.dynamic == ["tf"] and self.static == ["tf_static"]

    def pairs(self) -> list[tuple[Optional[str], Optional[str]]]:
        """(tf topic or None, tf_static topic or None) per listener to open."""
        n = max(len(self.dynamic), len(self.static))
        return [(self.dynamic[i] if i < len(self.dynamic) else None, self.static[i] if i < len(self.static) else None)
                for i in range(n)]

    def describe(self, namespace: str = "") -> str:
        """The topics as full names ('/robot1/tf, /robot1/tf_static')."""
        ns = namespace.strip("/")

        def show(t: str) -> str:
            return t if t.startswith("/") else (f"/{ns}/{t}" if ns else f"/{t}")
        return ", ".join(show(t) for t in [*self.dynamic, *self.static])


def split_ros_args(args: list[str]) -> tuple[list[str], list[str]]:
    """(the arguments without the ``--ros-args ... [--]`` section, that section's tokens)."""
    if "--ros-args" not in args:
        return args, []
    i = args.index("--ros-args")
    rest = args[i + 1:]
    end = rest.index("--") if "--" in rest else len(rest)
    return args[:i] + rest[end + 1:], rest[:end]


def _parse_ros_args(tokens: list[str]) -> tuple[dict[str, str], dict[str, Any]]:
    """-r/--remap FROM:=TO and -p/--param NAME:=VALUE; anything else is one clear error."""
    from zentf.transport.options import OptionsError, parse_param_assignment

    remaps: dict[str, str] = {}
    params: dict[str, Any] = {}
    i = 0
    while i < len(tokens):
        tok = tokens[i]
        if tok in ("-r", "--remap", "-p", "--param"):
            if i + 1 >= len(tokens):
                raise click.UsageError(f"--ros-args {tok} needs a value (FROM:=TO / NAME:=VALUE)")
            value = tokens[i + 1]
            i += 2
        elif tok.startswith(("-r", "-p")) and ":=" in tok:
            value, tok = tok[2:], tok[:2]
            i += 1
        else:
            raise click.UsageError(f"--ros-args {tok}: zentf takes -r/--remap FROM:=TO and -p/--param NAME:=VALUE "
                                   "there")
        if ":=" not in value:
            raise click.UsageError(f"--ros-args {tok} {value}: expected FROM:=TO")
        if tok in ("-p", "--param"):
            try:
                k, v = parse_param_assignment(value)
            except OptionsError as exc:
                raise click.UsageError(f"--ros-args {tok} {value}: {exc}") from None
            params[k] = v
            continue
        src, _, dst = value.partition(":=")
        src = src.rsplit(":", 1)[-1]  # ROS 2's node-specific form: NODE:FROM:=TO
        if src not in _TF_NAMES:
            raise click.UsageError(f"--ros-args -r {value}: a tf tool remaps only /tf and /tf_static")
        if not dst.strip():
            raise click.UsageError(f"--ros-args -r {value}: empty target topic")
        remaps[_TF_NAMES[src]] = dst.strip()
    return remaps, params


class TfToolCommand(NumberArgsCommand):
    """A tf tool's command: negative numbers as arguments, and a ``--ros-args`` section (ROS 2's habit)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        args, ros = split_ros_args(list(args))
        if ros:
            ctx.meta["zentf.ros_args"] = _parse_ros_args(ros)
        return super().parse_args(ctx, args)


_OPTIONS = [
    click.option("--tf-topic", "tf_topic", multiple=True, metavar="TOPIC",
                 help="tf topic to read (repeat for several; '*' and '**' parts match namespaces). Default: tf. "
                      "Its tf_static is TOPIC + '_static' unless --tf-static-topic says."),
    click.option("--tf-static-topic", "tf_static_topic", multiple=True, metavar="TOPIC",
                 help="tf_static topic to read (repeat). Default: tf_static, or each --tf-topic + '_static'."),
    click.option("--all-namespaces", "-A", "all_namespaces", is_flag=True,
                 help="Read the tf of every namespace (a fleet: /**/tf and /**/tf_static)."),
]


def _topics(tf_topic: tuple, tf_static_topic: tuple, all_namespaces: bool, ros: Any) -> TfTopics:
    remaps, params = ros if ros else ({}, {})
    if all_namespaces and (tf_topic or tf_static_topic or remaps):
        raise click.UsageError("--all-namespaces reads every tf topic: give it without --tf-topic/--ros-args -r")
    for t in (*tf_topic, *tf_static_topic, *remaps.values()):
        if not t.strip("/"):
            raise click.BadParameter(f"{t!r} is not a topic name", param_hint="'--tf-topic'")
        parts = t.strip("/").split("/")
        if any("*" in p and p not in ("*", "**") for p in parts):
            raise click.BadParameter(f"{t!r}: a wildcard must be a whole part ('*' or '**')",
                                     param_hint="'--tf-topic'")
    if all_namespaces:
        return TfTopics([ALL_TF], [ALL_TF_STATIC], params)
    dynamic = list(tf_topic) or ([remaps["tf"]] if "tf" in remaps else ["tf"])
    if tf_static_topic:
        static = list(tf_static_topic)
    elif "tf_static" in remaps:
        static = [remaps["tf_static"]]
    elif tf_topic or "tf" in remaps:
        static = [t + "_static" for t in dynamic]
    else:
        static = ["tf_static"]
    return TfTopics(dynamic, static, params)


def tf_topic_options(func: Callable[..., Any]) -> Callable[..., Any]:
    """Add --tf-topic/--tf-static-topic/--all-namespaces (and read --ros-args); the command gets ``tf_topics``."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        ctx = click.get_current_context()
        kwargs["tf_topics"] = _topics(kwargs.pop("tf_topic", ()), kwargs.pop("tf_static_topic", ()),
                                      kwargs.pop("all_namespaces", False), ctx.meta.get("zentf.ros_args"))
        return func(*args, **kwargs)

    for deco in reversed(_OPTIONS):
        wrapper = deco(wrapper)
    return wrapper


def open_tf_listeners(buffer: Any, node: Any, topics: TfTopics) -> list[Any]:
    """One TransformListener per (tf, tf_static) pair of ``topics`` into ``buffer``."""
    from zentf.transport.listener import TransformListener

    out: list[Any] = []
    try:
        for dyn, static in topics.pairs():
            if dyn is None:
                out.append(TransformListener(buffer, node, static_only=True, tf_static_topic=static or "tf_static"))
            elif static is None:  # a tf topic without its own static one: listen to tf only
                out.append(_tf_only(buffer, node, dyn))
            else:
                out.append(TransformListener(buffer, node, tf_topic=dyn, tf_static_topic=static))
    except BaseException:
        for lis in out:
            lis.unregister()
        raise
    return out


def _tf_only(buffer: Any, node: Any, topic: str) -> Any:
    # TransformListener always reads a static topic: point it at the static topic of this tf topic
    from zentf.transport.listener import TransformListener

    return TransformListener(buffer, node, tf_topic=topic, tf_static_topic=topic + "_static")
