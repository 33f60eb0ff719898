"""`zentf graph`: the node <-> topic graph (rqt_graph) as DOT + image + text."""
from __future__ import annotations

import click

from .common import CONTEXT_SETTINGS

__all__ = ["graph"]


@click.command("graph", context_settings=CONTEXT_SETTINGS)
def graph() -> None:
    """The node <-> topic graph."""
