"""A child program for the service tests: serves `echo` (SetBool, answers data in message), `fail`
(Trigger, whose handler raises) and `stall` (Trigger, whose handler blocks until the process dies).

Prints `serving` once its services are declared and `handling stall` when a stall call arrives.
"""
from __future__ import annotations

import sys
import threading

from zentf.core.services import SetBool, Trigger
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
    print("serving", flush=True)
    node.spin()
    return 0


if __name__ == "__main__":
    sys.exit(main())
