"""Build the compiled core (Cython): every ``zentf/**/*.pyx`` becomes an extension module.

pyproject.toml holds the metadata; this file lists the extensions and the packages, so ``pip install .`` and
``pip install -e .`` compile them (Cython comes from PyPI as a build requirement; gcc from the
machine). See docs/architecture.md for why Cython and what is compiled.
"""
import os
import sys
from pathlib import Path

from setuptools import Extension, find_packages, setup

try:
    from Cython.Build import cythonize
except ImportError:  # build_py/sdist need no compiler; anything that compiles does
    if not {"build_py", "sdist", "egg_info"}.issuperset(a for a in sys.argv[1:] if not a.startswith("-")
                                                            and "/" not in a):
        raise SystemExit("zentf compiles its core with Cython: pip install Cython (pip install . does it for you)")
    cythonize = None

extensions = [
    Extension(".".join(p.with_suffix("").parts), [str(p)], extra_compile_args=["-O3", "-fno-math-errno"])
    for p in sorted(Path("zentf").rglob("*.pyx"))
]
# The wheel's one top-level package is zentf; the checkout's configs/ (launch files, Zenoh configs, the demo
# recording and robot) goes in as zentf/configs, where `zentf launch NAME` finds it when installed.
CONFIGS = ["*.yaml", "*/*.yaml", "zenoh/*.json5", "recordings/*.mcap", "robots/*.urdf"]
CONFIG_DIRS = sorted(f"zentf.configs.{d.name}" for d in Path("configs").iterdir() if d.is_dir() and d.name[0] != "_")
setup(packages=[*find_packages(include=["zentf", "zentf.*"]), "zentf.configs", *CONFIG_DIRS],
      package_dir={"zentf.configs": "configs"},
      package_data={"zentf.configs": CONFIGS},
      options={"build_ext": {"parallel": os.cpu_count() or 1}},
      ext_modules=[] if cythonize is None else cythonize(extensions, language_level=3, nthreads=2,
                            compiler_directives={"boundscheck": False, "wraparound": False,
                                                 "cdivision": True, "initializedcheck": False,
                                                 "embedsignature": True}))
