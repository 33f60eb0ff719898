"""The transport layer (tf2_ros to the core's tf2): nodes, publishers, subscriptions, listener, broadcasters,
clock, services and parameters over Zenoh, in either wire profile."""
