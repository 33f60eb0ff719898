"""The one place where node identity and Zenoh options come from: flags > ZENTF_* env vars > defaults.

The options themselves are declared once, in ``SHARED_OPTIONS``.
Node programs: ``add_node_arguments(parser)`` then ``NodeOptions.from_args(parser.parse_args())``.
CLI (click) commands: ``zentf.cli.common.with_options`` builds the same options, then
``ZenohOptions.from_values(...)`` and ``.config()`` / ``.open_session()``.
Launcher: ``NodeOptions(...).to_env()`` gives the env vars that pass identity to a child.
"""
from __future__ import annotations

import argparse
import ipaddress
import json
import logging
import os
import re
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from ..core.text import parse_bool
from .names import fully_qualified_node_name, normalize_namespace, validate_node_name
from .shared_options import MODES, SHARED_OPTIONS, WIRES, SharedOption

__all__ = [
    "OptionsError", "ZenohOptions", "NodeOptions", "SharedOption", "SHARED_OPTIONS", "add_zenoh_arguments",
    "add_node_arguments", "node_options_help",
    "parse_param_assignment", "parse_remap", "load_params_file", "params_for_node", "ParamsFileError",
    "ROS_PARAMETERS", "ENV_VARS", "LOCAL_PORT", "exposure",
]

ENV_VARS = ("ZENTF_NODE_NAME", "ZENTF_NAMESPACE", "ZENTF_PARAMS", "ZENTF_PARAMS_FILE", "ZENTF_REMAP",
            "ZENTF_ZENOH_CONFIG", "ZENTF_CONNECT", "ZENTF_LISTEN", "ZENTF_MODE", "ZENTF_NO_MULTICAST",
            "ZENTF_LAN", "ZENTF_LOCAL_PORT", "ZENTF_WIRE", "ROS_DOMAIN_ID")
_ENDPOINT = re.compile(r"[a-z0-9]+/\S+\Z")
#: Loopback port of the local profile's rendezvous: the first zentf process of this machine listens
#: there, every later one connects to it and gossip links them all (zentf's rmw_zenohd, in-process).
LOCAL_PORT = 7448
#: How sessions retry their connect endpoints (a restarted router, the local rendezvous taken over by
#: a later process): every 0.25 s growing to 1 s, as configs/zenoh/client.json5 does.
_RETRY = "{period_init_ms: 250, period_max_ms: 1000, period_increase_factor: 2}"
# Zenoh reads each link into a pool of rx_buffer_size / batch size buffers, one by default; a buffer
# comes back to the pool only once every sample cut from it is dropped, so while a subscriber's
# RingChannel still holds the previous batch's samples, every read callocs a fresh 64 kB buffer and
# zeroes it, which under a flood of small messages is most of the receiving thread's work. Four
# batches (at most 256 kB a link) let the reads recycle (docs/protocol.md, "Sessions").
_RX_BUFFER = 4 * 65535
log = logging.getLogger("zentf.network")
_warned_exposed = False


class OptionsError(ValueError):
    """A bad flag, env var or file; the message is one line naming the culprit."""


def _split_list(value: str | None) -> list[str]:
    return [v.strip() for v in (value or "").split(",") if v.strip()]


_PORT = re.compile(r"(?:tcp|udp|tls|quic|ws)/.*:(\d+)(?:[?#].*)?\Z")


def _check_endpoints(eps: Sequence[str], what: str) -> list[str]:
    out = []
    for ep in eps:
        if not isinstance(ep, str) or not _ENDPOINT.match(ep.strip()):
            raise OptionsError(f"{what}: bad endpoint {ep!r} (expected like tcp/127.0.0.1:7447)")
        m = _PORT.match(ep.strip())
        if m and int(m.group(1)) > 65535:  # zenoh would accept it and retry forever
            raise OptionsError(f"{what}: bad endpoint {ep!r} (port {m.group(1)} is not in 0-65535)")
        out.append(ep.strip())
    return out


