"""`python -m nodes.frame_listener` from a checkout: every second, where the laser is as seen from the camera (installed: `zentf run frame_listener`)."""
from zentf.demos.frame_listener import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
