"""Where ``package://NAME/...`` and ``file://`` mesh references live on this machine.

Search order for ``package://NAME/rest``: the directories of the ``package_path`` option, then of
``$ZENTF_PACKAGE_PATH`` and ``$ROS_PACKAGE_PATH`` (os.pathsep-separated), then the URDF file's own
ancestors. A directory D holds package NAME when D is the package (its package.xml names NAME, or
its base name is NAME) or D/NAME is. Nothing is ever fetched: an unresolved file is just missing.
"""
from __future__ import annotations

import os
import re
from functools import lru_cache
from pathlib import Path
from urllib.parse import unquote

__all__ = ["PACKAGE_PATH_ENV", "search_path", "resolve_uri", "package_name"]

PACKAGE_PATH_ENV = "ZENTF_PACKAGE_PATH"
_NAME_RE = re.compile(r"<name>\s*([^<\s]+)\s*</name>")


@lru_cache(maxsize=256)
def package_name(directory: str) -> str | None:
    """The <name> in directory/package.xml, or None."""
    try:
        text = Path(directory, "package.xml").read_text(encoding="utf-8", errors="replace")[:20000]
    except OSError:
        return None
    m = _NAME_RE.search(text)
    return m.group(1) if m else None


def search_path(package_path: list[str] | None = None, urdf_file: str | None = None) -> list[str]:
    """The directories package:// is looked up in, in order."""
    dirs = [d for d in (package_path or []) if d]
    for var in (PACKAGE_PATH_ENV, "ROS_PACKAGE_PATH"):
        dirs += [d for d in os.environ.get(var, "").split(os.pathsep) if d]
    if urdf_file:
        here = Path(urdf_file).resolve().parent
        dirs += [str(here), *map(str, here.parents)][:6]
    return dirs


def _package_dir(name: str, dirs: list[str]) -> Path | None:
    for d in dirs:
        base = Path(d)
        for cand in (base, base / name):
            if cand.is_dir() and (package_name(str(cand)) == name
                                  or (cand != base and not (cand / "package.xml").exists())
                                  or (cand == base and base.name == name)):
                return cand
    return None


def resolve_uri(uri: str, dirs: list[str], base_dir: str | None = None) -> str | None:
    """A local path for a mesh reference if that file exists, else None."""
    if uri.startswith("package://"):
        rest = uri[len("package://"):]
        name, _, sub = rest.partition("/")
        pkg = _package_dir(name, dirs) if name else None
        path = pkg / unquote(sub) if pkg is not None else None
    elif uri.startswith("file://"):
        path = Path(unquote(uri[len("file://"):]))
    elif "://" in uri:
        return None  # http:// and the like: never fetched
    else:
        path = Path(uri)
        if not path.is_absolute() and base_dir:
            path = Path(base_dir) / path
    if path is not None and path.is_file():
        return str(path)
    return None