def env_flag(env: Mapping[str, str], var: str) -> bool:
    """A yes/no environment variable (unset or empty: no); a word parse_bool does not know is an error."""
    try:
        return parse_bool(env.get(var, ""), var)
    except ValueError as e:
        raise OptionsError(str(e)) from None


def _port(value: str | None, what: str) -> int:
    if not value or not value.strip():
        return LOCAL_PORT
    try:
        port = int(value.strip())
    except ValueError:
        port = -1
    if not 1 <= port <= 65535:
        raise OptionsError(f"{what}: bad port {value!r} (expected 1-65535)")
    return port


@dataclass
class ZenohOptions:
    """How to reach the Zenoh network (config file + endpoint/mode overrides).

    Three profiles (docs/networking.md, Security): *local* (the default: loopback only, no multicast,
    processes of this machine meet at ``tcp/127.0.0.1:LOCAL_PORT``), *lan* (``--lan`` /
    ``ZENTF_LAN=1``: Zenoh's own defaults, i.e. every interface and multicast scouting) and *file*
    (``--zenoh-config``: the file decides). Flags override each profile. Zenoh's shared-memory
    transport is off in *local* and *lan* (as in rmw_zenoh); a file decides for itself.
    """

    config_file: str | None = None
    connect: list[str] = field(default_factory=list)
    listen: list[str] = field(default_factory=list)
    mode: str | None = None
    no_multicast: bool = False
    timestamping: bool = True
    lan: bool = False
    local_port: int = LOCAL_PORT

    @property
    def profile(self) -> str:
        """'file', 'lan' or 'local' (the safe default)."""
        return "file" if self.config_file else ("lan" if self.lan else "local")

    @property
    def local_endpoint(self) -> str:
        return f"tcp/127.0.0.1:{self.local_port}"

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> "ZenohOptions":
        env = os.environ if env is None else env
        opts = cls(config_file=env.get("ZENTF_ZENOH_CONFIG") or None,
                   connect=_check_endpoints(_split_list(env.get("ZENTF_CONNECT")), "ZENTF_CONNECT"),
                   listen=_check_endpoints(_split_list(env.get("ZENTF_LISTEN")), "ZENTF_LISTEN"),
                   mode=(env.get("ZENTF_MODE") or None),
                   no_multicast=env_flag(env, "ZENTF_NO_MULTICAST"),
                   lan=env_flag(env, "ZENTF_LAN"),
                   local_port=_port(env.get("ZENTF_LOCAL_PORT"), "ZENTF_LOCAL_PORT"))
        opts._check()
        return opts

    @classmethod
    def from_values(cls, zenoh_config: str | None = None, connect: Sequence[str] | None = None,
                    listen: Sequence[str] | None = None, mode: str | None = None,
                    no_multicast: bool | None = None, env: Mapping[str, str] | None = None,
                    lan: bool | None = None) -> "ZenohOptions":
        """Explicit values (e.g. typer options) over env vars; None/empty means 'not given'."""
        base = cls.from_env(env)
        if lan:
            base.lan = True
        if zenoh_config:
            base.config_file = zenoh_config
        if connect:
            base.connect = _check_endpoints(list(connect), "--connect")
        if listen:
            base.listen = _check_endpoints(list(listen), "--listen")
        if mode:
            base.mode = mode
        if no_multicast:
            base.no_multicast = True
        base._check()
        return base

    def _check(self) -> None:
        if self.mode is not None and self.mode not in MODES:
            raise OptionsError(f"bad Zenoh mode {self.mode!r} (choose peer, client or router)")
        if self.config_file is not None and os.path.isdir(self.config_file):
            raise OptionsError(f"Zenoh config file is a directory: {self.config_file}")
        if self.config_file is not None and not os.path.isfile(self.config_file):
            raise OptionsError(f"Zenoh config file not found: {self.config_file}")

    def _holds_rendezvous(self) -> bool:
        """Local profile, peer, no endpoint given: try to be this machine's rendezvous first."""
        return self.profile == "local" and (self.mode or "peer") == "peer" and not self.listen and not self.connect

    def config(self, *, hold: bool | None = None) -> Any:
        """A zenoh.Config: profile, then file (if any), then overrides; timestamping on (latched topics).

        ``hold`` (local profile): listen on the rendezvous port (True) or connect to it (False);
        default: hold when this session may (see ``open_session``, which falls back to joining).
        """
        import zenoh

        self._check()
        try:
            cfg = zenoh.Config.from_file(self.config_file) if self.config_file else zenoh.Config()
        except Exception as e:  # zenoh raises ZError with a multi-line text
            raise OptionsError(f"bad Zenoh config file {self.config_file}: {_config_error(str(e))}") from None
        if hold is None:
            hold = self._holds_rendezvous()
        try:
            if self.profile == "local":
                self._local_defaults(cfg, hold)
            if self.profile != "file":
                # Zenoh's default puts every message of 3 kB or more into a 16 MiB shared-memory pool and
                # has each receiver on the machine map the sender's pool: a listener flooded with big
                # messages keeps those mappings in its RSS after the flood. Off, as in rmw_zenoh's
                # default session; a config file may turn it back on.
                cfg.insert_json5("transport/shared_memory/enabled", "false")
                cfg.insert_json5("transport/link/rx/buffer_size", str(_RX_BUFFER))
            if self.mode:
                cfg.insert_json5("mode", json.dumps(self.mode))
            if self.connect:
                cfg.insert_json5("connect/endpoints", json.dumps(self.connect))
                if self.profile != "file":  # Zenoh's default backs off to 4 s; docs promise data within 3 s
                    cfg.insert_json5("connect/retry", _RETRY)
            if self.listen:
                cfg.insert_json5("listen/endpoints", json.dumps(self.listen))
            if self.no_multicast:
                cfg.insert_json5("scouting/multicast/enabled", "false")
            if self.timestamping:
                cfg.insert_json5("timestamping/enabled", "true")
        except Exception as e:
            raise OptionsError(f"bad Zenoh option: {str(e).strip().splitlines()[0]}") from None
        _check_tls_files(cfg, self.config_file)
        return cfg

    def _local_defaults(self, cfg: Any, hold: bool) -> None:
        """The local profile (as rmw_zenoh's default session): loopback only, no multicast, gossip on."""
        mode = self.mode or "peer"
        cfg.insert_json5("scouting/multicast/enabled", "false")
        cfg.insert_json5("scouting/gossip/enabled", "true")
        if mode != "client":
            here = self.local_endpoint if hold else "tcp/127.0.0.1:0"
            cfg.insert_json5("listen/endpoints", json.dumps([here]))
        if not hold and mode != "router" and not self.listen:  # given endpoints: the user draws the map
            cfg.insert_json5("connect/endpoints", json.dumps([self.local_endpoint]))
            cfg.insert_json5("connect/retry", _RETRY)

    def open_session(self) -> Any:
        """zenoh.open(self.config()) with a one-line error on failure (e.g. port already in use).

        Local profile: the first process of the machine listens on the rendezvous port; when it is
        taken (the usual case), the session listens on a free loopback port and connects to it.
        """
        if self._holds_rendezvous():
            try:
                return self._open(self.config(hold=True))
            except OptionsError as e:
                if "in use" not in str(e) and "TCP listener" not in str(e):
                    raise
        return self._open(self.config(hold=False))

    def open_query_session(self) -> tuple[Any, str]:
        """(session, mode) for a one-shot query of the whole local graph (node list, topic list...).

        Local profile: a *client* of the rendezvous. Every local peer links to the rendezvous holder,
        which answers a client's liveliness query from all their tokens at once (Zenoh's peer-to-peer
        routing forwards other peers' declarations to clients, never to peers), so the answer does
        not depend on gossip having linked this short-lived session to each peer. With nobody holding
        the rendezvous nothing of this machine runs: the usual peer session (which then holds it).
        Other profiles, or given mode/endpoints: ``open_session()`` as is.
        """
        if self._holds_rendezvous():
            try:
                return self._open(replace(self, mode="client").config(hold=False)), "client"
            except OptionsError as e:
                if "nable to connect" not in str(e):
                    raise
        return self.open_session(), self.mode or "peer"

    def _open(self, cfg: Any) -> Any:
        import zenoh

        # zenoh.open blocks in Rust (a client config may wait for its router forever) where Python
        # cannot run signal handlers: open on a helper thread so Ctrl-C/SIGTERM still stop start-up.
        result: dict[str, Any] = {}

        def _open() -> None:
            try:
                result["session"] = zenoh.open(cfg)
            except Exception as e:  # noqa: BLE001 - reported below
                result["error"] = e

        opener = threading.Thread(target=_open, name="zenoh-open", daemon=True)
        opener.start()
        while opener.is_alive():
            opener.join(0.05)
        if "error" in result:
            e = result["error"]
            text = re.sub(r"\s+at \S+\.rs:\d+\.?", "", str(e)).strip()
            text = text.splitlines()[0] if text else type(e).__name__
            raise OptionsError(f"cannot open Zenoh session: {text}") from None
        _warn_if_exposed(cfg)
        return result["session"]

    def to_env(self) -> dict[str, str]:
        env: dict[str, str] = {}
        if self.config_file:
            env["ZENTF_ZENOH_CONFIG"] = self.config_file
        if self.connect:
            env["ZENTF_CONNECT"] = ",".join(self.connect)
        if self.listen:
            env["ZENTF_LISTEN"] = ",".join(self.listen)
        if self.mode:
            env["ZENTF_MODE"] = self.mode
        if self.no_multicast:
            env["ZENTF_NO_MULTICAST"] = "1"
        if self.lan:
            env["ZENTF_LAN"] = "1"
        if self.local_port != LOCAL_PORT:
            env["ZENTF_LOCAL_PORT"] = str(self.local_port)
        return env

    def to_args(self) -> list[str]:
        args: list[str] = []
        if self.config_file:
            args += ["--zenoh-config", self.config_file]
        for ep in self.connect:
            args += ["--connect", ep]
        for ep in self.listen:
            args += ["--listen", ep]
        if self.mode:
            args += ["--mode", self.mode]
        if self.no_multicast:
            args.append("--no-multicast")
        if self.lan:
            args.append("--lan")
        return args


