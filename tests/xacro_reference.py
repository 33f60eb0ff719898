"""The PyPI ``xacro`` package as the reference expansion, in its own process (test-only).

    python tests/xacro_reference.py MODEL.xacro PKG=DIR [PKG=DIR ...] -- [NAME:=VALUE ...]

prints the URDF xacro makes. Its ``$(find PKG)`` needs a ROS 2 install (ament_index); here it is
answered from the PKG=DIR pairs instead. Run only on the real models in tests/data (xacro evaluates
Python from the model: never on an untrusted file).
"""
from __future__ import annotations

import os
import sys

import xacro
import xacro.substitution_args as subst


def main(argv: list[str]) -> int:
    model, rest = argv[0], argv[1:]
    split = rest.index("--") if "--" in rest else len(rest)
    packages = {k: os.path.abspath(v) for k, v in (p.split("=", 1) for p in rest[:split])}
    mappings = dict(a.split(":=", 1) for a in rest[split + 1:])

    def find(pkg: str) -> str:
        return packages[pkg]

    subst._eval_find = find
    doc = xacro.process_file(model, mappings=mappings)
    sys.stdout.write(doc.toprettyxml(indent="  "))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
