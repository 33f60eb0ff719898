"""The compiled wire path of zentf's transport (Cython), by concern:

- ``decoders``: the TFMessage decoders, one per wire (zentf's msgpack, ROS 2's CDR);
- ``handler``: a listener's per-topic ingest (decode, future-stamp guard, insert from C) and what it
  reports (``IngestEvents``);
- ``thread``: a listener's ``tf`` thread (per-sender queues, bounded in messages and bytes);
- ``tf_encoder``, ``joint_state_encoder``: zentf's msgpack TransformStamped and JointState, written in C.
"""
