"""`python -m zentf.cli`."""
from zentf.cli import run

run()
