"""A child program for the rate tests: a node whose 1 kHz timer and whose subscription callback always
raise, and a `speed` parameter; prints `ready` once it serves."""
from __future__ import annotations

import sys

from zentf.core.messages import String
from zentf.transport.node import Node


def main() -> int:
    node = Node("raising_node")
    node.declare_parameter("speed", 1.0)

    def tick() -> None:
        raise ZeroDivisionError("tick divides by zero")

    def on_msg(msg: String) -> None:
        raise KeyError("no such key in the message")

    node.create_timer(0.001, tick)
    node.create_subscription("chatter", String, on_msg)
    print("ready", flush=True)
    node.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
