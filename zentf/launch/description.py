"""Launch files: read, check and resolve into a flat list of nodes (plus the sim clock)."""
from __future__ import annotations

import importlib.util
import json
import math
import os
import re
import shlex
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import yaml

from ..core import safe_yaml
from ..core.text import parse_bool
from ..transport.clock import MAX_RATE, MIN_RATE
from ..transport.names import fully_qualified_node_name
from ..transport.options import ParamsFileError, load_params_file
from ..tools.programs import PROGRAMS, module_of
from .errors import LaunchError
from .substitution import SubstitutionContext, SubstitutionError, has_substitution, substitute
from .yaml_tree import Y, load_yaml_file

__all__ = ["NodeSpec", "ClockSpec", "ArgSpec", "LaunchDescription", "load_launch", "resolve_launch_file",
           "parse_cli_args", "join_namespace", "TOP_KEYS", "NODE_KEYS", "GROUP_KEYS", "INCLUDE_KEYS",
           "CLOCK_KEYS"]

TOP_KEYS = ("description", "args", "env", "clock", "nodes", "groups", "include")
NODE_KEYS = ("name", "run", "module", "cmd", "arguments", "namespace", "parameters", "params_file", "remappings",
             "env", "respawn", "respawn_delay", "respawn_max", "required", "output", "if", "unless")
GROUP_KEYS = ("namespace", "env", "nodes", "groups", "include", "if", "unless")
INCLUDE_KEYS = ("file", "args", "namespace", "if", "unless")
CLOCK_KEYS = ("start", "rate", "frequency", "paused")
ARG_KEYS = ("default", "description")

_SEGMENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_MODULE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*\Z")
_ENV_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


@dataclass
class ArgSpec:
    name: str
    default: str | None
    description: str
    line: int


@dataclass
class ClockSpec:
    """The launcher's sim clock: start time (None = wall time now), rate factor, publish Hz, paused."""

    start: float | None = None
    rate: float = 1.0
    frequency: float = 100.0
    paused: bool = False
    source: str = ""


@dataclass
class NodeSpec:
    """One process to run, fully resolved."""

    name: str
    namespace: str
    cmd: list[str]
    module: str | None = None
    parameters: dict[str, Any] = field(default_factory=dict)
    params_file: str | None = None
    remappings: dict[str, str] = field(default_factory=dict)
    env: dict[str, str] = field(default_factory=dict)
    respawn: bool = False
    respawn_delay: float = 1.0
    respawn_max: int | None = None
    required: bool = False
    output: str = "screen"
    source: str = ""
    python_path: str | None = None  # where `module` was found, so the child imports the same one

    @property
    def full_name(self) -> str:
        return f"{self.namespace}/{self.name}" if self.namespace else self.name

    def child_env(self) -> dict[str, str]:
        """The identity env vars of the launcher -> node contract (docs/architecture.md)."""
        env = dict(self.env)
        env["ZENTF_NODE_NAME"] = self.name
        env["ZENTF_NAMESPACE"] = self.namespace
        env["ZENTF_PARAMS"] = json.dumps(self.parameters, separators=(",", ":"))
        env["ZENTF_REMAP"] = json.dumps(self.remappings, separators=(",", ":"))
        env["PYTHONUNBUFFERED"] = "1"
        return env


@dataclass
class LaunchDescription:
    file: str
    args: dict[str, str]
    arg_specs: list[ArgSpec]
    nodes: list[NodeSpec]
    clock: ClockSpec | None
    description: str = ""


# ---------------------------------------------------------------- finding files and args

def package_configs_dir() -> Path:
    """The shipped launch files and Zenoh configs: ``zentf/configs`` in a wheel, ``configs/`` in a checkout."""
    package = Path(__file__).resolve().parent.parent
    installed = package / "configs"
    return installed if installed.is_dir() else package.parent / "configs"