def _json_at(cfg: Any, key: str) -> Any:
    try:
        return json.loads(cfg.get_json(key))
    except Exception:
        return None


def _is_loopback(endpoint: str) -> bool:
    """tcp/127.0.0.1:7447, tcp/[::1]:0, tcp/localhost:7447 (+ #/? suffixes) -> True; unix sockets too."""
    proto, _, rest = endpoint.partition("/")
    if proto in ("unixsock-stream", "unixpipe", "vsock"):
        return proto != "vsock"
    host = re.split(r"[?#]", rest, maxsplit=1)[0].rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def exposure(cfg: Any) -> list[str]:
    """What makes a session reachable from other machines without authentication ([] = loopback/secured)."""
    mode = _json_at(cfg, "mode") or "peer"
    listen = _json_at(cfg, "listen/endpoints")
    if isinstance(listen, dict):
        listen = listen.get(mode, [])
    connect = _json_at(cfg, "connect/endpoints")
    if isinstance(connect, dict):
        connect = connect.get(mode, [])
    tls = _json_at(cfg, "transport/link/tls") or {}
    auth = _json_at(cfg, "transport/auth") or {}
    secured = bool(tls.get("enable_mtls")) or any(
        any(v for v in (auth.get(kind) or {}).values()) for kind in ("usrpwd", "pubkey"))
    out = []
    wide = [ep for ep in (listen or []) + (connect or []) if isinstance(ep, str) and not _is_loopback(ep)]
    if wide and not (secured and all(ep.split("/", 1)[0] in ("tls", "quic") for ep in wide)):
        out.append(", ".join(wide))
    multicast = _json_at(cfg, "scouting/multicast/enabled")
    if multicast is None or multicast is True:
        out.append("multicast scouting on")
    return out


