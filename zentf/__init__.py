"""zentf: tf2 coordinate transforms for processes that talk over Zenoh.

The core (time, messages, math, buffer) imports no Zenoh; transport names (Node,
TransformListener, ...) load lazily on first use so `import zentf` stays light.
"""
from __future__ import annotations

import importlib
from typing import Any

from .core.exceptions import (ConnectivityException, ExtrapolationException, InvalidArgumentException,
                              LookupException, TimeoutException, TransformException, TypeException)
from .core.messages import (Header, Point, PointStamped, Pose, PoseStamped, Quaternion, TFMessage,
                            Transform, TransformStamped, Vector3, Vector3Stamped)
from .core.time import Duration, Time

__version__ = "0.1.0"

# name -> module that defines it; filled in as layers land (core first, transport on top).
_LAZY: dict[str, str] = {
    "BufferCore": "zentf.core.buffer_core",
    "Buffer": "zentf.transport.buffer",
    "Node": "zentf.transport.node",
    "TransformListener": "zentf.transport.listener",
    "TransformBroadcaster": "zentf.transport.broadcaster",
    "StaticTransformBroadcaster": "zentf.transport.broadcaster",
    "MessageFilter": "zentf.transport.message_filter",
    "Clock": "zentf.transport.clock",
    "Rate": "zentf.transport.clock",
    "BufferServer": "zentf.transport.buffer_server",
    "BufferClient": "zentf.transport.buffer_server",
    "ServiceException": "zentf.transport.service",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'zentf' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


__all__ = [
    "Time", "Duration", "Header", "Point", "PointStamped", "Pose", "PoseStamped", "Quaternion",
    "TFMessage", "Transform", "TransformStamped", "Vector3", "Vector3Stamped",
    "TransformException", "LookupException", "ConnectivityException", "ExtrapolationException",
    "InvalidArgumentException", "TimeoutException", "TypeException", *_LAZY,
]
