"""tf2_ros's buffer_server node: keep the tf buffer here, answer BufferClients' lookups.

Listens to `tf` and `tf_static` into a Buffer of `buffer_size` seconds (default 120, tf2_ros's) and
serves it on `tf2_buffer_server` (parameter `service_name`). Prints `serving <name>` once ready.
A lookup waits for its data at most `max_wait` seconds (default 60), and never after its caller gave up.
"""
from __future__ import annotations

from typing import Sequence

from ..transport import program
from ..transport.buffer import Buffer
from ..transport.buffer_server import DEFAULT_MAX_WAIT, DEFAULT_NAME, BufferServer
from ..transport.listener import TransformListener
from ..transport.options import NodeOptions

PROG = "buffer_server"


def main(argv: Sequence[str] | None = None) -> int:
    return program.main(PROG, argv, _run, __doc__)


def _run(opts: NodeOptions) -> None:
    with program.make_node(opts, "tf2_buffer_server") as node:
        buffer = Buffer(cache_time=program.param_positive(node, "buffer_size", 120.0), node=node)
        TransformListener(buffer, node)
        max_wait = program.param_positive(node, "max_wait", DEFAULT_MAX_WAIT)
        if max_wait > 1e6:
            raise program.OptionsError(f"parameter max_wait must be at most 1e6 seconds, got {max_wait!r}")
        server = BufferServer(buffer, node, str(program.param(node, "service_name", DEFAULT_NAME)),
                              max_wait=max_wait)
        program.say(f"serving {server.name}")
        node.spin()


if __name__ == "__main__":
    program.finish(main())
