"""A search area in metres: the local frame, the grid, the free-cell mask and the scenario.

Inputs are shapely geometries in WGS84 lon/lat (x = longitude, y = latitude, as in GeoJSON);
everything here is pure computation on them."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from planner.environment import SearchMap, Sensor
from planner.georef import Grid, LocalFrame
from planner.motion import MoveCosts, cell_lengths
from planner.rasterise import block_unsafe_moves, cells_inside, free_cells
from planner.scenario import Scenario, UavSpec

#: Largest grid `build_area_grid` accepts by default: 1000 x 1000 cells. The exact return table
#: alone is 8 * cells int32 per UAV (32 MB per UAV at this size).
MAX_CELLS = 1_000_000

#: What a step over a real area charges against the range: its length, in thousandths of a cell
#: side (`planner.motion.cell_lengths`), so a range in metres is spent as the flown path spends it.
AREA_MOVE_COSTS = cell_lengths()

#: Legs are checked against the safe region grown by this much: 1 cm, far below any flight
#: accuracy, absorbs the projection round-off of shapes drawn exactly on cell edges (a diagonal
#: through a no-fly corner would otherwise "cut" it by micrometres).
LEG_TOLERANCE_M = 0.01


@dataclass(frozen=True)
class AreaGrid:
    """The area laid on a grid: geometries in local metres and the free-cell mask. `safe_m` is
    the area less the no-fly zones (after the margin); `legs_m` is it grown by LEG_TOLERANCE_M,
    the region every search leg must stay in. `keep_out_m` is what no leg may enter, inside the
    area or outside it (a plane's landing approach may leave the area): the no-fly zones and the
    area's holes grown by the margin, shrunk by LEG_TOLERANCE_M."""

    frame: LocalFrame
    grid: Grid
    area_m: BaseGeometry
    no_fly_m: BaseGeometry
    safe_m: BaseGeometry
    legs_m: BaseGeometry
    keep_out_m: BaseGeometry
    free: np.ndarray
    edge_blocked: int
    margin_m: float = 0.0

    def to_local(self, geometry: BaseGeometry) -> BaseGeometry:
        return shapely.transform(geometry, self.frame.lonlat2local_coords)

    def to_lonlat(self, geometry: BaseGeometry) -> BaseGeometry:
        return shapely.transform(geometry, self.frame.local2lonlat_coords)

    def point_m(self, lon_deg: float, lat_deg: float) -> tuple[float, float]:
        east, north = self.frame.geodetic2local(lat_deg, lon_deg)
        return float(east), float(north)

    def cells_lonlat(self, cells: np.ndarray) -> np.ndarray:
        """(n, 2) cells -> (n, 2) rows of (lat_deg, lon_deg) of their centres."""
        cells = np.asarray(cells).reshape(-1, 2)
        lat, lon = self.frame.local2geodetic(*self.grid.centre_m(cells[:, 0], cells[:, 1]))
        return np.column_stack([lat, lon])


def local_frame_for(area_lonlat: BaseGeometry) -> LocalFrame:
    """The frame centred on the area's bounding-box centre (a plain lon/lat centre is enough:
    the projection is exact at any origin inside the area)."""
    min_lon, min_lat, max_lon, max_lat = area_lonlat.bounds
    return LocalFrame(0.5 * (min_lat + max_lat), 0.5 * (min_lon + max_lon))


def build_area_grid(area_lonlat: BaseGeometry, no_fly_lonlat: list[BaseGeometry], cell_size_m: float,
                    margin_m: float = 0.0, max_cells: int = MAX_CELLS) -> AreaGrid:
    """Project the area and no-fly zones, lay the grid, and mark the free cells.

    `margin_m` shrinks the area and grows every no-fly zone before rasterising (a safety buffer
    for position error). ValueError when the grid would exceed `max_cells` or no cell is free."""
    frame = local_frame_for(area_lonlat)
    area_m = shapely.transform(area_lonlat, frame.lonlat2local_coords)
    no_fly_m = unary_union([shapely.transform(g, frame.lonlat2local_coords) for g in no_fly_lonlat]) \
        if no_fly_lonlat else shapely.Polygon()
    grid = Grid.covering(area_m.bounds, cell_size_m)
    if grid.cells > max_cells:
        fitting = cell_size_m * math.sqrt(grid.cells / max_cells)
        raise ValueError(f"cell size {cell_size_m:g} m makes a {grid.nx}x{grid.ny} grid ({grid.cells} cells), "
                         f"more than the maximum of {max_cells}; use a cell size of at least {math.ceil(fitting)} m")
    if margin_m < 0 or not math.isfinite(margin_m):
        raise ValueError(f"margin must be >= 0 metres, got {margin_m}")
    inner = area_m.buffer(-margin_m) if margin_m > 0 else area_m
    keep_out = no_fly_m.buffer(margin_m) if margin_m > 0 and not no_fly_m.is_empty else no_fly_m
    safe_m = inner.difference(keep_out) if not keep_out.is_empty else inner
    legs_m = safe_m.buffer(LEG_TOLERANCE_M)
    holes = unary_union([shapely.Polygon(ring) for part in shapely.get_parts(area_m) for ring in part.interiors])
    keep_out_m = unary_union([keep_out, holes.buffer(margin_m) if margin_m > 0 else holes]).buffer(-LEG_TOLERANCE_M)
    free, edge_blocked = block_unsafe_moves(free_cells(safe_m, grid), legs_m, grid)
    if not free.any():
        raise ValueError(f"no cell centre lies inside the area and outside the no-fly zones at cell size "
                         f"{cell_size_m:g} m; use a smaller cell size")
    return AreaGrid(frame, grid, area_m, no_fly_m, safe_m, legs_m, keep_out_m, free, edge_blocked, margin_m)


def range_units(range_m: float, cell_size_m: float, costs: MoveCosts = AREA_MOVE_COSTS) -> int:
    """A range in metres in the move-cost units of `costs` (rounded down: never more than given)."""
    return int(math.floor(range_m / cell_size_m * costs.straight + 1e-9))


def units_m(units: float, cell_size_m: float, costs: MoveCosts = AREA_MOVE_COSTS) -> float:
    """Move-cost units in metres."""
    return units * cell_size_m / costs.straight


#: How far (in cells, on each axis) from the cell holding an airport a UAV may be given its own
#: cell when the nearer ones are blocked or taken by UAVs launched from the same point.
AIRPORT_REACH_CELLS = 2


def airport_cell(area: AreaGrid, east_m: float, north_m: float, label: str,
                 taken: frozenset[tuple[int, int]] | set[tuple[int, int]] = frozenset()) -> tuple[int, int]:
    """The free cell an airport flies from: the cell holding it, or else the free cell with the
    nearest centre within AIRPORT_REACH_CELLS of it (the straight leg from the airport to the
    chosen centre must be safe either way). Cells in `taken` (those of UAVs already launched from
    this or another airport) are skipped: several UAVs may launch from one point, each from its
    own cell, so no two share a cell at step 0. An airport on the area's edge is inside it (to
    within LEG_TOLERANCE_M, the round-off of a point drawn on the edge).

    ValueError when the airport is outside the area, in a no-fly zone, or has no such cell."""
    point = Point(east_m, north_m)
    if area.area_m.distance(point) > LEG_TOLERANCE_M:
        raise ValueError(f"{label} is outside the area")
    if not area.no_fly_m.is_empty and area.no_fly_m.covers(point):
        raise ValueError(f"{label} is inside a no-fly zone")
    if not area.legs_m.covers(point):
        raise ValueError(f"{label} is within the {area.margin_m:g} m safety margin of the area edge or a no-fly zone")
    g = area.grid  # an airport on the grid's edge belongs to the edge cell
    x0 = min(max(math.floor((east_m - g.east0_m) / g.cell_size_m), 0), g.nx - 1)
    y0 = min(max(math.floor((north_m - g.north0_m) / g.cell_size_m), 0), g.ny - 1)
    options = []
    reach = range(-AIRPORT_REACH_CELLS, AIRPORT_REACH_CELLS + 1)
    for dx in reach:
        for dy in reach:
            x, y = x0 + dx, y0 + dy
            if 0 <= x < area.grid.nx and 0 <= y < area.grid.ny and area.free[x, y] and (x, y) not in taken:
                if max(abs(dx), abs(dy)) > 1 and not taken:
                    continue
                ce, cn = area.grid.centre_m(x, y)
                leg = shapely.LineString([(east_m, north_m), (float(ce), float(cn))])
                if area.legs_m.covers(leg):
                    options.append(((dx, dy) != (0, 0), math.hypot(ce - east_m, cn - north_m), x, y))
    if not options:
        if taken:
            raise ValueError(f"{label}: no free cell within {AIRPORT_REACH_CELLS} cells of cell ({x0 + 1}, {y0 + 1}) "
                             f"is left for it (the UAVs launched there before it took them); move the airport or "
                             f"use a smaller cell size")
        raise ValueError(f"{label} is in cell ({x0 + 1}, {y0 + 1}), which the grid blocks (its centre is outside "
                         f"the area or too close to an edge), and no neighbouring cell is reachable; move the "
                         f"airport inward or use a smaller cell size")
    *_, x, y = min(options)
    return x, y


@dataclass(frozen=True)
class PriorCells:
    """A prior region in local metres with its TEP and EU."""

    geometry_m: BaseGeometry
    tep: float
    eu: float


def area_search_map(area: AreaGrid, priors: list[PriorCells], default_tep: float, default_eu: float,
                    base: np.ndarray | None = None) -> SearchMap:
    """TEP/EU maps: the defaults (or `base`, a mass prior's TEP, for both), then each prior region
    in order (later regions win where they overlap); cells not free are blocked (the planner's
    no-fly mask)."""
    tep = np.full(area.grid.shape, float(default_tep)) if base is None else np.array(base, dtype=np.float64)
    eu = np.full(area.grid.shape, float(default_eu)) if base is None else np.array(base, dtype=np.float64)
    for prior in priors:
        inside = cells_inside(prior.geometry_m, area.grid)
        tep[inside] = prior.tep
        eu[inside] = prior.eu
    return SearchMap(tep, eu, ~area.free)


def area_scenario(name: str, area: AreaGrid, priors: list[PriorCells], uavs: list[UavSpec],
                  targets_m: list[tuple[float, float]], default_tep: float, default_eu: float,
                  sensor: Sensor, base: np.ndarray | None = None) -> Scenario:
    """The planner scenario of an area; targets are local points (placed in their cell). UAV
    ranges are in `AREA_MOVE_COSTS` units (`range_units`); `base` as in `area_search_map`."""
    targets = [area.grid.cell_of(e, n) for e, n in targets_m]
    return Scenario(name, area_search_map(area, priors, default_tep, default_eu, base), uavs,
                    np.array(targets, dtype=np.int64).reshape(-1, 2), sensor, move_costs=AREA_MOVE_COSTS,
                    unit_m=units_m(1, area.grid.cell_size_m))
