"""`zentf node`: introspection over liveliness."""
from __future__ import annotations

import click

from .common import CONTEXT_SETTINGS

__all__ = ["node"]


@click.group("node", context_settings=CONTEXT_SETTINGS)
def node() -> None:
    """node tools."""
