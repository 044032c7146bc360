"""Kinematic software-in-the-loop vehicles that speak MAVLink 2 over UDP (see docs/sim.md).

`sim.autopilot` is each vehicle's MAVLink behaviour (protocol, modes, missions, parameters,
telemetry), `sim.physics` the airframe it flies (motion, battery, sensor); the fleet
(`sim.fleet`) and its UDP links (`sim.vehicle_link`) run them; `new_vehicle` makes one vehicle
of a config's profile. `LocalFrame` is the planner's (`planner.georef`), `WireItem` and
`MissionType` the station's (`gcs.autopilots.wire_item`), re-exported here.
"""

from gcs.autopilots.wire_item import MissionType, WireItem
from planner.georef import LocalFrame
from sim.autopilot.ardupilot import BootTimes
from sim.autopilot.failsafe import FailsafeLevel
from sim.autopilot.mission_protocol import MissionProtocol, ProtocolConfig
from sim.autopilot.modes import Mode
from sim.autopilot.profiles import new_vehicle
from sim.autopilot.px4 import Px4BootTimes
from sim.autopilot.vehicle import SimVehicle, VehicleConfig, VehicleState
from sim.fleet import FleetOptions, SimFleet, homes_for
from sim.physics.airframe import HomePose
from sim.physics.battery import BatteryConfig
from sim.physics.sensor import Observation, SensorConfig
from sim.vehicle_link import LinkFaults, signing_key_from

__all__ = [
    "BatteryConfig",
    "BootTimes",
    "FailsafeLevel",
    "FleetOptions",
    "HomePose",
    "LinkFaults",
    "LocalFrame",
    "MissionProtocol",
    "MissionType",
    "Mode",
    "Observation",
    "ProtocolConfig",
    "Px4BootTimes",
    "SensorConfig",
    "SimFleet",
    "SimVehicle",
    "VehicleConfig",
    "VehicleState",
    "WireItem",
    "homes_for",
    "new_vehicle",
    "signing_key_from",
]
