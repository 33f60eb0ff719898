"""tf2_ros's buffer_server node: keep the tf buffer here, answer BufferClients' lookups.

Listens to `tf` and `tf_static` into a Buffer of `buffer_size` seconds (default 120, tf2_ros's) and
serves it on `tf2_buffer_server` (parameter `service_name`). Prints `serving <name>` once ready.
"""
from __future__ import annotations

from typing import Sequence

from nodes import _common
from zentf.buffer import Buffer
from zentf.buffer_server import DEFAULT_NAME, BufferServer
from zentf.listener import TransformListener
from zentf.options import NodeOptions

PROG = "buffer_server"


def main(argv: Sequence[str] | None = None) -> int:
    return _common.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with _common.make_node(opts, "tf2_buffer_server") as node:
        buffer = Buffer(cache_time=_common.param_positive(node, "buffer_size", 120.0), node=node)
        TransformListener(buffer, node)
        server = BufferServer(buffer, node, str(_common.param(node, "service_name", DEFAULT_NAME)))
        _common.say(f"serving {server.name}")
        node.spin()


if __name__ == "__main__":
    _common.finish(main())
