"""The simulated vehicle's MAVLink behaviour: the protocol, modes, mission storage and
telemetry of each autopilot profile (ArduPilot, PX4)."""
