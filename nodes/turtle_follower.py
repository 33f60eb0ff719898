"""`python -m nodes.turtle_follower` from a checkout: spawn turtle2 and steer it toward turtle1 through tf (installed: `zentf run turtle_follower`)."""
from zentf.demos.turtle_follower import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
