"""The architecture holds: zentf/core is self-contained and Zenoh-free, imports point downward, no cycles.

Layers, lowest first: 0 ``zentf/core/`` (tf2), 1 formats (``zentf/ros/``, ``zentf/urdf/``: pure, no
Zenoh), 2 transport (``zentf/*.py``), 3 ``zentf/tools/``, 4 ``zentf/launch/`` and ``zentf/cli/``.
Every import counts, lazy ones (inside functions) included.
"""
from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "zentf"
SUBPACKAGES = {"core": 0, "ros": 1, "urdf": 1, "tools": 3, "launch": 4, "cli": 4}
TRANSPORT = {"options", "names", "wire", "entities", "heap", "node", "clock", "buffer", "listener", "broadcaster", "profile",
             "message_filter", "graph", "router", "service", "parameters", "buffer_server", "tfwire",
             "msgpack_reader"}
#: Old module paths kept for one release; each only forwards to its new home (zentf/_moved.py).
MOVED = {"time", "messages", "math3d", "exceptions", "buffer_core", "geometry", "_chain_kernel", "bag", "view",
         "_moved"}
ZENOH_FREE = {0, 1}


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


#: Cython sources (the compiled core) are not Python syntax: their imports and cimports are read by line.
_PYX_IMPORT = re.compile(r"^[ \t]*(?:from[ \t]+(\.*)([\w.]*)[ \t]+c?import[ \t]+(\([^)]*\)|[^\n]+)"
                         r"|c?import[ \t]+([\w.]+))", re.M)


def _import_statements(path: Path) -> list[tuple[int, str, list[str]]]:
    """(level, module, imported names) per import statement of a .py or .pyx file, lazy ones too."""
    out: list[tuple[int, str, list[str]]] = []
    if path.suffix in (".pyx", ".pxd"):
        for dots, mod, names, plain in _PYX_IMPORT.findall(path.read_text()):
            if plain:
                out.append((0, plain, []))
            else:
                names = [n.split()[0] for n in names.strip("()").replace("\n", " ").split(",") if n.strip()]
                out.append((len(dots), mod, names))
        return out
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out.extend((0, a.name, []) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            out.append((node.level, node.module or "", [a.name for a in node.names]))
    return out


def _imports(path: Path) -> set[str]:
    """Absolute names of the zentf modules (and 'zenoh') a file imports, lazy imports included."""
    package = _module_name(path) if path.name == "__init__.py" else _module_name(path).rpartition(".")[0]
    found: set[str] = set()
    for level, module, imported in _import_statements(path):
        if level:
            base = package.split(".")[: len(package.split(".")) - level + 1]
            mod = ".".join(base + ([module] if module else []))
        else:
            mod = module
        # "from pkg import name" may name a submodule
        names = [mod] + [f"{mod}.{a}" for a in imported]
        for name in names:
            if name.split(".")[0] in ("zenoh", "zenoh_ext"):
                found.add("zenoh")
            elif name.startswith("zentf"):
                resolved = _resolve(name)
                if resolved:
                    found.add(resolved)
    return found


def _resolve(name: str) -> str | None:
    """The longest prefix of a dotted name that is a module or package file in zentf/."""
    parts = name.split(".")
    while parts:
        p = ROOT.joinpath(*parts)
        if any(p.with_suffix(x).is_file() for x in (".py", ".pyx", ".pxd")) or (p / "__init__.py").is_file():
            return ".".join(parts)
        parts.pop()
    return None


def _layer(module: str) -> int | None:
    """The layer of a zentf module, or None for the package root and the moved-module aliases."""
    parts = module.split(".")
    if len(parts) == 1:
        return None
    if parts[1] in SUBPACKAGES:
        return SUBPACKAGES[parts[1]]
    if parts[1] in MOVED:
        return None
    if parts[1] in TRANSPORT:
        return 2
    raise AssertionError(f"{module} is in no layer: add it to tests/test_layers.py")


FILES = sorted([*PKG.rglob("*.py"), *PKG.rglob("*.pyx"),
                *(p for p in PKG.rglob("*.pxd") if not p.with_suffix(".pyx").is_file())])  # a .pxd of its own
GRAPH = {_module_name(p): _imports(p) for p in FILES}


def test_every_module_is_placed_in_a_layer() -> None:
    for module in GRAPH:
        _layer(module)


def test_compiled_core_imports_are_read() -> None:
    """The .pyx reader sees cimports and imports (a reader that found nothing would pass every check)."""
    assert {"zentf.core.cache", "zentf.core.exceptions", "zentf.core.time"} <= GRAPH["zentf.core.buffer_core"]


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_imports_point_downward(module: str) -> None:
    level = _layer(module)
    if level is None:
        return
    bad = sorted(dep for dep in GRAPH[module] - {"zenoh", "zentf"}
                 if (_layer(dep) is None and dep.split(".")[1] in MOVED) or (_layer(dep) or 0) > level)
    assert not bad, f"{module} (layer {level}) imports upward or through a moved alias: {bad}"
    if level in ZENOH_FREE:
        assert "zenoh" not in GRAPH[module], f"{module} (layer {level}) imports Zenoh"


@pytest.mark.parametrize("module", sorted(m for m in GRAPH if m.startswith("zentf.core")))
def test_core_imports_nothing_outside_core(module: str) -> None:
    outside = sorted(d for d in GRAPH[module] if d == "zenoh" or not d.startswith("zentf.core"))
    assert not outside, f"{module} imports from outside zentf/core: {outside}"


def test_no_import_cycle() -> None:
    """Module-level graph (a package counts as importing its __init__'s imports) has no cycle."""
    graph = {m: {d for d in deps if d in GRAPH and d != m} for m, deps in GRAPH.items()}
    for m in list(graph):  # the package root re-exports lazily by name; its edges are not real cycles
        if m == "zentf":
            graph[m] = set()
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for d in sorted(graph[m]):
            # importing a submodule imports its parents first: an edge to zentf.core.x also enters zentf.core
            if state.get(d) == 1:
                cycle = stack[stack.index(d):] + [d]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)


def test_core_import_loads_no_zenoh() -> None:
    code = ("import sys, zentf, zentf.core.buffer_core, zentf.core.geometry, zentf.core.math3d; "
            "zentf.BufferCore; print('zenoh' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("old,new", [(f"zentf.{m}", f"zentf.core.{m}") for m in
                                     ("time", "messages", "math3d", "exceptions", "buffer_core", "geometry")]
                         + [("zentf.bag", "zentf.tools.bag"), ("zentf.view", "zentf.tools.view")])
def test_old_module_paths_warn_and_alias(old: str, new: str) -> None:
    code = (f"import warnings, importlib\n"
            f"with warnings.catch_warnings(record=True) as w:\n"
            f"    warnings.simplefilter('always')\n"
            f"    old = importlib.import_module('{old}')\n"
            f"new = importlib.import_module('{new}')\n"
            f"print(old is new, [str(x.category.__name__) for x in w], '{new}' in str(w[0].message))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "['DeprecationWarning']", "True"]
