"""`python -m nodes.point_publisher` from a checkout: an obstacle seen by the laser, on laser_point (installed: `zentf run point_publisher`)."""
from zentf.demos.point_publisher import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
