"""Which files a model may read while it is expanded, and ``$(find PKG)``.

A model reads its own folder (and below), the package/search directories the user gave (the
``--package-path`` option, ``$ZENTF_PACKAGE_PATH``, ``$ROS_PACKAGE_PATH``) and the ROS packages it
sits in (an ancestor folder whose package.xml names the package). Everything else is refused with one
line, whatever the path says (``..``, absolute paths, symbolic links: the real path is checked).
Nothing is ever written.
"""
from __future__ import annotations

import glob as _glob
import os
import re

from .budget import Meter
from .errors import XacroError

__all__ = ["FilePolicy", "package_xml_name", "MAX_FILE", "MAX_GLOB"]

#: Largest single file read (an include or a YAML file).
MAX_FILE = 16 * 1024 * 1024
#: Most files one glob pattern may include.
MAX_GLOB = 1000
_NAME = re.compile(rb"<name>\s*([^<\s]+)\s*</name>")
_PKG = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*$")


def package_xml_name(directory: str) -> str | None:
    """The <name> in directory/package.xml, or None."""
    try:
        with open(os.path.join(directory, "package.xml"), "rb") as f:
            head = f.read(20000)
    except OSError:
        return None
    m = _NAME.search(head)
    return m.group(1).decode("utf-8", "replace") if m else None


class FilePolicy:
    """Allowed roots (real paths), the search directories, the known packages; reads files within them."""

    def __init__(self, roots: list[str], search: list[str], packages: dict[str, str], meter: Meter) -> None:
        self.roots = [os.path.realpath(r) for r in roots if r and os.path.isdir(r)]
        self.search = [s for s in search if s]
        self.packages = dict(packages)
        self.meter = meter

    def allowed(self, path: str) -> str:
        """The real path of ``path`` if it lies within a root; XacroError otherwise."""
        real = os.path.realpath(path)
        for root in self.roots:
            if real == root or real.startswith(root.rstrip(os.sep) + os.sep):
                return real
        raise XacroError(f"'{path}' is outside the model's folder and the package paths (symbolic links "
                         f"leading out are not followed; give its package's folder with --package-path)")

    def read(self, path: str, what: str) -> bytes:
        """The bytes of a file within the roots (FileNotFoundError when it does not exist)."""
        real = self.allowed(path)
        if not os.path.exists(real):
            raise FileNotFoundError(path)
        if not os.path.isfile(real):
            raise XacroError(f"{what} '{path}' is not a regular file")
        size = os.path.getsize(real)
        if size > MAX_FILE:
            raise XacroError(f"{what} '{path}' is {size} bytes, more than the {MAX_FILE} a model file may have")
        self.meter.bytes_read(size, f"{what} '{path}'")
        with open(real, "rb") as f:
            data = f.read(MAX_FILE + 1)
        if len(data) > MAX_FILE:
            raise XacroError(f"{what} '{path}' grew past {MAX_FILE} bytes while read")
        return data

    def glob(self, pattern: str) -> list[str]:
        """The files a glob pattern names, sorted, within the roots only."""
        fixed = re.split(r"[*?[]", pattern, maxsplit=1)[0]
        self.allowed(os.path.dirname(fixed) or ".")
        out = []
        for p in sorted(_glob.iglob(pattern)):
            self.meter.tick()
            try:
                self.allowed(p)
            except XacroError:
                continue
            out.append(p)
            if len(out) > MAX_GLOB:
                raise XacroError(f"include pattern '{pattern}' matches more than {MAX_GLOB} files")
        return out

    def find(self, name: str) -> str:
        """$(find NAME): the package's directory."""
        if not _PKG.match(name):
            raise XacroError(f"$(find {name}): not a package name")
        known = self.packages.get(name)
        if known is not None:
            return known
        for d in self.search:
            for cand in (d, os.path.join(d, name)):
                if not os.path.isdir(cand):
                    continue
                pkg = package_xml_name(cand)
                if pkg == name or (pkg is None and (cand != d or os.path.basename(os.path.normpath(d)) == name)):
                    self.packages[name] = os.path.abspath(cand)
                    return self.packages[name]
        raise XacroError(f"$(find {name}): package not found (give its folder with --package-path or "
                         f"$ZENTF_PACKAGE_PATH)")
