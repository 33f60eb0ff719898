"""Undeclaring what a node, service or tool declared on its session (subscribers, publishers, queryables, tokens)."""
from __future__ import annotations

from collections.abc import Iterable
from typing import Any

__all__ = ["undeclare_all"]


def undeclare_all(objs: Iterable[Any]) -> None:
    """Undeclare each object (None skipped); one that fails (session already closed) does not stop the rest."""
    for obj in objs:
        if obj is None:
            continue
        try:
            obj.undeclare()
        except Exception:  # noqa: BLE001 - closing must reach every object
            pass
