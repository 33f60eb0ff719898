"""`python -m nodes.turtle_teleop_key` from a checkout: drive a turtle with this terminal's arrow keys (installed: `zentf run turtle_teleop_key`)."""
from zentf.demos.turtle_teleop_key import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
