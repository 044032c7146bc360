"""From a planned flight over an area to each UAV's mission: cell centres back to lat/lon,
straight runs merged, every search leg checked against the safe region (area less no-fly zones);
a plane's landing approach (`gcs.missions.approach`) may leave the area, clear of no-fly zones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from gcs.missions.approach import Approach, ApproachOptions, landing_approach
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
    """A mission's path in local metres: airport, kept waypoints, (a plane's approach point,)
    airport; for a plane its `approach` and the `corridor_m` its landing may use, which its
    geofence must include."""

    points_m: np.ndarray
    length_m: float
    approach: Approach | None = None
    corridor_m: Polygon | None = None


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


def uav_mission(area: AreaGrid, uav: UavPlan, name: str, vehicle: Vehicle, home_lat_lon: tuple[float, float],
                altitude_m: float, *, home_amsl_m: float = 0.0,
                altitude_reference: AltitudeReference = AltitudeReference.HOME,
                approach: ApproachOptions | None = None) -> tuple[UavMission, FlownPath]:
    """The mission of one planned UAV; ValueError if the plan is not closed or a leg is unsafe.
    A plane lands along its airport's heading (the UAV's start heading) after an approach
    (`landing_approach`), which may lie outside the area."""
    if not uav.closed:
        raise ValueError(f"UAV {uav.uav_id}: the plan does not end at its airport")
    lat0, lon0 = home_lat_lon
    airport_m = area.point_m(lon0, lat0)
    points = mission_path_m(area, uav, airport_m)
    if not legs_inside(points, area.legs_m).all():
        raise ValueError(f"UAV {uav.uav_id}: a mission leg leaves the area or enters a no-fly zone")
    inner = points[1:-1]
    landing: LandingApproach | None = None
    landed: Approach | None = None
    corridor: Polygon | None = None
    if vehicle is Vehicle.PLANE:
        options = approach or ApproachOptions()
        last = inner[-1] if len(inner) else np.asarray(airport_m, dtype=float)
        landed = landing_approach(area, airport_m, uav.start_heading * 45.0, last, options, f"UAV {uav.uav_id}")
        if landed.over_airport:
            inner = np.vstack([inner, [airport_m]])
        point = np.asarray(landed.point_m)
        alat, alon = area.frame.local2geodetic(point[0], point[1])
        landing = LandingApproach(round(float(alat), COORD_DECIMALS), round(float(alon), COORD_DECIMALS),
                                  options.alt_for(landed.distance_m))
        points = np.vstack([points if landed.over_airport else points[:-1], [point], points[-1:]])
        cell_e, cell_n = area.grid.centre_m(uav.trajectory[0].x, uav.trajectory[0].y)  # where a flown return ends
        corridor = landed.corridor(options.corridor_m, (float(cell_e), float(cell_n)))
    lat, lon = area.frame.local2geodetic(inner[:, 0], inner[:, 1])
    waypoints = [(round(float(a), COORD_DECIMALS), round(float(b), COORD_DECIMALS))
                 for a, b in zip(np.atleast_1d(lat), np.atleast_1d(lon))]
    mission = UavMission(uav.uav_id, name, vehicle, lat0, lon0, altitude_m, waypoints, home_amsl_m, altitude_reference,
                         landing)
    return mission, FlownPath(points, path_length_m(points), landed, corridor)
