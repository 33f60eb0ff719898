"""Services and parameters under the ros2 wire profile (rmw_zenoh's service wire), between real processes.

A zentf node started with ``--wire ros2`` (ZENTF_WIRE=ros2) serves its rcl_interfaces parameter services
and its own services as rmw_zenoh does; `zentf param` and `zentf service` reach them with ``--wire ros2``.
Interop with zenoh-ros2-sdk (an independent ROS 2-over-Zenoh implementation, test-only): its client calls
zentf's services (SetBool and the parameter services), zentf's client calls its server. The SDK computes
the service type hashes itself, so the calls only meet when both sides agree on the service keys.
A service type zentf has no .srv definition for is skipped with one warning; the node runs.
Each test has its own router and ROS domain.
"""
from __future__ import annotations

import json
import logging
import sys
import time
import uuid
from dataclasses import dataclass
from typing import ClassVar

import pytest
from cli_helpers import assert_one_line_error, zentf

from conftest import REPO, router_address
from zentf.core.messages import Message
from zentf.core.services import ServiceType, Trigger
from zentf.transport.node import Node
from zentf.transport.options import NodeOptions, ZenohOptions
from zentf.transport.service import ServiceUnavailableError

SDK_SERVICE = [sys.executable, str(REPO / "tests" / "ros2_sdk_service.py")]


@pytest.fixture
def cli_env(ros2_env: dict[str, str]) -> dict[str, str]:
    """The same for `zentf` commands, which are given ``--wire ros2`` on the command line instead."""
    return {k: v for k, v in ros2_env.items() if k != "ZENTF_WIRE"}


def _ok(proc) -> str:
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    return proc.stdout


def test_ros2_node_starts_and_param_cli_works(ros2_env, cli_env, spawn) -> None:
    node = spawn([sys.executable, "tests/param_node.py"], ros2_env)
    node.wait_for_line("^ready$", 40)
    w = ["--wire", "ros2"]
    assert _ok(zentf(["param", "list", "param_node", *w], cli_env)).splitlines() == [
        "  gains", "  mode", "  speed", "  use_sim_time"]
    assert _ok(zentf(["param", "get", "param_node", "speed", *w], cli_env)) == "Double value is: 1.0\n"
    assert _ok(zentf(["param", "set", "param_node", "speed", "2.5", *w], cli_env)) == "Set parameter successful\n"
    node.wait_for_line(r"^speed is now 2\.5$", 20)
    assert _ok(zentf(["param", "get", "param_node", "speed", *w], cli_env)) == "Double value is: 2.5\n"
    assert_one_line_error(zentf(["param", "set", "param_node", "speed", "-1", *w], cli_env),
                          "Setting parameter failed: speed must be >= 0", code=1)
    assert_one_line_error(zentf(["param", "set", "param_node", "mode", "true", *w], cli_env),
                          "{mode} is of type {string}, setting it to {bool}", code=1)
    # ROS 2 graph: the parameter services are rcl_interfaces services of the node
    listed = _ok(zentf(["service", "list", "-t", *w], cli_env)).splitlines()
    assert "/param_node/get_parameters [rcl_interfaces/srv/GetParameters]" in listed
    assert "/param_node/set_parameters [rcl_interfaces/srv/SetParameters]" in listed
    # zentf's own profile does not see them: they live on ROS 2's keys and tokens
    assert "/param_node/get_parameters" not in zentf(["service", "list", "--wait", "1"], cli_env).stdout
    assert "Traceback" not in node.output()


def test_service_call_under_ros2(ros2_env, cli_env, spawn) -> None:
    server = spawn([sys.executable, "tests/service_server.py"], ros2_env)
    server.wait_for_line("^serving$", 40)
    w = ["--wire", "ros2"]
    out = _ok(zentf(["service", "call", "/echo", "std_srvs/srv/SetBool", "{data: true}", *w], cli_env))
    assert out.endswith("response:\nsuccess: true\nmessage: data was True\n"), out
    assert_one_line_error(zentf(["service", "call", "/fail", "std_srvs/srv/Trigger", *w], cli_env),
                          "service /fail failed: RuntimeError: the disk is full")
    # a zentf client without the profile does not reach a ros2 server: it is not in zentf's graph
    assert_one_line_error(zentf(["service", "call", "/echo", "std_srvs/srv/SetBool", "{data: true}",
                                 "--timeout", "1"], cli_env), "service /echo is not offered by any node")


