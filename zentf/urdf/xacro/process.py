"""Expanding a .xacro model in a confined child process (the parent's side).

The child is a fresh interpreter (``python -I``: no user site, no current folder on the path, no
environment) that loads only this package, by file, under a private name: it starts in ~50 ms
without zentf's or numpy's imports. It gets the model's path, the allowed roots, the search folders,
the packages it sits in, the xacro arguments, the environment variables the caller passed by name,
and the budget; it confines itself (``sandbox.confine``) and answers with the URDF text or one line.
A wall-clock timeout (the CPU budget plus slack) ends a child that stops making progress.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from dataclasses import dataclass, field

from .budget import DEFAULT_BUDGET, BUDGET_OPTION, Budget
from .errors import BudgetExceeded, XacroError
from .files import package_xml_name

__all__ = ["expand_file", "Expansion", "model_roots", "PACKAGE_PATH_ENV"]

PACKAGE_PATH_ENV = "ZENTF_PACKAGE_PATH"
_PKG_DIR = os.path.dirname(os.path.abspath(__file__))
_BOOT = ("import importlib.util,sys\n"
         "d=sys.argv[1]\n"
         "sys.path.extend(p for p in sys.argv[2:] if p not in sys.path)\n"
         "s=importlib.util.spec_from_file_location('_zentf_xacro',d+'/__init__.py',submodule_search_locations=[d])\n"
         "m=importlib.util.module_from_spec(s);sys.modules['_zentf_xacro']=m;s.loader.exec_module(m)\n"
         "from _zentf_xacro.sandbox import main\n"
         "sys.exit(main())\n")


def _yaml_dir() -> str:
    """Where PyYAML is (isolated mode leaves out a user site-packages; the child is told)."""
    import yaml

    return os.path.dirname(os.path.dirname(os.path.abspath(yaml.__file__)))


@dataclass
class Expansion:
    """The expanded URDF text, xacro's warnings, and how the child was confined."""

    urdf: str
    warnings: list[str] = field(default_factory=list)
    confined: dict = field(default_factory=dict)


def model_roots(path: str, package_path: list[str] | None) -> tuple[list[str], list[str], dict[str, str]]:
    """(allowed roots, search folders, {package: folder}) for a model file: its folder, the package
    paths given (option, then $ZENTF_PACKAGE_PATH and $ROS_PACKAGE_PATH), and the ROS packages above
    it (an ancestor folder, up to five up, whose package.xml names it)."""
    here = os.path.dirname(os.path.abspath(path))
    search = [os.path.abspath(d) for d in (package_path or []) if d]
    for var in (PACKAGE_PATH_ENV, "ROS_PACKAGE_PATH"):
        search += [os.path.abspath(d) for d in os.environ.get(var, "").split(os.pathsep) if d]
    packages: dict[str, str] = {}
    d = here
    for _ in range(6):
        name = package_xml_name(d)
        if name is not None and name not in packages:
            packages[name] = d
        parent = os.path.dirname(d)
        if parent == d:
            break
        d = parent
    roots = [here, *[s for s in search if os.path.isdir(s)], *packages.values()]
    return list(dict.fromkeys(roots)), search, packages


def expand_file(path: str, *, args: dict[str, str] | None = None, package_path: list[str] | None = None,
                env: dict[str, str] | None = None, budget: Budget | None = None) -> Expansion:
    """The URDF text of a .xacro file, expanded in a confined child; XacroError (one line) otherwise."""
    budget = budget or DEFAULT_BUDGET
    path = os.path.abspath(path)
    if not os.path.isfile(path):
        raise XacroError("no such file", path)
    roots, search, packages = model_roots(path, package_path)
    request = json.dumps({"path": path, "roots": roots, "search": search, "packages": packages,
                          "args": dict(args or {}), "env": dict(env or {}), "cwd": os.getcwd(),
                          "budget": {"cpu_s": budget.cpu_s, "memory_mb": budget.memory_mb}}).encode()
    child_env = {k: os.environ[k] for k in ("LD_LIBRARY_PATH", "SYSTEMROOT") if k in os.environ}
    if not sys.executable:
        raise XacroError("cannot expand .xacro: no Python interpreter to run the expansion in", path)
    wall = budget.cpu_s * 3 + 15
    try:
        proc = subprocess.run([sys.executable, "-I", "-c", _BOOT, _PKG_DIR, _yaml_dir()], input=request,
                              capture_output=True,
                              timeout=wall, env=child_env, cwd=os.path.dirname(path))
    except subprocess.TimeoutExpired:
        raise BudgetExceeded(f"xacro expansion stopped: no answer within {wall:g} s (raise it with {BUDGET_OPTION})",
                             path) from None
    except OSError as e:
        raise XacroError(f"cannot start the xacro expansion: {e.strerror or e}", path) from None
    rc, out = proc.returncode, proc.stdout
    if rc < 0 and -rc in (getattr(signal, "SIGXCPU", -1), getattr(signal, "SIGKILL", -1)):
        raise BudgetExceeded(f"xacro expansion stopped: it used up its CPU budget of {budget.cpu_s:g} s "
                             f"(raise it with {BUDGET_OPTION})", path)
    reply = None
    if rc == 0 and len(out) >= 8:
        n = int.from_bytes(out[:8], "big")
        try:
            reply = json.loads(out[8:8 + n])
        except ValueError:
            reply = None
    if not isinstance(reply, dict):
        first = (proc.stderr.decode("utf-8", "replace").strip().splitlines() or [""])[-1][:300]
        how = f"signal {-rc}" if rc < 0 else f"exit status {rc}"
        raise XacroError(f"the xacro expansion failed ({how}){': ' + first if first else ''}", path)
    if reply.get("ok"):
        return Expansion(str(reply["urdf"]), [str(w) for w in reply.get("warnings", [])], reply.get("confined", {}))
    if reply.get("budget") == "memory":
        raise BudgetExceeded(f"xacro expansion stopped: it ran out of its memory budget of {budget.memory_mb} MB "
                             f"(raise it with {BUDGET_OPTION})", path)
    line = reply.get("line")
    raise XacroError(str(reply.get("error", "xacro expansion failed")), reply.get("file") or path,
                     int(line) if isinstance(line, int) else None)
