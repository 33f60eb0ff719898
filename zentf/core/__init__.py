"""zentf.core: tf2 itself (time, messages, math, per-frame caches, BufferCore, batches); no Zenoh, nothing from outside.

Mirrors tf2's own split: ``buffer_core`` (BufferCore, the walk) over ``cache`` (TimeCache and
StaticCache, one object per frame), with ``time``, ``messages``, ``rotation`` (numpy-free),
``math3d``, ``exceptions``, ``constants`` below, and beside it ``geometry`` (do_transform_*) and
``batch`` (whole series and clouds at once, over BufferCore's walk). ``buffer_core``, ``cache`` and
``time`` are compiled (Cython, built on install). The transport
(``zentf.transport.node``, ``zentf.transport.listener`` ...) builds on this package, never the other way.
"""
from __future__ import annotations

import importlib
from typing import Any

from .exceptions import (ConnectivityException, ExtrapolationException, InvalidArgumentException,
                         LookupException, TimeoutException, TransformException, TypeException)
from .time import Duration, Time

__all__ = ["BufferCore", "Time", "Duration", "TransformException", "LookupException", "ConnectivityException",
           "ExtrapolationException", "InvalidArgumentException", "TimeoutException", "TypeException"]


def __getattr__(name: str) -> Any:
    """BufferCore loads on first use, so importing the core's messages stays light."""
    if name == "BufferCore":
        value = importlib.import_module(".buffer_core", __name__).BufferCore
        globals()[name] = value
        return value
    raise AttributeError(f"module 'zentf.core' has no attribute {name!r}")