def test_sdk_client_calls_zentf_services(ros2_env, spawn) -> None:
    spawn([sys.executable, "tests/service_server.py"], ros2_env).wait_for_line("^serving$", 40)
    spawn([sys.executable, "tests/param_node.py"], ros2_env).wait_for_line("^ready$", 40)
    sdk = spawn([*SDK_SERVICE, "call", router_address(ros2_env), "/param_node"], ros2_env)
    assert sdk.wait(90) == 0, sdk.output()
    values = [json.loads(x[len("RESULT "):]) for x in sdk.output().splitlines() if x.startswith("RESULT ")]
    assert values[0] == {"success": True, "message": "data was True"}
    assert values[1] == [{"type": 3, "double": 1.0}, {"type": 0, "double": 0.0}]  # speed, then not set
    assert values[2] == ["gains", "mode", "speed", "use_sim_time"]


def test_zentf_client_calls_sdk_server(ros2_env, cli_env, spawn) -> None:
    sdk = spawn([*SDK_SERVICE, "server", router_address(ros2_env)], ros2_env)
    sdk.wait_for_line("^serving$", 60)
    out = _ok(zentf(["service", "call", "/sdk_echo", "std_srvs/srv/SetBool", "{data: true}", "--wire", "ros2",
                     "--timeout", "30"], cli_env))
    assert out.endswith("response:\nsuccess: true\nmessage: sdk got True\n"), out
    sdk.wait_for_line("^request data=True$", 10)
    listed = _ok(zentf(["service", "list", "-t", "--wire", "ros2"], cli_env)).splitlines()
    assert "/sdk_echo [std_srvs/srv/SetBool]" in listed


@dataclass(slots=True)
class _NoDefinitionRequest(Message):
    TYPE_NAME: ClassVar[str] = "zentf_test_msgs/srv/NoDefinition_Request"
    x: int = 0


@dataclass(slots=True)
class _NoDefinitionResponse(Message):
    TYPE_NAME: ClassVar[str] = "zentf_test_msgs/srv/NoDefinition_Response"


class NoDefinition(ServiceType):
    """A service type of the program's own, with no ROS 2 .srv definition zentf knows."""

    TYPE_NAME = "zentf_test_msgs/srv/NoDefinition"
    Request = _NoDefinitionRequest
    Response = _NoDefinitionResponse


def test_type_without_definition_is_skipped_with_one_warning(isolated_router, caplog) -> None:
    opts = NodeOptions(zenoh=ZenohOptions(connect=[isolated_router], no_multicast=True, mode="client"),
                       wire="ros2", domain_id=1 + uuid.uuid4().int % 200)
    caplog.set_level(logging.WARNING)
    with Node("skipper", options=opts) as node:
        servers = [node.create_service(f"lookup{i}", NoDefinition, lambda req, resp: resp) for i in range(3)]
        client = node.create_client("lookup0", NoDefinition)
        assert not any(s.active for s in servers) and not client.active
        warnings = [r.getMessage() for r in caplog.records if "no ROS 2 definition" in r.getMessage()]
        assert len(warnings) == 1, warnings  # rate-limited: one line per type
        assert "zentf_test_msgs/srv/NoDefinition" in warnings[0] and "skipped" in warnings[0]
        assert client.wait_for_service(0.1) is False
        with pytest.raises(ServiceUnavailableError, match="no ROS 2 definition"):
            client.call(None, timeout=1.0)
        # the node runs: its other services work, on rmw_zenoh's key and tokens
        trig = node.create_service("trig", Trigger, lambda req, resp: Trigger.Response(success=True, message="ok"))
        assert trig.key == (f"{opts.domain_id}/trig/std_srvs::srv::dds_::Trigger_/"
                            "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f")
        caller = node.create_client("trig", Trigger)
        assert caller.wait_for_service(10)
        assert caller.call(None, timeout=10).message == "ok"
        tokens = [str(r.ok.key_expr) for r in node.session.liveliness().get(f"@ros2_lv/{opts.domain_id}/**",
                                                                           timeout=2.0) if r.ok is not None]
        ss = [t for t in tokens if "/SS/" in t]
        assert any(t.endswith("/skipper/%trig/std_srvs::srv::dds_::Trigger_/"
                              "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f/::,10:,:,:,,")
                   for t in ss), ss
        assert any("/SS/%/%/skipper/%skipper%get_parameters/rcl_interfaces::srv::dds_::GetParameters_/" in t
                   and t.endswith("/::,1000:,:,:,,") for t in ss), ss
        assert any("/SC/%/%/skipper/%trig/" in t for t in tokens), tokens


