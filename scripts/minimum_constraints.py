#!/usr/bin/env python3
"""Print pip constraints pinning every requirement in pyproject.toml to its declared lower bound.

    python scripts/minimum_constraints.py > min.txt
    PIP_CONSTRAINT=min.txt pip install -e '.[test]'

So the oldest versions zentf says it works with are the ones installed, and a lower bound that is
not true fails a test instead of a user. Covers [project] dependencies, every extra and the
build-system requirements (PIP_CONSTRAINT, unlike -c, reaches pip's isolated build environment).
A requirement with no ``>=`` bound is an error: every dependency must say what it needs. Where two
entries name the same package, the highest lower bound wins (pip would need it anyway).
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

#: name, optional [extras], then the specifier list, optional ; marker
_REQ = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(\[[^\]]*\])?\s*([^;]*)(;.*)?$")


def lower_bound(requirement: str) -> tuple[str, str]:
    """(normalized name, version) of a requirement's ``>=`` bound."""
    m = _REQ.match(requirement)
    if not m:
        raise ValueError(f"cannot read requirement {requirement!r}")
    name = re.sub(r"[-_.]+", "-", m.group(1)).lower()
    bounds = [s.strip()[2:].strip() for s in m.group(3).split(",") if s.strip().startswith(">=")]
    if len(bounds) != 1:
        raise ValueError(f"requirement {requirement!r} needs exactly one '>=' lower bound")
    return name, bounds[0]


def _key(version: str) -> tuple[int, ...]:
    return tuple(int(p) for p in re.findall(r"\d+", version))


def minimums(pyproject: dict) -> dict[str, str]:
    """Package -> lowest version the project declares it works with."""
    reqs = list(pyproject["project"].get("dependencies", []))
    for extra in pyproject["project"].get("optional-dependencies", {}).values():
        reqs += extra
    reqs += pyproject.get("build-system", {}).get("requires", [])
    out: dict[str, str] = {}
    for r in reqs:
        name, version = lower_bound(r)
        if name not in out or _key(version) > _key(out[name]):
            out[name] = version
    return out


def main(argv: list[str]) -> int:
    path = Path(argv[1]) if len(argv) > 1 else Path(__file__).resolve().parents[1] / "pyproject.toml"
    with open(path, "rb") as f:
        data = tomllib.load(f)
    try:
        pins = minimums(data)
    except ValueError as e:
        print(f"minimum_constraints: {path}: {e}", file=sys.stderr)
        return 1
    print(f"# generated from {path.name} by scripts/minimum_constraints.py: each declared lower bound")
    for name in sorted(pins):
        print(f"{name}=={pins[name]}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