def _warn_if_exposed(cfg: Any) -> None:
    """One line per process when a session reaches beyond loopback unauthenticated: an exposure nobody
    asked for must not be silent."""
    global _warned_exposed
    if _warned_exposed:
        return
    what = exposure(cfg)
    if what:
        _warned_exposed = True
        log.warning("Zenoh reachable beyond this machine without authentication (%s): anyone on the network can "
                    "read every topic, publish transforms and /clock, call services, set parameters and take "
                    "node names; see docs/networking.md#what-the-lan-profile-exposes", "; ".join(what))


def _check_tls_files(cfg: Any, source: str | None) -> None:
    """A TLS certificate/key path that does not exist is named now (zenoh would retry silently)."""
    try:
        tls = json.loads(cfg.get_json("transport/link/tls")) or {}
    except Exception:
        return
    for key, value in tls.items():
        if (key.endswith("_certificate") or key.endswith("_private_key")) and isinstance(value, str) and value:
            if not os.path.isfile(value):
                where = f" (relative to {os.getcwd()})" if not os.path.isabs(value) else ""
                raise OptionsError(f"{source or 'Zenoh config'}: transport/link/tls/{key}: "
                                   f"file not found: {value}{where}")


def _config_error(text: str) -> str:
    """Zenoh's multi-line config error as 'line L, column C: what' (json5 syntax or unknown field)."""
    text = re.sub(r"\s+at \S+\.rs:\d+\.?\s*$", "", text.strip())
    m = re.search(r"-->\s*(\d+):(\d+).*?=\s*(.+)$", text, re.S)
    if m:
        return f"line {m.group(1)}, column {m.group(2)}: {m.group(3).strip()}"
    m = re.search(r'msg: "(.*?)", location: Some\(Location \{ line: (\d+), column: (\d+)', text, re.S)
    if m:
        return f"line {m.group(2)}, column {m.group(3)}: {m.group(1)}"
    return text.splitlines()[0] if text else "unreadable"


