"""What the vehicles report: per-vehicle status kept from MAVLink telemetry, and a watcher
of vehicles on links without a flight."""
