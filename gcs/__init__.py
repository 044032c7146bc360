"""Ground-control side of gcs: command line, MAVLink links, fleet monitoring, MQTT, logging."""
