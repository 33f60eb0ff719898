"""`python -m zentf.launch FILE [name:=value ...]` (same as `zentf launch`)."""
import sys

from zentf.launch.cli import launch_main

sys.exit(launch_main())
