"""The architecture holds: core imports no Zenoh, and imports only point downward."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CORE = {"time", "messages", "exceptions", "math3d", "buffer_core", "geometry", "_chain_kernel"}
TRANSPORT = {"options", "names", "wire", "node", "clock", "buffer", "listener", "broadcaster",
             "message_filter", "graph", "router", "bag", "view"}
TOP = {"launch", "cli"}
LEVEL = {**{m: 0 for m in CORE}, **{m: 1 for m in TRANSPORT}, **{m: 2 for m in TOP}}


def _zentf_imports(path: Path) -> set[str]:
    """First-level zentf modules a file imports (absolute or relative), including lazy imports."""
    tree = ast.parse(path.read_text(), str(path))
    pkg_parts = path.relative_to(ROOT).with_suffix("").parts[:-1]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(pkg_parts[: len(pkg_parts) - node.level + 1])
                mod = ".".join(base + ([node.module] if node.module else []))
                names = [mod] if node.module else [f"{mod}.{a.name}" for a in node.names]
            else:
                names = [node.module or ""]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "zentf" and len(parts) > 1:
                found.add(parts[1])
            if parts[0] == "zenoh":
                found.add("<zenoh>")
    return found


def _layer_of(path: Path) -> tuple[str, int] | None:
    rel = path.relative_to(ROOT / "zentf").parts
    name = rel[0].removesuffix(".py")
    return (name, LEVEL[name]) if name in LEVEL else None


def test_every_module_is_placed_in_a_layer() -> None:
    unplaced = sorted(p.name for p in (ROOT / "zentf").iterdir()
                      if p.name not in ("__init__.py", "__pycache__") and p.name.removesuffix(".py") not in LEVEL)
    assert not unplaced, f"modules without a layer in tests/test_layers.py: {unplaced}"


@pytest.mark.parametrize("path", sorted((ROOT / "zentf").rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_point_downward(path: Path) -> None:
    placed = _layer_of(path) if path.name != "__init__.py" or path.parent != ROOT / "zentf" else None
    if placed is None:
        return
    name, level = placed
    bad = []
    for dep in _zentf_imports(path):
        if dep == "<zenoh>":
            if level == 0:
                bad.append("zenoh")
        elif dep != name and LEVEL.get(dep, 0) > level:
            bad.append(dep)
    assert not bad, f"{path.relative_to(ROOT)} ({name}, layer {level}) imports upward: {bad}"


def test_core_import_loads_no_zenoh() -> None:
    code = ("import sys, zentf, zentf.buffer_core, zentf.geometry, zentf.math3d; "
            "zentf.BufferCore; print('zenoh' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "False"
