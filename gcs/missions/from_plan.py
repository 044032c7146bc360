"""From a planned flight over an area to each UAV's mission: cell centres back to lat/lon,
straight runs merged, every leg checked against the safe region (area less no-fly zones)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gcs.missions.items import AltitudeReference, LandingApproach, UavMission, Vehicle
from planner.area_grid import AreaGrid
from planner.plan import UavPlan
from planner.waypoints import legs_inside, merge_waypoints, path_length_m, turn_points

#: Waypoints closer than this to the previous one are dropped (the airport point and its cell centre).
SAME_POINT_M = 0.5

#: Waypoint latitudes/longitudes are rounded to 1e-9 degree (0.1 mm), the same in every file.
COORD_DECIMALS = 9


@dataclass(frozen=True)
class FlownPath:
    """A mission's path in local metres: airport, kept waypoints, airport."""

    points_m: np.ndarray
    length_m: float


def mission_path_m(area: AreaGrid, uav: UavPlan, airport_m: tuple[float, float]) -> np.ndarray:
    """The flown path's points (local metres): the airport point, the trajectory's turn points
    (cell centres), the airport point; legs leaving the safe region get their intermediate cells back."""
    cells = np.array([(p.x, p.y) for p in uav.trajectory], dtype=np.int64)
    east, north = area.grid.centre_m(cells[:, 0], cells[:, 1])
    full = np.vstack([[airport_m], np.column_stack([east, north]), [airport_m]])
    keep = np.concatenate([[0], turn_points(cells) + 1, [len(full) - 1]])
    kept = full[merge_waypoints(full, area.legs_m, keep)]
    out = [kept[0]]
    for p in kept[1:]:
        if np.hypot(*(p - out[-1])) >= SAME_POINT_M:
            out.append(p)
    if np.hypot(*(out[-1] - kept[-1])) > 0:
        out[-1] = kept[-1]
    return np.array(out)


@dataclass(frozen=True)
class ApproachOptions:
    """A plane's landing approach: `distance_m` out along the runway axis (shortened down to
    `min_distance_m` where the area or a no-fly zone leaves no room), reached at `alt_m`, or lower
    where that would make the glide steeper than `max_glide_deg` (PX4 refuses a mission whose
    glide is steeper than its FW_LND_ANG, 5 degrees by default)."""

    distance_m: float = 500.0
    alt_m: float = 30.0
    min_distance_m: float = 250.0
    max_glide_deg: float = 5.0

    def alt_for(self, distance_m: float) -> float:
        """The approach altitude over `distance_m` of glide: `alt_m`, lowered (to a tenth of a
        metre) where it would be steeper than `max_glide_deg` as PX4 rounds it (to 0.1 degree)."""
        if round(math.degrees(math.atan2(self.alt_m, distance_m)), 1) <= self.max_glide_deg:
            return self.alt_m
        return math.floor(distance_m * math.tan(math.radians(self.max_glide_deg)) * 10.0) / 10.0


def landing_approach(area: AreaGrid, airport_m: tuple[float, float], heading_deg: float, last_m: np.ndarray,
                     options: ApproachOptions, label: str = "the airport") -> tuple[np.ndarray, bool]:
    """The approach point (local metres) behind the airport on its runway axis, for a plane that
    lands in the direction `heading_deg`; and whether the plane must first pass over the airport
    (the leg from its last waypoint straight to the approach point is not safe). ValueError when
    no approach of at least `min_distance_m` stays inside the area and out of no-fly zones."""
    back = np.array([-math.sin(math.radians(heading_deg)), -math.cos(math.radians(heading_deg))])
    airport = np.asarray(airport_m, dtype=float)
    distance = options.distance_m
    while distance >= options.min_distance_m - 1e-9:
        approach = airport + distance * back
        if legs_inside(np.array([airport, approach, airport]), area.legs_m).all():
            direct = bool(legs_inside(np.array([last_m, approach]), area.legs_m).all())
            return approach, not direct
        distance -= 50.0
    raise ValueError(f"{label}: no room for a landing approach of {options.min_distance_m:.0f} m or more along "
                     f"heading {heading_deg:.0f} degrees inside the area (use --approach-m, or give the airport "
                     "another heading)")


def uav_mission(area: AreaGrid, uav: UavPlan, name: str, vehicle: Vehicle, home_lat_lon: tuple[float, float],
                altitude_m: float, *, home_amsl_m: float = 0.0,
                altitude_reference: AltitudeReference = AltitudeReference.HOME,
                approach: ApproachOptions | None = None) -> tuple[UavMission, FlownPath]:
    """The mission of one planned UAV; ValueError if the plan is not closed or a leg is unsafe.
    A plane lands along its airport's heading (the UAV's start heading) after an approach."""
    if not uav.closed:
        raise ValueError(f"UAV {uav.uav_id}: the plan does not end at its airport")
    lat0, lon0 = home_lat_lon
    airport_m = area.point_m(lon0, lat0)
    points = mission_path_m(area, uav, airport_m)
    if not legs_inside(points, area.legs_m).all():
        raise ValueError(f"UAV {uav.uav_id}: a mission leg leaves the area or enters a no-fly zone")
    inner = points[1:-1]
    landing = None
    if vehicle is Vehicle.PLANE:
        options = approach or ApproachOptions()
        last = inner[-1] if len(inner) else np.asarray(airport_m, dtype=float)
        point, over_airport = landing_approach(area, airport_m, uav.start_heading * 45.0, last, options,
                                               f"UAV {uav.uav_id}")
        if over_airport:
            inner = np.vstack([inner, [airport_m]])
        alat, alon = area.frame.local2geodetic(point[0], point[1])
        landing = LandingApproach(round(float(alat), COORD_DECIMALS), round(float(alon), COORD_DECIMALS),
                                  options.alt_for(float(np.hypot(*(point - np.asarray(airport_m))))))
        points = np.vstack([points if over_airport else points[:-1], [point], points[-1:]])
    lat, lon = area.frame.local2geodetic(inner[:, 0], inner[:, 1])
    waypoints = [(round(float(a), COORD_DECIMALS), round(float(b), COORD_DECIMALS))
                 for a, b in zip(np.atleast_1d(lat), np.atleast_1d(lon))]
    mission = UavMission(uav.uav_id, name, vehicle, lat0, lon0, altitude_m, waypoints, home_amsl_m, altitude_reference,
                         landing)
    return mission, FlownPath(points, path_length_m(points))
