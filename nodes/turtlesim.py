"""`python -m nodes.turtlesim` from a checkout: headless turtlesim: turtles, their poses and ROS's services (installed: `zentf run turtlesim`)."""
from zentf.demos.turtlesim import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
