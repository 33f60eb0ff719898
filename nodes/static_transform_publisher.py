"""`python -m nodes.static_transform_publisher` from a checkout: publish one latched transform (tf2_ros static_transform_publisher) (installed: `zentf run static_transform_publisher`)."""
from zentf.tools.static_transform_publisher import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
