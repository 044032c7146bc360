"""Real autopilots for the tests: ArduPilot and PX4 SITL from the peers folder
(`../shared/peers` beside the repository, or `$GCS_PEERS_DIR`), started on loopback."""
