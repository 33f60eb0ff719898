"""``convert``: ROS 1 / ROS 2 bags -> zentf MCAP, and zentf MCAP -> ROS 2 MCAP."""
from __future__ import annotations

import os
from collections.abc import Callable, Collection
from typing import Any

from .errors import BagError
from .formats import BagFormat
from .native import BagWriter
from .source import open_bag

__all__ = ["convert", "TARGETS"]

TARGETS = ("zentf", "ros2")


def convert(src: str | os.PathLike, dst: str | os.PathLike, *, to: str | None = None,
            topics: Collection[str] | None = None,
            on_skip: Callable[[str, str], None] | None = None) -> dict[str, Any]:
    """Write ``src`` to ``dst`` as ``to`` (default: zentf for a ROS bag, ros2 for a zentf bag).

    Returns {"messages": written, "format": target, "problem": what stopped reading src or None,
    "skipped": {topic: why}}. A ROS 2 target ending in ``.mcap`` is a single MCAP file, else a
    rosbag2 folder.
    """
    bag = open_bag(src)
    target = to or ("ros2" if bag.format is BagFormat.ZENTF else "zentf")
    if target not in TARGETS:
        raise BagError(f"unknown target format {target!r} (one of {', '.join(TARGETS)})")
    if os.path.abspath(os.fspath(dst)) == os.path.abspath(os.fspath(src)):
        raise BagError(f"{dst}: the output would overwrite the input")
    writer: Any
    if target == "zentf":
        writer = BagWriter(dst)
    else:
        from .ros2write import Ros2Writer

        writer = Ros2Writer(dst, on_skip=on_skip)
    n = 0
    try:
        for m in bag.zentf(topics, on_skip):
            writer.write(m.key, m.payload, m.encoding, m.sender, m.log_time, m.latched)
        n = writer.messages
    finally:
        writer.close()
    skipped = dict(bag.skipped)
    skipped.update(getattr(writer, "skipped", {}))
    return {"messages": n, "format": target, "problem": bag.problem, "skipped": skipped}
