"""Node parameters over the network: ROS 2's parameter services on every node, and a client for tools.

A node serves ``~/get_parameters``, ``~/set_parameters``, ``~/list_parameters``,
``~/describe_parameters``, ``~/get_parameter_types`` and ``~/set_parameters_atomically`` (rcl_interfaces
types, as rclcpp's ParameterService; keys ``<ns>/<node>/<service>``, or rmw_zenoh's with --wire ros2), so
``zentf param list / get / set / dump`` reach it from anywhere. A set is checked against the type the
parameter was declared with, then offered to the node's ``add_on_set_parameters_callback`` callbacks
(any may reject it, with a reason), then applied; ``use_sim_time`` switches the node's clock.
"""
from __future__ import annotations

import logging
from typing import Any

from ..core.parameters import (PARAMETER_NOT_SET, TYPE_NAMES, DescribeParameters, GetParameters,
                              GetParameterTypes, ListParameters, ListParametersResult, ParameterDescriptor,
                              ParameterMsg, ParameterValue, SetParameters, SetParametersAtomically,
                              SetParametersResult, check_type, coerce, from_value, to_value, type_of)

__all__ = ["ParameterService", "ParameterClient", "InvalidParameterTypeException",
           "InvalidParameterValueException", "declared_type", "set_one", "set_all", "raise_for", "SERVICE_NAMES"]

log = logging.getLogger("zentf.transport.parameters")

#: The parameter services of a node, relative to its fully qualified name (ROS 2's names).
SERVICE_NAMES = ("get_parameters", "set_parameters", "list_parameters", "describe_parameters")


class InvalidParameterTypeException(TypeError):
    """A set of another type than the parameter was declared with (rclpy's name)."""


class InvalidParameterValueException(ValueError):
    """A set that an on-set-parameters callback rejected (rclpy's name)."""


def declared_type(default: Any, value: Any) -> tuple[int, Any]:
    """(type the parameter keeps: the default's, else the value's; the value, widened if it fits).

    An override of another type (say a launch substitution left as text) is kept as given, as before:
    the declared type binds the sets that come later. Not set = any type (e.g. a YAML mapping).
    """
    try:
        ptype = type_of(default if default is not None else value)
    except ValueError:
        return PARAMETER_NOT_SET, value
    if check_type("", value, ptype) is None:
        value = coerce(value, ptype)
    return ptype, value


def _result(ok: Any) -> SetParametersResult:
    """A callback's answer as a SetParametersResult (rclpy's type; bool and (bool, reason) work too)."""
    if isinstance(ok, SetParametersResult):
        return ok
    if isinstance(ok, tuple) and len(ok) == 2:
        return SetParametersResult(bool(ok[0]), str(ok[1]))
    if ok is None or isinstance(ok, bool):
        return SetParametersResult(ok is not False, "" if ok is not False else "rejected by a parameter callback")
    raise TypeError(f"an on-set-parameters callback returned {type(ok).__name__}, expected SetParametersResult")


def set_one(node: Any, name: str, value: Any) -> SetParametersResult:
    """Check, offer to the callbacks, apply: the result says why a set was refused."""
    res = set_all(node, [(name, value)])
    if res.successful:
        node.get_logger().debug("parameter %s set to %r", name, node._params[name].value)
    return res


def set_all(node: Any, items: list[tuple[str, Any]]) -> SetParametersResult:
    """All or nothing (set_parameters_atomically): every value checked, the callbacks offered the whole
    list at once, then all applied; the result says why nothing was set."""
    checked = []
    for name, value in items:
        if name not in node._params:
            return SetParametersResult(False, f"parameter '{name}' is not declared on {node.get_fully_qualified_name()}")
        declared = node._param_types.get(name, PARAMETER_NOT_SET)
        problem = check_type(name, value, declared)
        if problem is not None:
            return SetParametersResult(False, problem)
        value = coerce(value, declared)
        if name == "use_sim_time" and not isinstance(value, bool):
            return SetParametersResult(False, "use_sim_time must be true or false")
        checked.append((name, value))
    for cb in list(node._param_callbacks):
        try:
            res = _result(cb([type(node._params[n])(n, v) for n, v in checked]))
        except Exception as e:
            return SetParametersResult(False, f"a parameter callback raised {type(e).__name__}: {e}")
        if not res.successful:
            return SetParametersResult(False, res.reason or "rejected by a parameter callback")
    for name, value in checked:
        node._params[name].value = value
        if name == "use_sim_time":
            node._set_use_sim_time(value)
    return SetParametersResult(True, "")


