"""Wire profiles (``profiles``): how a node's topics, payloads, attachments and graph tokens look on Zenoh,
zentf's own msgpack wire (``codec``) or rmw_zenoh's for ROS 2."""
