"""The simulated world a vehicle flies in: its airframe (motion within its limits, battery,
downward sensor). Nothing here knows MAVLink or the autopilot (`sim.autopilot`)."""
