"""Programs built on the transport: bag record/play (MCAP), the Rerun view."""
