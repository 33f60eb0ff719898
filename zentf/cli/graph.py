"""`zentf graph`: the node <-> topic graph (what rqt_graph shows) as text, DOT and an image."""
from __future__ import annotations

import sys
from typing import Optional

import click

from .common import CONTEXT_SETTINGS, liveliness_wait_option, CliError, CliOptions, with_options

__all__ = ["graph"]


@click.command("graph", context_settings=CONTEXT_SETTINGS)
@click.option("--output", "-o", default=None, metavar="NAME",
              help="Write NAME.gv and NAME.pdf (a .svg/.png suffix picks that format).")
@click.option("--dot", "print_dot", is_flag=True, help="Print the DOT source instead of the text listing.")
@click.option("--all", "-a", "show_all", is_flag=True,
              help="Include hidden nodes (CLI tools, names starting with '_').")
@liveliness_wait_option
@with_options
def graph(output: Optional[str], print_dot: bool, show_all: bool, wait: float, *, opts: CliOptions) -> None:
    """The node <-> topic graph: who publishes (node -> topic) and subscribes (topic -> node)."""
    from .format import NodeDesc, format_node_graph, node_graph_dot, printable
    from .introspect import graph_namespace, graph_snapshot
    from .node import is_hidden

    nodes, _ = graph_snapshot(opts, wait, graph_namespace(opts))
    descs = [NodeDesc(n.fq_name, dict(n.publishers), dict(n.subscriptions))
             for fq, n in sorted(nodes.items()) if show_all or not is_hidden(fq)]
    if not descs:
        raise CliError("no live nodes found" + (f" in namespace /{graph_namespace(opts)}"
                                                 if graph_namespace(opts) else ""))
    dot_text = node_graph_dot(descs)
    print(dot_text.rstrip() if print_dot else format_node_graph(descs))
    if output:
        from .tf import write_graph

        dot_path, img_path, problem = write_graph(dot_text, output, "graph")
        print(f"Wrote {dot_path}" + (f" and {img_path}" if img_path else ""))
        if problem:
            sys.stderr.write(f"zentf: warning: {printable(problem)}\n")
