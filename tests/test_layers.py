"""The architecture holds: zentf/core is self-contained and Zenoh-free, imports point downward, no cycles.

Rooms, lowest first: 0 ``zentf/core/`` (tf2), 1 formats (``zentf/ros/``, ``zentf/urdf/``: pure, no
Zenoh), 2 ``zentf/transport/`` (Zenoh), 3 the programs (``zentf/tools/``, ``zentf/demos/``), 4
``zentf/launch/`` and ``zentf/cli/``. The top of ``zentf/`` holds ``__init__.py`` and rooms only.
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
ROOMS = {"core": 0, "ros": 1, "urdf": 1, "transport": 2, "tools": 3, "demos": 3, "launch": 4, "cli": 4}
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
    tree = ast.parse(path.read_text(), str(path))
    typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If) and _is_type_checking(block.test)
                   for stmt in block.body for n in ast.walk(stmt)}
    for node in ast.walk(tree):
        if id(node) in typing_only:  # `if TYPE_CHECKING:` imports never run
            continue
        if isinstance(node, ast.Import):
            out.extend((0, a.name, []) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            out.append((node.level, node.module or "", [a.name for a in node.names]))
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


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
            elif name.split(".")[0] == "nodes":
                found.add("nodes")
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
    """The layer of a zentf module, or None for the package root."""
    parts = module.split(".")
    if len(parts) == 1:
        return None
    if parts[1] in ROOMS:
        return ROOMS[parts[1]]
    raise AssertionError(f"{module} is in no room: the top of zentf/ holds __init__.py and rooms only")


FILES = sorted([*PKG.rglob("*.py"), *PKG.rglob("*.pyx"),
                *(p for p in PKG.rglob("*.pxd") if not p.with_suffix(".pyx").is_file())])  # a .pxd of its own
GRAPH = {_module_name(p): _imports(p) for p in FILES}


def test_every_module_is_placed_in_a_layer() -> None:
    for module in GRAPH:
        _layer(module)


def test_the_top_of_the_package_holds_only_rooms() -> None:
    top = {p.name for p in PKG.iterdir() if not p.name.startswith((".", "__pycache__"))}
    loose = sorted(n for n in top if n != "__init__.py" and n.split(".")[0] not in ROOMS)
    assert not loose, f"files or folders at the top of zentf/ outside the rooms: {loose}"


def test_nothing_in_the_library_imports_the_checkout_programs() -> None:
    """nodes/ is the checkout's thin runners; the library (and so the wheel) never needs it."""
    users = sorted(m for m, deps in GRAPH.items() if "nodes" in deps)
    assert not users, f"modules importing the nodes package: {users}"


def test_compiled_core_imports_are_read() -> None:
    """The .pyx reader sees cimports and imports (a reader that found nothing would pass every check)."""
    assert {"zentf.core.cache", "zentf.core.exceptions", "zentf.core.time"} <= GRAPH["zentf.core.buffer_core"]


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_imports_point_downward(module: str) -> None:
    level = _layer(module)
    if level is None:
        return
    bad = sorted(dep for dep in GRAPH[module] - {"zenoh", "zentf", "nodes"} if (_layer(dep) or 0) > level)
    assert not bad, f"{module} (layer {level}) imports upward: {bad}"
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


@pytest.mark.parametrize("old", ["zentf.node", "zentf.listener", "zentf.wire", "zentf.profile", "zentf.tfwire",
                                 "zentf.time", "zentf.messages", "zentf.buffer_core", "zentf.bag", "zentf.view",
                                 "zentf._moved"])
def test_the_old_module_paths_are_gone(old: str) -> None:
    """Removed in this release (CHANGELOG.md names each new path); nothing forwards them any more."""
    out = subprocess.run([sys.executable, "-c", f"import {old}"], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 1 and "ModuleNotFoundError" in out.stderr, out.stderr