def raise_for(name: str, value: Any, result: SetParametersResult) -> None:
    """A refused local set as rclpy's exception."""
    if result.successful:
        return
    if result.reason.startswith("Wrong parameter type"):
        raise InvalidParameterTypeException(result.reason)
    raise InvalidParameterValueException(f"cannot set {name} to {value!r}: {result.reason}")


def _value_of(value: Any) -> ParameterValue:
    try:
        return to_value(value)
    except ValueError:  # e.g. a mapping from a params file: shown as text, not lost
        return to_value(repr(value))


class ParameterService:
    """The four parameter services of one node; handlers run on the node's executor."""

    def __init__(self, node: Any) -> None:
        self.node = node
        depth = 1000  # rmw_qos_profile_parameters, as rclcpp's parameter services (shown in ROS 2 tokens)
        node.create_service("~/get_parameters", GetParameters, self._get, qos=depth)
        node.create_service("~/set_parameters", SetParameters, self._set, qos=depth)
        node.create_service("~/list_parameters", ListParameters, self._list, qos=depth)
        node.create_service("~/describe_parameters", DescribeParameters, self._describe, qos=depth)
        node.create_service("~/get_parameter_types", GetParameterTypes, self._types, qos=depth)
        node.create_service("~/set_parameters_atomically", SetParametersAtomically, self._set_atomically, qos=depth)

    def _get(self, req: Any, resp: Any) -> Any:
        params = self.node._params
        resp.values = [_value_of(params[n].value) if n in params else ParameterValue() for n in req.names]
        return resp

    def _set(self, req: Any, resp: Any) -> Any:
        results = []
        for p in req.parameters:
            try:
                value = from_value(p.value)
            except ValueError as e:
                results.append(SetParametersResult(False, str(e)))
                continue
            results.append(set_one(self.node, p.name, value))
        resp.results = results
        return resp

    def _set_atomically(self, req: Any, resp: Any) -> Any:
        try:
            items = [(p.name, from_value(p.value)) for p in req.parameters]
        except ValueError as e:
            resp.result = SetParametersResult(False, str(e))
            return resp
        resp.result = set_all(self.node, items)
        return resp

    def _types(self, req: Any, resp: Any) -> Any:
        params, types = self.node._params, self.node._param_types
        resp.types = [types.get(n, PARAMETER_NOT_SET) if n in params else PARAMETER_NOT_SET for n in req.names]
        return resp

    def _list(self, req: Any, resp: Any) -> Any:
        names = sorted(self.node._params)
        if req.prefixes:
            names = [n for n in names if any(n == p or n.startswith(p + ".") for p in req.prefixes)]
        if req.depth > 0:
            names = [n for n in names if n.count(".") < req.depth]
        prefixes = sorted({n.rsplit(".", 1)[0] for n in names if "." in n})
        resp.result = ListParametersResult(names=names, prefixes=prefixes)
        return resp

    def _describe(self, req: Any, resp: Any) -> Any:
        types = self.node._param_types
        resp.descriptors = [ParameterDescriptor(name=n, type=types.get(n, PARAMETER_NOT_SET))
                            for n in req.names if n in self.node._params]
        return resp


class ParameterClient:
    """Another node's parameters (for tools): ``list``, ``get``, ``set``, ``describe``."""

    def __init__(self, node: Any, remote_node: str) -> None:
        fq = remote_node if remote_node.startswith("/") else "/" + remote_node
        self.remote_node = fq.rstrip("/")
        self._clients = {name: node.create_client(f"{self.remote_node}/{name}", srv)
                         for name, srv in zip(SERVICE_NAMES, (GetParameters, SetParameters, ListParameters,
                                                              DescribeParameters))}

    def wait(self, timeout: float) -> bool:
        """True once the node's parameter services are reachable."""
        return self._clients["list_parameters"].wait_for_service(timeout)

    def list(self, timeout: float = 5.0) -> list[str]:
        return list(self._clients["list_parameters"].call(ListParameters.Request(), timeout).result.names)

    def get(self, names: list[str], timeout: float = 5.0) -> list[Any]:
        """Values (None for a name the node has not declared)."""
        resp = self._clients["get_parameters"].call(GetParameters.Request(names=list(names)), timeout)
        return [from_value(v) for v in resp.values]

    def set(self, name: str, value: Any, timeout: float = 5.0) -> SetParametersResult:
        req = SetParameters.Request(parameters=[ParameterMsg(name=name, value=to_value(value))])
        return self._clients["set_parameters"].call(req, timeout).results[0]

    def describe(self, names: list[str], timeout: float = 5.0) -> dict[str, str]:
        """{name: type name ('double', 'string', ...)}."""
        resp = self._clients["describe_parameters"].call(DescribeParameters.Request(names=list(names)), timeout)
        return {d.name: TYPE_NAMES.get(d.type, "unknown") for d in resp.descriptors}
