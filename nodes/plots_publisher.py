"""`python -m nodes.plots_publisher` from a checkout: the drones' trails as line-strip markers (installed: `zentf run plots_publisher`)."""
from zentf.demos.plots_publisher import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
