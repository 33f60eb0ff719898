"""`zentf urdf check | graph`: check_urdf and urdf_to_graphiz for URDF (and .xacro) files."""
from __future__ import annotations

import re
from typing import Any, Callable, Optional

import click

from .common import CONTEXT_SETTINGS, CliError
from .format import printable

__all__ = ["urdf", "load_or_fail", "model_options", "graph_file_stem"]


@click.group("urdf", context_settings=CONTEXT_SETTINGS)
def urdf() -> None:
    """Robot models: check (check_urdf), graph (urdf_to_graphiz)."""


def model_options(f: Callable) -> Callable:
    """The options of every command that loads a model: package paths and the .xacro ones."""
    for opt in reversed([
        click.option("--package-path", "package_path", multiple=True, metavar="DIR",
                     help="Where package:// meshes and $(find PKG) are looked up (repeat; also $ZENTF_PACKAGE_PATH)."),
        click.option("--xacro-arg", "xacro_arg", multiple=True, metavar="NAME:=VALUE",
                     help="A xacro argument (repeat)."),
        click.option("--xacro-budget", "xacro_budget", default=None, metavar="SECONDSs[,MEGABYTESMB]",
                     help="CPU and memory a .xacro expansion may use (default 10s,512MB; e.g. 60s,2GB)."),
        click.option("--xacro-env", "xacro_env", multiple=True, metavar="NAME",
                     help="An environment variable a .xacro model may read with $(env)/$(optenv) (repeat; "
                          "none by default)."),
    ]):
        f = opt(f)
    return f


def load_or_fail(path: str, package_path: tuple[str, ...] = (), xacro_arg: tuple[str, ...] = (),
                 xacro_budget: Optional[str] = None, xacro_env: tuple[str, ...] = ()) -> Any:
    """The checked model, or the one-line refusal as a usage error (exit 2)."""
    import os

    from zentf.urdf import URDFError, load_urdf, parse_xacro_budget

    args: dict[str, str] = {}
    for item in xacro_arg:
        name, sep, value = item.partition(":=")
        if not sep or not name:
            raise CliError(f"--xacro-arg expects NAME:=VALUE, got {item!r}", code=2)
        args[name] = value
    try:
        budget = parse_xacro_budget(xacro_budget) if xacro_budget is not None else None
    except ValueError as exc:
        raise CliError(str(exc), code=2) from exc
    env = {n: os.environ[n] for n in xacro_env if n in os.environ}
    try:
        return load_urdf(path, package_path=list(package_path), xacro_args=args, xacro_budget=budget, xacro_env=env)
    except URDFError as exc:
        raise CliError(str(exc), code=2) from exc


@urdf.command("check", context_settings=CONTEXT_SETTINGS)
@click.argument("path", metavar="URDF")
@model_options
def check(path: str, **model: Any) -> None:
    """Parse and check a URDF like check_urdf: the link tree with joint types, or the error."""
    robot = load_or_fail(path, **model)
    print(f"robot name is: {printable(robot.name)}")
    print("---------- Successfully Parsed XML ---------------")
    print(robot.tree_text())
    counts: dict[str, int] = {}
    for j in robot.joints.values():
        counts[j.type] = counts.get(j.type, 0) + 1
    summary = ", ".join(f"{n} {t}" for t, n in sorted(counts.items()))
    print(f"{len(robot.links)} links, {len(robot.joints)} joints" + (f" ({summary})" if summary else ""))
    mimics = [f"mimic: {printable(j.name)} = {j.mimic.multiplier:g} * {printable(j.mimic.joint)} + {j.mimic.offset:g}"
              for j in robot.joints.values() if j.mimic is not None]
    if mimics:  # one write: a model can have 100,000 of them
        print("\n".join(mimics))
    for link, filename in robot.missing_meshes():
        print(f"mesh not found (drawn without it; frames unaffected): link '{printable(link)}': {printable(filename)}")


def urdf_dot(robot: Any) -> str:
    """urdf_to_graphiz's picture: links as boxes, joints as ellipses with their origin on the edge."""
    def q(s: str) -> str:  # a DOT string: quotes and backslashes escaped, no raw line breaks
        return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\r", "\\r") + '"'

    def num(v: float) -> str:
        return f"{v:.6g}"

    lines = [f"digraph {q(robot.name)} {{", "node [shape=box];"]
    for name in robot.links:
        lines.append(f"{q(name)} [label={q(name)}];")
    lines.append("node [shape=ellipse, color=blue, fontcolor=blue];")
    for j in robot.joints_in_order():
        xyz = " ".join(num(v) for v in j.origin.xyz)
        rpy = " ".join(num(v) for v in j.origin.rpy)
        jid = q("joint:" + j.name)
        lines.append(f"{jid} [label={q(j.name + ' (' + j.type + ')')}];")
        lines.append(f'{q(j.parent)} -> {jid} [label="xyz: {xyz} \\nrpy: {rpy}"];')
        lines.append(f"{jid} -> {q(j.child)};")
    lines.append("}")
    return "\n".join(lines) + "\n"


_UNSAFE_FILE_CHARS = re.compile(r"[^A-Za-z0-9._+-]+")


def graph_file_stem(robot_name: str) -> str:
    """The default output name for a robot: a plain file name for the current folder, whatever the model
    calls itself (no folders, no leading '-' or '.', no control characters, at most 64 characters)."""
    stem = _UNSAFE_FILE_CHARS.sub("_", robot_name).lstrip("-.")[:64].rstrip(".")
    return stem or "robot"


@urdf.command("graph", context_settings=CONTEXT_SETTINGS)
@click.argument("path", metavar="URDF")
@click.option("--output", "-o", default=None, metavar="NAME",
              help="Write NAME.gv and NAME.pdf (a .svg/.png suffix picks that format). Default: the robot's "
                   "name made a plain file name, in the current folder.")
@model_options
def graph(path: str, output: Optional[str], **model: Any) -> None:
    """Draw the link/joint tree like urdf_to_graphiz: a Graphviz .gv file and its rendering."""
    from .tf import write_graph

    robot = load_or_fail(path, **model)
    dot_path, img_path, problem = write_graph(urdf_dot(robot), output, graph_file_stem(robot.name))
    if problem:
        click.echo(f"warning: {printable(problem)}", err=True)
    print(f"Created file {printable(dot_path)}" + (f" and {printable(img_path)}" if img_path else ""))
