"""`python -m nodes.turtle_teleop` from a checkout: drive a turtle along a scripted pattern (installed: `zentf run turtle_teleop`)."""
from zentf.demos.turtle_teleop import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
