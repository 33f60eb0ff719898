"""`python -m nodes.turtle_tf_broadcaster` from a checkout: world -> <turtlename> from a turtle's pose (installed: `zentf run turtle_tf_broadcaster`)."""
from zentf.demos.turtle_tf_broadcaster import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
