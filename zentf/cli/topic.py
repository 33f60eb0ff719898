"""`zentf topic`: introspection over liveliness."""
from __future__ import annotations

import click

from .common import CONTEXT_SETTINGS

__all__ = ["topic"]


@click.group("topic", context_settings=CONTEXT_SETTINGS)
def topic() -> None:
    """topic tools."""
