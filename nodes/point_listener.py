"""`python -m nodes.point_listener` from a checkout: each obstacle point in base_link, through a MessageFilter (installed: `zentf run point_listener`)."""
from zentf.demos.point_listener import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
