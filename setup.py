"""Build the compiled core (Cython): every ``zentf/**/*.pyx`` becomes an extension module.

pyproject.toml holds the metadata; this file lists the extensions and the packages, so ``pip install .`` and
``pip install -e .`` compile them (Cython comes from PyPI as a build requirement; gcc from the
machine). See docs/architecture.md for why Cython and what is compiled.
"""
import os
from pathlib import Path

from Cython.Build import cythonize
from setuptools import Extension, find_packages, setup

extensions = [
    Extension(".".join(p.with_suffix("").parts), [str(p)], extra_compile_args=["-O3", "-fno-math-errno"])
    for p in sorted(Path("zentf").rglob("*.pyx"))
]
# The wheel's one top-level package is zentf; the checkout's configs/ (launch files, Zenoh configs, the demo
# recording and robot) goes in as zentf/configs, where `zentf launch NAME` finds it when installed.
CONFIGS = ["*.yaml", "*/*.yaml", "zenoh/*.json5", "recordings/*.mcap", "robots/*.urdf"]
setup(packages=[*find_packages(include=["zentf", "zentf.*"]), "zentf.configs"],
      package_dir={"zentf.configs": "configs"},
      package_data={"zentf.configs": CONFIGS},
      options={"build_ext": {"parallel": os.cpu_count() or 1}},
      ext_modules=cythonize(extensions, language_level=3, nthreads=2,
                            compiler_directives={"boundscheck": False, "wraparound": False,
                                                 "cdivision": True, "initializedcheck": False,
                                                 "embedsignature": True}))
