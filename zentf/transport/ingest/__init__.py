"""The compiled ingest path: TFMessage decoders, the listener's per-message insert and its thread."""
