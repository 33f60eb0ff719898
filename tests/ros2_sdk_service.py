"""Service side of the live tests, made with zenoh-ros2-sdk (an independent ROS 2-over-Zenoh implementation).

    python tests/ros2_sdk_service.py server ROUTER_HOST:PORT     # serves /sdk_echo (std_srvs/srv/SetBool)
    python tests/ros2_sdk_service.py call ROUTER_HOST:PORT NODE  # calls a node's services, prints JSON

``server`` answers ``success = data`` and ``message = "sdk got <data>"`` and prints ``serving``.
``call`` calls ``/echo`` (SetBool, data true), then NODE's ``get_parameters`` (names speed, nope) and
``list_parameters``, and prints one line `RESULT <json>` per response (``null`` when the SDK got none).
ROS_DOMAIN_ID picks the domain. The SDK reads its definitions from tests/data/ros2_msgs.
"""
from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from pathlib import Path

MSGS = Path(__file__).resolve().parent / "data" / "ros2_msgs"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("mode", choices=("server", "call"))
    ap.add_argument("router")
    ap.add_argument("node", nargs="?", default="/param_node")
    args = ap.parse_args()
    host, _, port = args.router.rpartition(":")

    from zenoh_ros2_sdk import ROS2ServiceClient, ROS2ServiceServer, get_registry
    from zenoh_ros2_sdk.session import ZenohSession

    ZenohSession.get_instance(host, int(port))  # first: the SDK's shared session, on our router
    get_registry(str(MSGS))  # the first call fixes the registry's folder
    common = dict(router_ip=host, router_port=int(port))

    if args.mode == "server":
        stop = threading.Event()
        signal.signal(signal.SIGTERM, lambda *a: stop.set())
        signal.signal(signal.SIGINT, lambda *a: stop.set())
        server: ROS2ServiceServer | None = None

        def echo(req: object) -> object:
            print(f"request data={req.data}", flush=True)
            return server.response_msg_class(success=bool(req.data), message=f"sdk got {req.data}")

        server = ROS2ServiceServer("/sdk_echo", "std_srvs/srv/SetBool", callback=echo, node_name="sdk_server",
                                   **common)
        print("serving", flush=True)
        stop.wait()
        server.close()
        return 0

    echo = ROS2ServiceClient("/echo", "std_srvs/srv/SetBool", node_name="sdk_client", timeout=20.0, **common)
    r = echo.call(data=True)
    print("RESULT " + json.dumps(None if r is None else {"success": bool(r.success), "message": r.message}), flush=True)
    get = ROS2ServiceClient(f"{args.node}/get_parameters", "rcl_interfaces/srv/GetParameters",
                            node_name="sdk_client", timeout=20.0, **common)
    r = get.call(names=["speed", "nope"])
    print("RESULT " + json.dumps(None if r is None else [{"type": int(v.type), "double": float(v.double_value)}
                                             for v in r.values]), flush=True)
    lst = ROS2ServiceClient(f"{args.node}/list_parameters", "rcl_interfaces/srv/ListParameters",
                            node_name="sdk_client", timeout=20.0, **common)
    r = lst.call(prefixes=[], depth=0)
    print("RESULT " + json.dumps(None if r is None else sorted(r.result.names)), flush=True)
    for c in (echo, get, lst):
        c.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
