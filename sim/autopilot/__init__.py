"""The simulated vehicle's MAVLink behaviour: the protocol, modes, mission storage, failsafes
and telemetry of each autopilot profile (ArduPilot, PX4), flying a `sim.physics` airframe."""
