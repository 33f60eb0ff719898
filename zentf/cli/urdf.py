"""`zentf urdf check | graph`: check_urdf and urdf_to_graphiz for URDF (and .xacro) files."""
from __future__ import annotations

from typing import Optional

import click

from .common import CONTEXT_SETTINGS, CliError

__all__ = ["urdf", "load_or_fail"]


@click.group("urdf", context_settings=CONTEXT_SETTINGS)
def urdf() -> None:
    """Robot models: check (check_urdf), graph (urdf_to_graphiz)."""


package_path_option = click.option("--package-path", "package_path", multiple=True, metavar="DIR",
                                   help="Where package:// meshes are looked up (repeat; also $ZENTF_PACKAGE_PATH).")


def load_or_fail(path: str, package_path: tuple[str, ...] = ()):
    """The checked model, or the one-line refusal as a usage error (exit 2)."""
    from zentf.urdf import URDFError, load_urdf

    try:
        return load_urdf(path, package_path=list(package_path))
    except URDFError as exc:
        raise CliError(str(exc), code=2) from exc


@urdf.command("check", context_settings=CONTEXT_SETTINGS)
@click.argument("path", metavar="URDF")
@package_path_option
def check(path: str, package_path: tuple[str, ...]) -> None:
    """Parse and check a URDF like check_urdf: the link tree with joint types, or the error."""
    robot = load_or_fail(path, package_path)
    print(f"robot name is: {robot.name}")
    print("---------- Successfully Parsed XML ---------------")
    print(robot.tree_text())
    counts: dict[str, int] = {}
    for j in robot.joints.values():
        counts[j.type] = counts.get(j.type, 0) + 1
    summary = ", ".join(f"{n} {t}" for t, n in sorted(counts.items()))
    print(f"{len(robot.links)} links, {len(robot.joints)} joints" + (f" ({summary})" if summary else ""))
    mimics = [j for j in robot.joints.values() if j.mimic is not None]
    for j in mimics:
        print(f"mimic: {j.name} = {j.mimic.multiplier:g} * {j.mimic.joint} + {j.mimic.offset:g}")
    for link, filename in robot.missing_meshes():
        print(f"mesh not found (drawn without it; frames unaffected): link '{link}': {filename}")


def urdf_dot(robot) -> str:
    """urdf_to_graphiz's picture: links as boxes, joints as ellipses with their origin on the edge."""
    def q(s: str) -> str:
        return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'

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


@urdf.command("graph", context_settings=CONTEXT_SETTINGS)
@click.argument("path", metavar="URDF")
@click.option("--output", "-o", default=None, metavar="NAME",
              help="Write NAME.gv and NAME.pdf (a .svg/.png suffix picks that format). Default: the robot's name.")
@package_path_option
def graph(path: str, output: Optional[str], package_path: tuple[str, ...]) -> None:
    """Draw the link/joint tree like urdf_to_graphiz: a Graphviz .gv file and its rendering."""
    from .tf import write_graph

    robot = load_or_fail(path, package_path)
    dot_path, img_path, problem = write_graph(urdf_dot(robot), output, robot.name)
    if problem:
        click.echo(f"warning: {problem}", err=True)
    print(f"Created file {dot_path}" + (f" and {img_path}" if img_path else ""))
