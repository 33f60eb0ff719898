"""`python -m nodes.dds_bridge` from a checkout: the DDS bridge as a node program (installed: `zentf run dds_bridge`)."""
from zentf.tools.dds.program import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
