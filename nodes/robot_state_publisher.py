"""`python -m nodes.robot_state_publisher` from a checkout: a URDF's frames on tf_static and, from joint_states, on tf (installed: `zentf run robot_state_publisher`)."""
from zentf.tools.robot_state_publisher import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
