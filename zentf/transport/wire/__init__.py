"""Wire profiles: how a node's topics, payloads, attachments, services and graph tokens look on Zenoh.
``base`` is the interface, ``zentf_wire`` (zentf's own msgpack wire, ``codec``) and ``ros2`` (rmw_zenoh's)
its two implementations, ``profiles.make_profile`` picks one by name."""