def resolve_launch_file(name: str, cwd: str | None = None) -> str:
    """A path as given, or a bare name like `drones` looked up in ./configs and the package's configs."""
    base = Path(cwd or os.getcwd())
    given = Path(name)
    if (base / given).is_file():
        return str(base / given) if not given.is_absolute() else str(given)
    if given.is_absolute():
        raise LaunchError("launch file not found", name)
    if "/" in name:  # `configs/drones.yaml` typed outside the checkout: the package's own copy
        own = package_configs_dir().parent / given
        if own.is_file():
            return str(own)
        raise LaunchError("launch file not found", name)
    candidates: list[Path] = []
    for d in (base / "configs", package_configs_dir(), base):
        for fname in (name, name + ".yaml", name + ".yml"):
            candidates.append(d / fname)
    for c in candidates:
        if c.is_file():
            return str(c)
    dirs = ", ".join(dict.fromkeys(str(c.parent) for c in candidates))
    raise LaunchError(f"no launch file named {name!r} (looked in {dirs})")


def parse_cli_args(items: Sequence[str]) -> dict[str, str]:
    """`name:=value` words from the command line; anything else is refused by name."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name:
            raise LaunchError(f"bad launch argument {item!r}: expected name:=value")
        out[name] = value
    return out


def join_namespace(parent: str, child: str) -> str:
    """Group/include namespaces nest; a leading '/' makes a namespace absolute."""
    if child.startswith("/"):
        return child.strip("/")
    child = child.strip("/")
    parent = parent.strip("/")
    if not child:
        return parent
    return f"{parent}/{child}" if parent else child


# ---------------------------------------------------------------- the loader

@dataclass
class _Scope:
    """What a file, group or include hands down to what is inside it."""

    file: str
    ctx: SubstitutionContext
    namespace: str = ""
    env: dict[str, str] = field(default_factory=dict)


class _Loader:
    def __init__(self, use_sim_time: bool | None = None) -> None:
        self.nodes: list[NodeSpec] = []
        self.names: dict[str, str] = {}
        self.stack: list[str] = []
        self.clock: ClockSpec | None = None

    # -- files
    def load_file(self, path: str, given: Mapping[str, str], given_where: tuple[str, int | None],
                  namespace: str, env: dict[str, str], top: bool) -> tuple[dict[str, str], list[ArgSpec], str]:
        real = os.path.realpath(path)
        if real in self.stack:
            chain = " -> ".join(os.path.basename(p) for p in [*self.stack, real])
            raise LaunchError(f"include cycle: {chain}", *given_where)
        root = load_yaml_file(path)
        if root is None:
            raise LaunchError("empty launch file", path, 1)
        if not root.is_map:
            raise root.error("a launch file must be a mapping with keys: " + ", ".join(TOP_KEYS))
        self._check_keys(root, TOP_KEYS, "launch file")
        self.stack.append(real)
        try:
            dirname = os.path.dirname(os.path.abspath(path))
            ctx = SubstitutionContext({}, dirname)
            args, specs = self._args(root, given, given_where, ctx)
            ctx.args = args
            scope = _Scope(path, ctx, namespace, dict(env))
            description = ""
            if "description" in root.value:
                description = str(self._scalar(root.value["description"], scope))
            if "clock" in root.value:
                if not top:
                    raise root.error("clock: is only allowed in the top-level launch file", "clock")
                self.clock = self._clock(root.value["clock"], scope)
            if "env" in root.value:
                scope.env.update(self._env(root.value["env"], scope))
            self._body(root, scope)
            return args, specs, description
        finally:
            self.stack.pop()

    def _args(self, root: Y, given: Mapping[str, str], given_where: tuple[str, int | None],
              ctx: SubstitutionContext) -> tuple[dict[str, str], list[ArgSpec]]:
        decl = root.value.get("args")
        specs: list[ArgSpec] = []
        default_nodes: dict[str, Y | None] = {}  # the YAML default of each arg (None: required)
        if decl is not None and decl.value is not None:
            if not decl.is_map:
                raise decl.error("args: must be a mapping of name -> {default, description} (or name -> default)")
            for name, y in decl.value.items():
                line = decl.key_lines[name]
                if not _SEGMENT.match(name):
                    raise LaunchError(f"bad argument name {name!r}", root.file, line)
                default: Any = None
                description = ""
                if y.is_map:
                    self._check_keys(y, ARG_KEYS, f"argument {name!r}")
                    if "default" in y.value:
                        default = y.value["default"]
                    if "description" in y.value:
                        description = str(y.value["description"].value or "")
                elif y.is_list:
                    raise y.error(f"argument {name!r}: expected a default value or {{default, description}}")
                else:
                    default = y
                specs.append(ArgSpec(name, None, description, line))
                default_nodes[name] = default
        declared = {s.name for s in specs}
        for name in given:
            if name not in declared:
                known = ", ".join(sorted(declared)) or "none"
                where = given_where if given_where[0] != root.file else (
                    root.file, root.key_lines.get("args", 1))
                raise LaunchError(f"unknown argument {name!r} for {os.path.basename(root.file)} "
                                  f"(declared: {known})", *where)
        values: dict[str, str] = {}
        for spec in specs:
            y = default_nodes[spec.name]
            if y is not None and not y.is_scalar:
                raise y.error(f"argument {spec.name!r}: default must be a single value")
            if spec.name in given:
                values[spec.name] = given[spec.name]
                if y is not None:  # shown by --show-args as written
                    spec.default = y.raw if y.raw is not None else _arg_text(y.value)
            elif y is None:
                raise LaunchError(f"argument {spec.name!r} is required (it has no default); "
                                  f"give it as {spec.name}:=VALUE", root.file, spec.line)
            else:
                ctx.args = values
                value = self._sub_text(y, ctx) if isinstance(y.value, str) else _arg_text(y.value)
                values[spec.name] = value
                spec.default = value
        return values, specs

    def _body(self, y: Y, scope: _Scope) -> None:
        for key in ("nodes", "groups", "include"):
            if key not in y.value or y.value[key].value is None:
                continue
            items = y.value[key]
            if not items.is_list:
                raise items.error(f"{key}: must be a list")
            for item in items.value:
                if not item.is_map:
                    raise item.error(f"each entry of {key}: must be a mapping")
                if key == "nodes":
                    self._node(item, scope)
                elif key == "groups":
                    self._group(item, scope)
                else:
                    self._include(item, scope)

    def _group(self, y: Y, scope: _Scope) -> None:
        self._check_keys(y, GROUP_KEYS, "group")
        if not self._condition(y, scope):
            return
        inner = _Scope(scope.file, scope.ctx, scope.namespace, dict(scope.env))
        if "namespace" in y.value:
            inner.namespace = self._namespace(y.value["namespace"], scope, scope.namespace)
        if "env" in y.value:
            inner.env.update(self._env(y.value["env"], scope))
        self._body(y, inner)

    def _include(self, y: Y, scope: _Scope) -> None:
        self._check_keys(y, INCLUDE_KEYS, "include")
        if "file" not in y.value:
            raise y.error("include needs file:")
        if not self._condition(y, scope):
            return
        fy = y.value["file"]
        fname = self._str(fy, scope, "file")
        path = fname if os.path.isabs(fname) else os.path.join(scope.ctx.dirname, fname)
        if not os.path.isfile(path):
            raise fy.error(f"included file not found: {fname}")
        given: dict[str, str] = {}
        if "args" in y.value and y.value["args"].value is not None:
            ay = y.value["args"]
            if not ay.is_map:
                raise ay.error("include args: must be a mapping of name -> value")
            for name, vy in ay.value.items():
                if not vy.is_scalar:
                    raise vy.error(f"include argument {name!r} must be a single value")
                given[name] = self._sub_text(vy, scope.ctx) if isinstance(vy.value, str) else _arg_text(vy.value)
        ns = scope.namespace
        if "namespace" in y.value:
            ns = self._namespace(y.value["namespace"], scope, scope.namespace)
        where = (scope.file, y.key_lines.get("args", y.line))
        self.load_file(display_path(path), given, where, ns, scope.env, top=False)

    def _node(self, y: Y, scope: _Scope) -> None:
        self._check_keys(y, NODE_KEYS, "node")
        v = y.value
        active = self._condition(y, scope)
        has_run, has_module, has_cmd = "run" in v, "module" in v, "cmd" in v
        if has_run + has_module + has_cmd != 1:
            raise y.error("a node needs exactly one program: run: NAME (zentf run --list), module: or cmd: [...]")
        module: str | None = None
        if has_run:
            program = self._str(v["run"], scope, "run")
            try:
                module = module_of(program)
            except KeyError as e:
                raise v["run"].error(str(e.args[0])) from None
            cmd = [sys.executable, "-m", module]
        elif has_module:
            module = self._str(v["module"], scope, "module")
            if not _MODULE.match(module):
                raise v["module"].error(f"bad module name {module!r}")
            cmd = [sys.executable, "-m", module]
        else:
            cy = v["cmd"]
            if cy.is_list:
                cmd = [self._word(c, scope, "cmd") for c in cy.value]
            elif isinstance(cy.value, str):
                try:
                    cmd = shlex.split(self._str(cy, scope, "cmd"))
                except ValueError as e:
                    raise cy.error(f"cmd: {e}") from None
            else:
                raise cy.error("cmd: must be a list of words or a command string")
            if not cmd:
                raise cy.error("cmd: is empty")
        if "arguments" in v:
            ay = v["arguments"]
            if not ay.is_list:
                raise ay.error("arguments: must be a list")
            cmd += [self._word(a, scope, "arguments") for a in ay.value]
        if "name" in v:
            name = self._str(v["name"], scope, "name")
            if not _SEGMENT.match(name):
                raise v["name"].error(f"bad node name {name!r} (letters, digits, _; no '/')")
        else:
            base = (program if has_run else module.rsplit(".", 1)[-1] if module else os.path.basename(cmd[0]))
            name = re.sub(r"\W", "_", base) or "node"
        namespace = scope.namespace
        if "namespace" in v:
            namespace = self._namespace(v["namespace"], scope, scope.namespace)
        node = NodeSpec(name=name, namespace=namespace, cmd=cmd, module=module,
                        source=f"{scope.file}:{y.line}")
        if "params_file" in v:
            py = v["params_file"]
            pf = self._str(py, scope, "params_file")
            path = pf if os.path.isabs(pf) else os.path.join(scope.ctx.dirname, pf)
            node.params_file = path
            node.parameters.update(_read_params_file(path, node, py))
        if "parameters" in v:
            py = v["parameters"]
            if py.value is not None:
                if not py.is_map:
                    raise py.error("parameters: must be a mapping of name -> value")
                for pname, pv in py.value.items():
                    node.parameters[pname] = self._value(pv, scope)
        if "remappings" in v:
            node.remappings = self._remappings(v["remappings"], scope)
        node.env = dict(scope.env)
        if "env" in v:
            node.env.update(self._env(v["env"], scope))
        if "respawn" in v:
            node.respawn = self._bool(v["respawn"], scope, "respawn")
        if "respawn_delay" in v:
            node.respawn_delay = self._number(v["respawn_delay"], scope, "respawn_delay", minimum=0.0)
        if "respawn_max" in v:
            ry = v["respawn_max"]
            val = self._scalar(ry, scope)
            if val is not None:
                if isinstance(val, bool) or not isinstance(val, int) or val < 0:
                    raise ry.error(f"respawn_max: expected a whole number >= 0 (or null for no cap), got {val!r}")
                node.respawn_max = val
        if "required" in v:
            node.required = self._bool(v["required"], scope, "required")
        if node.required and node.respawn:
            raise y.error("a node cannot be both required: and respawn:")
        if "output" in v:
            out = self._str(v["output"], scope, "output")
            if out not in ("screen", "log"):
                raise v["output"].error(f"output: must be screen or log, got {out!r}")
            node.output = out
        if not active:
            return
        self._check_program(node, v["run"] if has_run else v["module"] if has_module else v["cmd"])
        full = node.full_name
        if full in self.names:
            raise y.error(f"node name {full!r} is already used by the node at {self.names[full]}")
        self.names[full] = node.source
        self.nodes.append(node)

    def _check_program(self, node: NodeSpec, y: Y) -> None:
        if node.module is not None:
            module = node.module
            try:
                spec = importlib.util.find_spec(module)
            except (ImportError, ValueError):
                spec = None
            program = module.removeprefix("nodes.")
            if spec is None and program in PROGRAMS:  # `module: turtlesim` or `nodes.turtlesim` outside a checkout
                node.module = module = module_of(program)
                node.cmd[2] = module
                spec = importlib.util.find_spec(module)
            if spec is None:
                raise y.error(f"no module named {module!r}")
            node.python_path = _import_root(module)
            return
        prog = node.cmd[0]
        if "/" in prog:
            ok = os.path.isfile(prog) and os.access(prog, os.X_OK)
        else:
            ok = shutil.which(prog) is not None
        if not ok:
            raise y.error(f"program not found or not executable: {prog!r}")

    def _clock(self, y: Y, scope: _Scope) -> ClockSpec:
        spec = ClockSpec(source=f"{scope.file}:{y.line}")
        if y.value is None:
            return spec
        if not y.is_map:
            raise y.error("clock: must be a mapping with keys: " + ", ".join(CLOCK_KEYS))
        self._check_keys(y, CLOCK_KEYS, "clock")
        v = y.value
        if "start" in v:
            sv = self._scalar(v["start"], scope)
            if sv == "now" or sv is None:
                spec.start = None
            else:
                spec.start = self._number(v["start"], scope, "start", minimum=0.0)
        if "rate" in v:
            spec.rate = self._number(v["rate"], scope, "rate", minimum=0.0, strict=True)
            if not MIN_RATE <= spec.rate <= MAX_RATE:  # (a factor, kept in the range a timer's rate has)
                raise v["rate"].error(f"clock rate must be between {MIN_RATE:g} and {MAX_RATE:g}, got {spec.rate!r}")
        if "frequency" in v:
            spec.frequency = self._number(v["frequency"], scope, "frequency", minimum=0.0, strict=True)
            if spec.frequency > 10000:
                raise v["frequency"].error("clock frequency above 10000 Hz is not supported")
            if spec.frequency < MIN_RATE:
                raise v["frequency"].error(f"clock frequency below {MIN_RATE:g} Hz is not supported")
        if "paused" in v:
            spec.paused = self._bool(v["paused"], scope, "paused")
        return spec

    # -- typed values
    def _check_keys(self, y: Y, allowed: Sequence[str], what: str) -> None:
        for key in y.value:
            if key not in allowed:
                raise y.error(f"unknown key {key!r} in {what} (allowed: {', '.join(allowed)})", key)

    def _sub_text(self, y: Y, ctx: SubstitutionContext) -> str:
        try:
            return substitute(str(y.value), ctx)
        except SubstitutionError as e:
            raise y.error(str(e)) from None

    def _scalar(self, y: Y, scope: _Scope) -> Any:
        """A scalar with substitutions done; unquoted results are read again as YAML scalars."""
        if not y.is_scalar:
            raise y.error("expected a single value, not a list or mapping")
        if not isinstance(y.value, str) or not has_substitution(y.value):
            return y.value
        text = self._sub_text(y, scope.ctx)
        if y.plain:
            try:
                parsed = safe_yaml.load(text) if text.strip() else ""
            except (yaml.YAMLError, safe_yaml.YamlRefused):  # (refused: kept as the text it is)
                return text
            if isinstance(parsed, (bool, int, float, str)) or parsed is None:
                return parsed
        return text

    def _value(self, y: Y, scope: _Scope) -> Any:
        if y.is_map:
            return {k: self._value(v, scope) for k, v in y.value.items()}
        if y.is_list:
            return [self._value(v, scope) for v in y.value]
        val = self._scalar(y, scope)
        if isinstance(val, float) and not math.isfinite(val):
            raise y.error(f"parameter value must be finite, got {val!r}")
        return val

    def _str(self, y: Y, scope: _Scope, what: str) -> str:
        val = self._scalar(y, scope)
        if isinstance(val, bool) or val is None or not isinstance(val, (str, int, float)):
            raise y.error(f"{what}: expected text, got {val!r}")
        return str(val)

    def _word(self, y: Y, scope: _Scope, what: str) -> str:
        """A command-line word exactly as written (`0.40` stays `0.40`, `true` stays `true`)."""
        if not y.is_scalar or y.value is None:
            raise y.error(f"{what}: each word must be a single value")
        text = y.raw if y.raw is not None else str(y.value)
        try:
            return substitute(text, scope.ctx)
        except SubstitutionError as e:
            raise y.error(str(e)) from None

    def _bool(self, y: Y, scope: _Scope, what: str) -> bool:
        try:
            return parse_bool(self._scalar(y, scope), what)
        except ValueError as e:
            raise y.error(str(e)) from None

    def _number(self, y: Y, scope: _Scope, what: str, minimum: float, strict: bool = False) -> float:
        val = self._scalar(y, scope)
        if isinstance(val, str):
            try:
                val = float(val)
            except ValueError:
                pass
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
            raise y.error(f"{what}: expected a number, got {val!r}")
        if val < minimum or (strict and val == minimum):
            raise y.error(f"{what}: must be {'>' if strict else '>='} {minimum:g}, got {val!r}")
        return float(val)

    def _condition(self, y: Y, scope: _Scope) -> bool:
        ok = True
        if "if" in y.value:
            ok = ok and self._bool(y.value["if"], scope, "if")
        if "unless" in y.value:
            ok = ok and not self._bool(y.value["unless"], scope, "unless")
        return ok

    def _namespace(self, y: Y, scope: _Scope, parent: str) -> str:
        val = self._scalar(y, scope)
        if val is None:
            val = ""
        if not isinstance(val, str):
            raise y.error(f"namespace: expected text, got {val!r}")
        ns = join_namespace(parent, val)
        for seg in ns.split("/") if ns else ():
            if not _SEGMENT.match(seg):
                raise y.error(f"bad namespace {val!r} (segments are letters, digits, _)")
        return ns

    def _env(self, y: Y, scope: _Scope) -> dict[str, str]:
        if y.value is None:
            return {}
        if not y.is_map:
            raise y.error("env: must be a mapping of VARIABLE -> value")
        out: dict[str, str] = {}
        for name, vy in y.value.items():
            if not _ENV_NAME.match(name):
                raise y.error(f"bad environment variable name {name!r}", name)
            val = self._scalar(vy, scope)
            out[name] = _arg_text(val)
        return out

    def _remappings(self, y: Y, scope: _Scope) -> dict[str, str]:
        out: dict[str, str] = {}
        if y.value is None:
            return out
        if y.is_map:
            for src, vy in y.value.items():
                dst = self._str(vy, scope, "remapping")
                srcs = self._sub_text(Y(src, y.key_lines[src], y.file), scope.ctx)
                out[srcs] = dst
        elif y.is_list:
            for item in y.value:
                text = self._str(item, scope, "remapping")
                src, sep, dst = text.partition(":=")
                if not sep or not src or not dst:
                    raise item.error(f"bad remapping {text!r}: expected from:=to")
                out[src] = dst
        else:
            raise y.error("remappings: must be a mapping from -> to, or a list of 'from:=to'")
        for src, dst in out.items():
            if not src.strip("/") or not dst.strip("/"):
                raise y.error(f"bad remapping {src!r} -> {dst!r}: empty topic name")
        return out


def _import_root(module: str) -> str | None:
    """The sys.path entry that provides `module` (the directory holding its top-level package)."""
    try:
        top = importlib.util.find_spec(module.split(".")[0])
    except (ImportError, ValueError):
        return None
    if top is None:
        return None
    if top.submodule_search_locations:
        return os.path.dirname(os.path.abspath(list(top.submodule_search_locations)[0]))
    if top.origin and os.path.isfile(top.origin):
        return os.path.dirname(os.path.abspath(top.origin))
    return None


def _arg_text(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if v is None:
        return ""
    return str(v)


def _read_params_file(path: str, node: NodeSpec, where: Y) -> dict[str, Any]:
    """The parameters a params file gives this node (``zentf.transport.options.load_params_file``'s rules,
    ROS 2's); a problem inside the file is reported at its own line, a missing file at the node's key."""
    if not os.path.isfile(path):
        raise where.error(f"params file not found: {path}")
    try:
        return load_params_file(path, fully_qualified_node_name(node.namespace, node.name))
    except ParamsFileError as e:
        raise LaunchError(e.what, display_path(e.file), e.line) from None


def declared_args(file: str) -> tuple[str, list[ArgSpec]]:
    """The arguments a launch file declares, defaults as written (for --show-args; nothing resolved)."""
    path = display_path(resolve_launch_file(file))
    root = load_yaml_file(path)
    specs: list[ArgSpec] = []
    decl = root.value.get("args") if root is not None and root.is_map else None
    if decl is not None and decl.is_map:
        for name, y in decl.value.items():
            default, description = (y.value.get("default"), y.value.get("description")) if y.is_map else (y, None)
            text = None
            if isinstance(default, Y) and default.is_scalar:
                text = default.raw if default.raw is not None else _arg_text(default.value)
            desc = str(description.value or "") if isinstance(description, Y) else ""
            specs.append(ArgSpec(name, text, desc, decl.key_lines[name]))
    return path, specs


def display_path(path: str) -> str:
    """A path as short as it is unambiguous: relative when under the current directory."""
    absolute = os.path.abspath(path)
    rel = os.path.relpath(absolute)
    return absolute if rel.startswith("..") else rel


def load_launch(file: str, cli_args: Mapping[str, str] | Sequence[str] = (), *,
                namespace: str = "", resolve_name: bool = True) -> LaunchDescription:
    """Read and check a launch file and everything it includes; raise LaunchError on the first problem."""
    if not isinstance(cli_args, Mapping):
        cli_args = parse_cli_args(cli_args)
    path = resolve_launch_file(file) if resolve_name else file
    shown = display_path(path)
    if os.getcwd() not in sys.path and "" not in sys.path:  # `module:` may name one in the current dir,
        sys.path.append(os.getcwd())                         # as `python -m` in the child would find it
    loader = _Loader()
    root_ns = join_namespace("", namespace or "")
    for seg in root_ns.split("/") if root_ns else ():
        if not _SEGMENT.match(seg):
            raise LaunchError(f"bad namespace {namespace!r} (segments are letters, digits, _)")
    args, specs, description = loader.load_file(shown, cli_args, (shown, None), root_ns, {}, top=True)
    if loader.clock is not None:
        for node in loader.nodes:
            node.parameters.setdefault("use_sim_time", True)
    return LaunchDescription(file=shown, args=args, arg_specs=specs, nodes=loader.nodes,
                             clock=loader.clock, description=description)
