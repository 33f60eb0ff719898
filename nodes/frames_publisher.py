"""`python -m nodes.frames_publisher` from a checkout: two drones, av1 and av2, flying in world (installed: `zentf run frames_publisher`)."""
from zentf.demos.frames_publisher import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
