"""A UAV's mission as MAVLink mission items.

Copter: NAV_TAKEOFF at the airport, the waypoints, NAV_LAND at the airport.
Plane: NAV_TAKEOFF (minimum pitch 15 degrees), the waypoints (the planned path already ends over
the airport), then NAV_RETURN_TO_LAUNCH: a safe landing approach depends on the runway direction,
wind and obstacles, none of which the area file describes, so the plane comes home and loiters at
its return altitude until it is landed by the operator or by the autopilot's own configured landing
sequence (e.g. ArduPlane RTL_AUTOLAND with a DO_LAND_START sequence set up on site)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum, IntEnum


class MavCmd(IntEnum):
    NAV_WAYPOINT = 16
    NAV_RETURN_TO_LAUNCH = 20
    NAV_LAND = 21
    NAV_TAKEOFF = 22


class MavFrame(IntEnum):
    GLOBAL = 0                 # altitude above mean sea level
    GLOBAL_RELATIVE_ALT = 3    # altitude above home


class Vehicle(str, Enum):
    COPTER = "copter"
    PLANE = "plane"

    @property
    def mav_type(self) -> int:
        """MAV_TYPE: 2 quadrotor, 1 fixed wing."""
        return 2 if self is Vehicle.COPTER else 1


PLANE_TAKEOFF_PITCH_DEG = 15.0


@dataclass(frozen=True)
class MissionItem:
    """One MISSION_ITEM: `params` are param1..param4; altitude in metres in `frame`."""

    command: MavCmd
    frame: MavFrame
    lat_deg: float
    lon_deg: float
    alt_m: float
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    autocontinue: bool = True


@dataclass(frozen=True)
class UavMission:
    """What one UAV flies: home (its airport), altitude, and the waypoints as (lat, lon) rows."""

    uav_id: int
    name: str
    vehicle: Vehicle
    home_lat_deg: float
    home_lon_deg: float
    altitude_m: float
    waypoints: list[tuple[float, float]] = field(default_factory=list)
    home_amsl_m: float = 0.0

    @property
    def home(self) -> MissionItem:
        """Item 0 of a QGC WPL file: the home position (absolute frame)."""
        return MissionItem(MavCmd.NAV_WAYPOINT, MavFrame.GLOBAL, self.home_lat_deg, self.home_lon_deg,
                           self.home_amsl_m)


def mission_items(mission: UavMission) -> list[MissionItem]:
    """Take-off, waypoints and the landing (or return) item, without the home item."""
    rel = MavFrame.GLOBAL_RELATIVE_ALT
    lat0, lon0, alt = mission.home_lat_deg, mission.home_lon_deg, mission.altitude_m
    pitch = PLANE_TAKEOFF_PITCH_DEG if mission.vehicle is Vehicle.PLANE else 0.0
    items = [MissionItem(MavCmd.NAV_TAKEOFF, rel, lat0, lon0, alt, (pitch, 0.0, 0.0, 0.0))]
    items += [MissionItem(MavCmd.NAV_WAYPOINT, rel, lat, lon, alt) for lat, lon in mission.waypoints]
    if mission.vehicle is Vehicle.COPTER:
        items.append(MissionItem(MavCmd.NAV_LAND, rel, lat0, lon0, 0.0))
    else:
        items.append(MissionItem(MavCmd.NAV_RETURN_TO_LAUNCH, rel, 0.0, 0.0, 0.0))
    return items