def test_bad_ros2_requests_get_an_error_reply_and_one_line(isolated_router, caplog) -> None:
    import zenoh

    from zentf.core.services import SetBool
    from zentf.transport.wire.profiles import parse_ros2_attachment, ros2_attachment
    from zentf.ros import decode

    opts = NodeOptions(zenoh=ZenohOptions(connect=[isolated_router], no_multicast=True, mode="client"),
                       wire="ros2", domain_id=1 + uuid.uuid4().int % 200)
    caplog.set_level(logging.WARNING)
    served: list = []
    with Node("strict", options=opts) as node:
        srv = node.create_service("echo", SetBool, lambda req, resp: served.append(req) or SetBool.Response(True, "x"))
        raw = opts.zenoh.open_session()
        try:
            querier = raw.declare_querier(srv.key, target=zenoh.QueryTarget.ALL_COMPLETE)
            deadline = time.monotonic() + 10
            while not querier.matching_status.matching and time.monotonic() < deadline:
                time.sleep(0.02)  # polls an event Zenoh offers only as a status here

            def ask(payload: bytes, attachment: bytes | None) -> list:
                return [(r.ok, r.err) for r in raw.get(srv.key, target=zenoh.QueryTarget.ALL_COMPLETE, payload=payload,
                                                       attachment=attachment, timeout=10.0)]

            gid = bytes(range(16))
            (ok, err), = ask(b"\x00\x01\x00\x00\x01", None)  # no rmw_zenoh attachment: refused
            assert ok is None and "without rmw_zenoh attachment" in err.payload.to_bytes().decode()
            (ok, err), = ask(b"\x00\x01\x00", ros2_attachment(1, 5, gid))  # truncated CDR
            assert ok is None and "bad request for std_srvs/srv/SetBool" in err.payload.to_bytes().decode()
            (ok, err), = ask(b"\x00\x01\x00\x00\x01", ros2_attachment(7, 5, gid))  # data: true
            assert err is None
            seq, _, back_gid = parse_ros2_attachment(ok.attachment.to_bytes())
            assert (seq, back_gid) == (7, gid)  # the reply carries the request's sequence number and GID
            assert decode(ok.payload.to_bytes(), "std_srvs/srv/SetBool_Response").success is True
            assert [r.data for r in served] == [True]
        finally:
            raw.close()
    lines = [r.getMessage() for r in caplog.records if "/echo" in r.getMessage()]
    assert len(lines) == 1 and "refused" in lines[0], lines  # rate-limited per service


def test_parameter_types_and_atomic_sets_over_ros2(ros2_env, spawn, isolated_router) -> None:
    from zentf.core.parameters import (PARAMETER_DOUBLE, PARAMETER_DOUBLE_ARRAY, PARAMETER_NOT_SET,
                                       PARAMETER_STRING, GetParameterTypes, ParameterMsg,
                                       SetParametersAtomically, to_value)

    node_proc = spawn([sys.executable, "tests/param_node.py"], ros2_env)
    node_proc.wait_for_line("^ready$", 40)
    opts = NodeOptions(zenoh=ZenohOptions(connect=[isolated_router], no_multicast=True, mode="client"),
                       wire="ros2", domain_id=int(ros2_env["ROS_DOMAIN_ID"]))
    with Node("_asker", options=opts) as node:
        types = node.create_client("/param_node/get_parameter_types", GetParameterTypes)
        atomic = node.create_client("/param_node/set_parameters_atomically", SetParametersAtomically)
        assert types.wait_for_service(20) and atomic.wait_for_service(20)
        got = types.call(GetParameterTypes.Request(names=["speed", "mode", "gains", "nope"]), timeout=20).types
        assert got == [PARAMETER_DOUBLE, PARAMETER_STRING, PARAMETER_DOUBLE_ARRAY, PARAMETER_NOT_SET]

        def both(speed: object, mode: object) -> object:
            req = SetParametersAtomically.Request(parameters=[ParameterMsg("speed", to_value(speed)),
                                                              ParameterMsg("mode", to_value(mode))])
            return atomic.call(req, timeout=20).result

        refused = both(-1.0, "manual")  # the callback refuses speed: mode is not set either
        assert (refused.successful, refused.reason) == (False, "speed must be >= 0")
        wrong = both(3.0, True)         # mode is a string: speed is not set either
        assert not wrong.successful and "{mode} is of type {string}" in wrong.reason
        assert both(3.0, "manual").successful
        node_proc.wait_for_line(r"^speed is now 3\.0$", 20)
        assert "speed is now -1.0" not in node_proc.output()