#: Longest parameter value read from a command line (characters).
MAX_VALUE_CHARS = 1024 * 1024


def parse_scalar(text: str, what: str = "parameter value") -> Any:
    """A parameter value as a YAML scalar ('1' -> 1, 'true' -> True, '[1, 2]' -> list); text that is not
    YAML stays text. OptionsError naming ``what`` for YAML zentf refuses (aliases, anchors, tags, size)."""
    import yaml

    from ..core.safe_yaml import YamlRefused, load

    try:
        return load(text, limit=MAX_VALUE_CHARS) if text.strip() else ""
    except YamlRefused as e:
        raise OptionsError(f"{what}: {e}") from None
    except yaml.YAMLError:
        return text


def parse_param_assignment(text: str) -> tuple[str, Any]:
    """'name:=value' -> (name, parsed value)."""
    name, sep, value = text.partition(":=")
    if not sep or not name.strip():
        raise OptionsError(f"bad parameter {text!r}: expected name:=value")
    return name.strip(), parse_scalar(value, f"parameter {name.strip()}")


def parse_remap(text: str) -> tuple[str, str]:
    src, sep, dst = text.partition(":=")
    if not sep or not src.strip() or not dst.strip():
        raise OptionsError(f"bad remapping {text!r}: expected from:=to")
    return src.strip(), dst.strip()


class ParamsFileError(OptionsError):
    """A params file zentf cannot use: one line naming the file, the line when known, and what is wrong."""

    def __init__(self, file: str, what: str, line: int | None = None) -> None:
        self.file, self.what, self.line = file, what, line
        super().__init__(f"params file {file}{f':{line}' if line else ''}: {what}")


