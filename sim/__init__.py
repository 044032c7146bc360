"""Kinematic software-in-the-loop vehicles that speak MAVLink 2 over UDP (see docs/sim.md)."""

from sim.ardupilot import BootTimes
from sim.battery import BatteryConfig, FailsafeLevel
from sim.fleet import FleetOptions, SimFleet, homes_for
from sim.geo import HomePose, LocalFrame
from sim.link import LinkFaults, signing_key_from
from sim.mission_protocol import MissionItem, MissionProtocol, MissionType, ProtocolConfig
from sim.modes import Mode
from sim.px4 import Px4BootTimes
from sim.sensor import Observation, SensorConfig
from sim.vehicle import SimVehicle, VehicleConfig, VehicleState

__all__ = [
    "BatteryConfig",
    "BootTimes",
    "FailsafeLevel",
    "FleetOptions",
    "HomePose",
    "LinkFaults",
    "LocalFrame",
    "MissionItem",
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
    "homes_for",
    "signing_key_from",
]
