"""zentf's own xacro: expands .xacro robot models with their files as data, never as code.

xacro's ``${...}`` is Python's ``eval`` behind a thin filter, and its sandbox has known ways out (a
model ran shell commands; ``xacro.load_yaml`` read any file). Here the expressions go to a small
interpreter that knows only what robot models use (``evaluator``), files are read only from the
model's folder and the package paths the user gave (``files``), and the whole expansion runs in a
child process the kernel confines and limits (``sandbox``, ``process``) within a CPU and memory
budget (``budget``). ``process.expand_file`` is the entry point; the rest keeps xacro's semantics
(``expand``) so real models give the URDF xacro gives.

This package imports nothing from the rest of zentf: the child loads it alone, by file.
"""