#: The key that opens a node's parameters in a ROS 2 params file.
ROS_PARAMETERS = "ros__parameters"
_NODE_KEY_PART = re.compile(r"\*\*?\Z|[A-Za-z_][A-Za-z0-9_]*\Z")


def load_params_file(path: str, node_fqn: str) -> dict[str, Any]:
    """The parameters a params file gives the node ``node_fqn`` ('/ns/name'), read as ROS 2 reads it.

    A file whose sections hold ``ros__parameters`` is a ROS 2 file: each section's key (nested keys
    joined with '/') names nodes, a key without a leading '/' gets one (``talker`` is the root namespace's
    talker only), ``*`` stands for one name and ``**`` for any number of them (``/**`` is every node,
    ``/**/talker`` every talker), and every section whose key matches the whole ``node_fqn`` applies, in
    file order (a later one wins), as rclcpp's parameter_map_from does. Any other mapping is a flat
    ``{name: value}`` file for every node. A nested mapping of values is a parameter namespace
    (``gains: {p: 1}`` is ``gains.p``, as in ROS 2). YAML aliases, anchors and tags are refused (aliases
expand without bound), as a file over 16 MiB (``zentf.core.safe_yaml``).
    """
    import yaml

    from ..core.safe_yaml import YamlRefused, load_file

    try:
        data = load_file(path)
    except FileNotFoundError:
        raise ParamsFileError(path, "not found") from None
    except OSError as e:
        raise ParamsFileError(path, f"cannot read: {e.strerror}") from None
    except UnicodeDecodeError:
        raise ParamsFileError(path, "not UTF-8 text") from None
    except YamlRefused as e:
        raise ParamsFileError(path, e.problem, e.line) from None
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        what = " ".join(p for p in (e.context, e.problem) if p) or "invalid YAML"
        raise ParamsFileError(path, f"bad YAML: {what}", mark.line + 1 if mark else None) from None
    except yaml.YAMLError as e:
        raise ParamsFileError(path, f"bad YAML: {str(e).strip().splitlines()[0]}") from None
    return params_for_node(data, node_fqn, path)


def params_for_node(data: Any, node_fqn: str, path: str = "params file") -> dict[str, Any]:
    """``load_params_file``'s rules applied to a parsed params file (``data``); ``path`` names it in errors."""
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ParamsFileError(path, "expected a mapping at top level")
    if not _holds_ros_parameters(data):
        return _flatten(data, "", path)
    out: dict[str, Any] = {}
    for key, params in _sections(data, "", path):
        if _node_key_pattern(key, path).fullmatch(node_fqn):
            out.update(params)
    return out


def _holds_ros_parameters(data: dict) -> bool:
    return any(k == ROS_PARAMETERS or (isinstance(v, dict) and _holds_ros_parameters(v)) for k, v in data.items())


def _sections(data: dict, prefix: str, path: str) -> list[tuple[str, dict[str, Any]]]:
    """(node key, its flattened parameters) of each ``ros__parameters`` section, in file order."""
    out: list[tuple[str, dict[str, Any]]] = []
    for key, value in data.items():
        if key == ROS_PARAMETERS:
            if not prefix:
                raise ParamsFileError(path, f"{ROS_PARAMETERS} must be under a node name")
            if value is not None and not isinstance(value, dict):
                raise ParamsFileError(path, f"{ROS_PARAMETERS} of '{prefix}' must be a mapping")
            out.append((prefix, _flatten(value or {}, "", path)))
        elif isinstance(value, dict):
            out.extend(_sections(value, f"{prefix}/{key}" if prefix else str(key), path))
        else:
            where = f"{prefix}/{key}" if prefix else str(key)
            raise ParamsFileError(path, f"'{where}' is outside any {ROS_PARAMETERS} section")
    return out


def _flatten(params: dict, prefix: str, path: str) -> dict[str, Any]:
    """A nested mapping of parameters as ROS 2 names them: ``{gains: {p: 1}}`` -> ``{"gains.p": 1}``."""
    out: dict[str, Any] = {}
    for key, value in params.items():
        name = f"{prefix}.{key}" if prefix else str(key)
        if isinstance(value, dict):
            out.update(_flatten(value, name, path))
        else:
            out[name] = value
    return out


