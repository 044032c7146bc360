"""A plane's landing approach: the point on the runway axis behind its airport where the final
glide starts, and the ground around it the plane's geofence must leave open.

The approach and the legs to and from it may leave the searched area (a runway at the edge of a
meadow is landed on from outside it); they must stay clear of the no-fly zones and the area's
holes, grown by the planner's margin (`AreaGrid.keep_out_m`). The search waypoints stay inside
the area (`gcs.missions.from_plan`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from shapely.geometry import LineString, MultiPolygon, Polygon

from planner.area_grid import AreaGrid
from planner.waypoints import legs_clear

#: Corners of the landing corridor closer than this to the line through their neighbours are dropped.
CORNER_TOLERANCE_M = 0.5

#: How much shorter each try at a clear approach is, from `ApproachOptions.distance_m` down.
SHORTEN_STEP_M = 50.0


@dataclass(frozen=True)
class ApproachOptions:
    """A plane's landing approach: `distance_m` out along the runway axis (shortened down to
    `min_distance_m` where a no-fly zone leaves no room), reached at `alt_m`, or lower where that
    would make the glide steeper than `max_glide_deg` (PX4 refuses a mission whose glide is
    steeper than its FW_LND_ANG, 5 degrees by default). The geofence leaves `corridor_m` of room
    around the approach's legs for the turn onto the runway axis."""

    distance_m: float = 500.0
    alt_m: float = 30.0
    min_distance_m: float = 250.0
    max_glide_deg: float = 5.0
    corridor_m: float = 150.0

    def alt_for(self, distance_m: float) -> float:
        """The approach altitude over `distance_m` of glide: `alt_m`, lowered (to a tenth of a
        metre) where it would be steeper than `max_glide_deg` as PX4 rounds it (to 0.1 degree)."""
        if round(math.degrees(math.atan2(self.alt_m, distance_m)), 1) <= self.max_glide_deg:
            return self.alt_m
        return math.floor(distance_m * math.tan(math.radians(self.max_glide_deg)) * 10.0) / 10.0


@dataclass(frozen=True)
class Approach:
    """Where a plane lands from, in local metres: `point_m`, `distance_m` behind `airport_m` on
    the runway axis. The plane flies to it from `entry_m`: its last waypoint, or the airport when
    that leg is not clear (`over_airport`: it first flies back over the airport)."""

    airport_m: tuple[float, float]
    point_m: tuple[float, float]
    distance_m: float
    entry_m: tuple[float, float]
    over_airport: bool

    @property
    def circuit_m(self) -> float:
        """The landing circuit: out to the approach point and back to the airport. What a plane
        flies beyond its way back to the airport is at most this (the leg from its last waypoint
        straight to the approach point is no longer than the one through the airport)."""
        return 2.0 * self.distance_m

    def corridor(self, half_width_m: float, *also_m: tuple[float, float]) -> Polygon:
        """The ground the landing may use: the convex hull of the legs to the approach point
        from the airport, from the entry point and from each of `also_m` (where a return leg
        flown in flight ends: the airport's cell centre), each grown by `half_width_m` with square
        ends (room for the turn onto the runway axis), nearly collinear corners (0.5 m) dropped."""
        legs = [LineString([start, self.point_m]) for start in (self.airport_m, self.entry_m, *also_m)]
        hull = MultiPolygon([leg.buffer(half_width_m, cap_style="square") for leg in legs]).convex_hull
        return hull.simplify(CORNER_TOLERANCE_M)


def landing_approach(area: AreaGrid, airport_m: tuple[float, float], heading_deg: float, last_m: np.ndarray,
                     options: ApproachOptions, label: str = "the airport") -> Approach:
    """The approach of a plane that lands in the direction `heading_deg` and comes from its last
    waypoint `last_m`: the longest of `distance_m`, `distance_m` - 50, ... down to
    `min_distance_m` whose leg to the airport is clear of `area.keep_out_m` (inside the area or
    out of it), flown to straight from `last_m` when that leg is clear too, else over the
    airport. ValueError, one line, when none is clear."""
    back = np.array([-math.sin(math.radians(heading_deg)), -math.cos(math.radians(heading_deg))])
    airport = np.asarray(airport_m, dtype=float)
    last = np.asarray(last_m, dtype=float)
    distance = options.distance_m
    while distance >= options.min_distance_m - 1e-9:
        point = airport + distance * back
        if legs_clear(np.array([airport, point]), area.keep_out_m).all():
            direct = bool(legs_clear(np.array([last, point]), area.keep_out_m).all())
            entry = last if direct else airport
            return Approach((float(airport[0]), float(airport[1])), (float(point[0]), float(point[1])), distance,
                            (float(entry[0]), float(entry[1])), not direct)
        distance -= SHORTEN_STEP_M
    margin = f" (and their {area.margin_m:g} m margin)" if area.margin_m > 0 else ""
    raise ValueError(f"{label}: no landing approach of {options.min_distance_m:.0f} m or more along heading "
                     f"{heading_deg:.0f} degrees is clear of the no-fly zones{margin} and the area's holes (give the "
                     "airport another heading or move it, or shorten the approach with --approach-m)")
