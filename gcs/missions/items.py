"""A UAV's mission as MAVLink mission items.

Copter: NAV_TAKEOFF at the airport, the waypoints, NAV_LAND at the airport.
Plane: NAV_TAKEOFF along the runway (the airport's heading) with a 15 degree climb pitch, the
waypoints (the planned path already ends over the airport), then a landing sequence that lines up
with the runway: DO_LAND_START, an approach waypoint on the runway axis behind the airport at the
approach altitude, and NAV_LAND at the airport. Because the sequence starts with DO_LAND_START,
ArduPlane's RTL with RTL_AUTOLAND = 2 flies it too, so RTL still ends on the runway."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum, IntEnum


class MavCmd(IntEnum):
    NAV_WAYPOINT = 16
    NAV_RETURN_TO_LAUNCH = 20
    NAV_LAND = 21
    NAV_TAKEOFF = 22
    DO_LAND_START = 189


class MavFrame(IntEnum):
    GLOBAL = 0                 # altitude above mean sea level
    GLOBAL_RELATIVE_ALT = 3    # altitude above home
    GLOBAL_TERRAIN_ALT = 10    # altitude above the ground below (terrain following)
    GLOBAL_TERRAIN_ALT_INT = 11

    @property
    def in_files(self) -> MavFrame:
        """The frame a plain-text or QGroundControl file writes (float coordinates: no _INT frames)."""
        return MavFrame.GLOBAL_TERRAIN_ALT if self is MavFrame.GLOBAL_TERRAIN_ALT_INT else self


class AltitudeReference(str, Enum):
    """What a mission's altitude is measured from: the airport (home), or the ground below."""

    HOME = "home"
    TERRAIN = "terrain"

    @property
    def frame(self) -> MavFrame:
        return MavFrame.GLOBAL_RELATIVE_ALT if self is AltitudeReference.HOME else MavFrame.GLOBAL_TERRAIN_ALT_INT


class Vehicle(str, Enum):
    COPTER = "copter"
    PLANE = "plane"

    @property
    def mav_type(self) -> int:
        """MAV_TYPE: 2 quadrotor, 1 fixed wing."""
        return 2 if self is Vehicle.COPTER else 1


PLANE_TAKEOFF_PITCH_DEG = 15.0


@dataclass(frozen=True)
class LandingApproach:
    """A plane's final approach: the point on the runway axis where it starts its glide to the
    airport, and the altitude (above home) it reaches that point at."""

    lat_deg: float
    lon_deg: float
    alt_m: float


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
    altitude_reference: AltitudeReference = AltitudeReference.HOME
    approach: LandingApproach | None = None

    @property
    def home(self) -> MissionItem:
        """Item 0 of a QGC WPL file: the home position (absolute frame)."""
        return MissionItem(MavCmd.NAV_WAYPOINT, MavFrame.GLOBAL, self.home_lat_deg, self.home_lon_deg,
                           self.home_amsl_m)


def mission_items(mission: UavMission) -> list[MissionItem]:
    """Take-off, waypoints and the landing items, without the home item. Take-off and landing
    are measured from home; the waypoints from home or, terrain following, the ground."""
    rel = MavFrame.GLOBAL_RELATIVE_ALT
    lat0, lon0, alt = mission.home_lat_deg, mission.home_lon_deg, mission.altitude_m
    pitch = PLANE_TAKEOFF_PITCH_DEG if mission.vehicle is Vehicle.PLANE else 0.0
    items = [MissionItem(MavCmd.NAV_TAKEOFF, rel, lat0, lon0, alt, (pitch, 0.0, 0.0, 0.0))]
    return items + waypoint_items(mission, mission.waypoints) + landing_items(mission)


def waypoint_items(mission: UavMission, waypoints: list[tuple[float, float]]) -> list[MissionItem]:
    """NAV_WAYPOINTs at the mission's altitude (above home, or above the ground)."""
    frame = mission.altitude_reference.frame
    return [MissionItem(MavCmd.NAV_WAYPOINT, frame, lat, lon, mission.altitude_m) for lat, lon in waypoints]


def landing_items(mission: UavMission) -> list[MissionItem]:
    """How the mission ends: NAV_LAND at the airport (copter); the runway landing sequence, or
    RETURN_TO_LAUNCH for a plane without an approach (plan folders made before approaches)."""
    rel = MavFrame.GLOBAL_RELATIVE_ALT
    lat0, lon0 = mission.home_lat_deg, mission.home_lon_deg
    if mission.vehicle is Vehicle.COPTER:
        return [MissionItem(MavCmd.NAV_LAND, rel, lat0, lon0, 0.0)]
    a = mission.approach
    if a is None:
        return [MissionItem(MavCmd.NAV_RETURN_TO_LAUNCH, rel, 0.0, 0.0, 0.0)]
    return [MissionItem(MavCmd.DO_LAND_START, rel, lat0, lon0, 0.0),
            MissionItem(MavCmd.NAV_WAYPOINT, rel, a.lat_deg, a.lon_deg, a.alt_m),
            MissionItem(MavCmd.NAV_LAND, rel, lat0, lon0, 0.0)]