def _node_key_pattern(key: str, path: str) -> re.Pattern[str]:
    """A params file's node key as a pattern over fully qualified node names (rclcpp's reading)."""
    parts = key.strip().strip("/").split("/")
    if not all(_NODE_KEY_PART.match(p) for p in parts):
        raise ParamsFileError(path, f"bad node name '{key}' (names, * and ** between slashes)")
    rx = "".join("(?:/[A-Za-z0-9_]+)*" if p == "**" else "/[A-Za-z0-9_]+" if p == "*" else "/" + p for p in parts)
    return re.compile(rx)


def _json_object(env: Mapping[str, str], var: str) -> dict[str, Any]:
    text = env.get(var)
    if not text:
        return {}
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise OptionsError(f"{var} is not valid JSON: {e.msg} at char {e.pos}") from None
    if not isinstance(value, dict):
        raise OptionsError(f"{var} must be a JSON object")
    return value


@dataclass
class NodeOptions:
    """Who a node is (name, namespace, params, remappings) and how it reaches Zenoh."""

    name: str | None = None
    namespace: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    params_file: str | None = None
    remappings: dict[str, str] = field(default_factory=dict)
    zenoh: ZenohOptions = field(default_factory=ZenohOptions)
    wire: str = "zentf"
    domain_id: int = 0

    @classmethod
    def from_env(cls, env: Mapping[str, str] | None = None) -> "NodeOptions":
        env = os.environ if env is None else env
        opts = cls(name=env.get("ZENTF_NODE_NAME") or None,
                   namespace=env.get("ZENTF_NAMESPACE") or None,
                   params=_json_object(env, "ZENTF_PARAMS"),
                   params_file=env.get("ZENTF_PARAMS_FILE") or None,
                   remappings={str(k): str(v) for k, v in _json_object(env, "ZENTF_REMAP").items()},
                   zenoh=ZenohOptions.from_env(env),
                   wire=(env.get("ZENTF_WIRE") or "zentf").strip().lower(),
                   domain_id=_domain_id(env.get("ROS_DOMAIN_ID")))
        opts._check()
        return opts

    @classmethod
    def from_args(cls, args: argparse.Namespace | Sequence[str] | None = None,
                  env: Mapping[str, str] | None = None,
                  parser: argparse.ArgumentParser | None = None) -> "NodeOptions":
        """From parsed args (a parser given ``add_node_arguments``) or an argv list, over env vars.

        With ``parser``, a bad value becomes ``parser.error(...)`` (usage line, exit code 2).
        """
        if parser is not None:
            try:
                return cls.from_args(args, env)
            except OptionsError as e:
                parser.error(str(e))
        if args is None or not isinstance(args, argparse.Namespace):
            parser = argparse.ArgumentParser(add_help=False)
            add_node_arguments(parser)
            args = parser.parse_args(list(args) if args is not None else None)
        opts = cls.from_env(env)
        g = lambda n: getattr(args, n, None)  # noqa: E731
        if g("node_name"):
            opts.name = g("node_name")
        if g("namespace") is not None:
            opts.namespace = g("namespace")
        if g("params_file"):
            opts.params_file = g("params_file")
        for p in g("params") or []:
            k, v = parse_param_assignment(p)
            opts.params[k] = v
        for r in g("remap") or []:
            src, dst = parse_remap(r)
            opts.remappings[src] = dst
        if g("wire"):
            opts.wire = g("wire")
        opts.zenoh = ZenohOptions.from_values(g("zenoh_config"), g("connect"), g("listen"), g("mode"),
                                              g("no_multicast"), env, lan=g("lan"))
        opts._check()
        return opts

    def _check(self) -> None:
        try:
            if self.name is not None:
                validate_node_name(self.name)
            normalize_namespace(self.namespace)
        except ValueError as e:
            raise OptionsError(str(e)) from None
        if self.params_file is not None and not os.path.isfile(self.params_file):
            raise OptionsError(f"params file not found: {self.params_file}")
        if self.wire not in WIRES:
            raise OptionsError(f"bad wire profile {self.wire!r} (choose zentf or ros2) [ZENTF_WIRE]")

    def resolved_params(self, node_name: str | None = None, namespace: str | None = None) -> dict[str, Any]:
        """Params file values (the sections that match this node: ``load_params_file``) overridden by
        explicit params; the node is ``node_name``/``namespace``, by default the options' own."""
        out: dict[str, Any] = {}
        if self.params_file:
            ns = normalize_namespace(namespace if namespace is not None else self.namespace)
            out.update(load_params_file(self.params_file, fully_qualified_node_name(ns, node_name or self.name or "")))
        out.update(self.params)
        return out

    def with_(self, **changes: Any) -> "NodeOptions":
        return replace(self, **changes)

    def to_env(self) -> dict[str, str]:
        """Env vars that give a child process this identity (the launcher -> node contract)."""
        env = self.zenoh.to_env()
        if self.name:
            env["ZENTF_NODE_NAME"] = self.name
        if self.namespace:
            env["ZENTF_NAMESPACE"] = normalize_namespace(self.namespace)
        if self.params:
            env["ZENTF_PARAMS"] = json.dumps(self.params)
        if self.params_file:
            env["ZENTF_PARAMS_FILE"] = self.params_file
        if self.remappings:
            env["ZENTF_REMAP"] = json.dumps(self.remappings)
        if self.wire != "zentf":
            env["ZENTF_WIRE"] = self.wire
            env["ROS_DOMAIN_ID"] = str(self.domain_id)
        return env


