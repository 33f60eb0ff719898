"""One thin file per runnable program, for `python -m nodes.<name>` from a checkout.

Each imports its program from the library (`zentf.demos`, `zentf.tools`) and runs it; the library never
imports this package and the wheel does not ship it. Installed, `zentf run <name>` starts the same program.
"""
