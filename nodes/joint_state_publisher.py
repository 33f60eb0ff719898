"""`python -m nodes.joint_state_publisher` from a checkout: joint_states for a URDF's movable joints: values, --sweep, --gui sliders (installed: `zentf run joint_state_publisher`)."""
from zentf.tools.joint_state_publisher import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
