"""`python -m nodes.buffer_server` from a checkout: tf2_ros's buffer server: answers BufferClients' lookups (installed: `zentf run buffer_server`)."""
from zentf.tools.buffer_server import main
from zentf.transport.program import finish

if __name__ == "__main__":
    finish(main())
