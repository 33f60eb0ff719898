"""A child program for the service tests: serves `echo` (SetBool, answers data in message), `fail`
(Trigger, whose handler raises), `stall` (Trigger, whose handler blocks until the process dies) and `frames`
(tf2_msgs/srv/FrameGraph, a type zentf has only a definition of: its class is made from it).

Prints `serving` once its services are declared and `handling stall` when a stall call arrives.
"""
from __future__ import annotations

import sys
import threading

from zentf.core.services import SetBool, Trigger
from zentf.ros.classes import service_class
from zentf.transport.node import Node


def main() -> int:
    node = Node("service_server")

    def echo(req: SetBool.Request, resp: SetBool.Response) -> SetBool.Response:
        resp.success = req.data
        resp.message = f"data was {req.data}"
        return resp

    def fail(req: Trigger.Request) -> Trigger.Response:
        raise RuntimeError("the disk is full")

    def stall(req: Trigger.Request) -> Trigger.Response:
        print("handling stall", flush=True)
        threading.Event().wait()  # never answers: the test kills this process
        return Trigger.Response()

    node.create_service("echo", SetBool, echo)
    node.create_service("fail", Trigger, fail)
    node.create_service("stall", Trigger, stall)
    frame_graph = service_class("tf2_msgs/srv/FrameGraph")
    node.create_service("frames", frame_graph, lambda req, resp: frame_graph.Response(frame_yaml="av1: {parent: world}"))
    print("serving", flush=True)
    node.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
