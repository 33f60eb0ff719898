"""Build the compiled core (Cython): every ``zentf/**/*.pyx`` becomes an extension module.

pyproject.toml holds the metadata; this file only lists the extensions, so ``pip install .`` and
``pip install -e .`` compile them (Cython comes from PyPI as a build requirement; gcc from the
machine). See docs/architecture.md for why Cython and what is compiled.
"""
import os
from pathlib import Path

from Cython.Build import cythonize
from setuptools import Extension, setup

extensions = [
    Extension(".".join(p.with_suffix("").parts), [str(p)], extra_compile_args=["-O3", "-fno-math-errno"])
    for p in sorted(Path("zentf").rglob("*.pyx"))
]
setup(options={"build_ext": {"parallel": os.cpu_count() or 1}},
      ext_modules=cythonize(extensions, language_level=3, nthreads=2,
                            compiler_directives={"boundscheck": False, "wraparound": False,
                                                 "cdivision": True, "initializedcheck": False,
                                                 "embedsignature": True}))