def _domain_id(text: str | None) -> int:
    """ROS_DOMAIN_ID as ROS 2 reads it: empty means 0; otherwise an integer 0-232."""
    if text is None or not text.strip():
        return 0
    try:
        value = int(text.strip())
    except ValueError:
        raise OptionsError(f"ROS_DOMAIN_ID must be an integer 0-232, got {text!r}") from None
    if not 0 <= value <= 232:
        raise OptionsError(f"ROS_DOMAIN_ID must be an integer 0-232, got {value}")
    return value


_GROUP_TITLES = {"node": "node options", "zenoh": "Zenoh options"}


def _add_arguments(parser: argparse.ArgumentParser, groups: Sequence[str]) -> argparse.ArgumentParser:
    have = {o for a in parser._actions for o in a.option_strings}  # e.g. a program's own --debug
    for group in groups:
        g = parser.add_argument_group(_GROUP_TITLES[group])
        for opt in SHARED_OPTIONS:
            if opt.group != group or have.intersection(opt.flags):
                continue
            kw: dict[str, Any] = {"dest": opt.dest, "help": opt.help_text, "default": None}
            if opt.kind == "flag":
                kw["action"] = "store_true"
            else:
                kw["metavar"] = opt.metavar
                if opt.kind == "repeat":
                    kw["action"] = "append"
                if opt.choices:
                    kw["choices"] = opt.choices
            g.add_argument(*opt.flags, **kw)
    return parser


def add_zenoh_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The Zenoh options of SHARED_OPTIONS (--zenoh-config, --connect, --listen, --mode, ...) on ``parser``."""
    return _add_arguments(parser, ("zenoh",))


def node_options_help() -> str:
    """The shared options' sections of a program's --help, for programs that print a usage text of their
    own (static_transform_publisher's is tf2_ros's) or parse them apart (robot_state_publisher)."""
    parser = argparse.ArgumentParser(add_help=False, usage=argparse.SUPPRESS)
    return add_node_arguments(parser).format_help().strip()


def add_node_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Every option of SHARED_OPTIONS (identity, parameters, remappings, wire, --debug, Zenoh) on a node
    program's parser."""
    return _add_arguments(parser, ("node", "zenoh"))
