"""A child program for the parameter tests: `speed` (double, a callback refuses negatives) and `mode`
(string); prints `speed is now X` after each accepted set and `ready` once it serves."""
from __future__ import annotations

import sys

from zentf.core.parameters import SetParametersResult
from zentf.transport.node import Node


def main() -> int:
    node = Node("param_node")
    node.declare_parameter("speed", 1.0)
    node.declare_parameter("mode", "auto")
    node.declare_parameter("gains", [1.0, 2.0])

    def check(params) -> SetParametersResult:
        for p in params:
            if p.name == "speed" and p.value < 0:
                return SetParametersResult(successful=False, reason="speed must be >= 0")
        return SetParametersResult(successful=True)

    def report() -> None:
        print(f"speed is now {node.get_parameter('speed').value!r}", flush=True)

    def after(params) -> SetParametersResult:
        if any(p.name == "speed" for p in params):
            node._post(report)  # runs after the set is applied
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(check)
    node.add_on_set_parameters_callback(after)
    print("ready", flush=True)
    node.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
