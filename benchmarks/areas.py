"""Seeded random search areas for the benchmarks: an irregular area with no-fly zones, prior
regions and 2-4 airports, built with the same area builders as `gcs plan --area` (projection,
rasterising, airport cells, ranges in metres), and the example areas of `missions/` as scenarios.

    from benchmarks.areas import random_area, mission_scenario
    scenario = random_area(3)                       # a planner Scenario, 10 targets drawn from the prior
    scenario = mission_scenario("irregular")        # what gcs plan --area missions/irregular.geojson plans"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from planner.area_grid import (  # noqa: E402
    AREA_MOVE_COSTS,
    PriorCells,
    airport_cell,
    area_scenario,
    build_area_grid,
    local_frame_for,
    range_units,
)
from planner.environment import Sensor  # noqa: E402
from planner.georef import LocalFrame  # noqa: E402
from planner.motion import OC3  # noqa: E402
from planner.return_exact import return_table  # noqa: E402
from planner.scenario import Scenario, UavSpec  # noqa: E402

CELL_M = 25.0
TARGETS = 10


def _blob(rng: np.random.Generator, cx: float, cy: float, radius: float, vertices: int, wobble: float) -> Polygon:
    """A star-shaped polygon around (cx, cy): radius times 1 +- wobble at each vertex."""
    angles = np.sort(rng.uniform(0, 2 * math.pi, vertices))
    radii = radius * (1 + rng.uniform(-wobble, wobble, vertices))
    return Polygon(np.column_stack([cx + radii * np.cos(angles), cy + radii * np.sin(angles)]))


def _rectangle(rng: np.random.Generator, cx: float, cy: float, length: float, width: float) -> Polygon:
    a = rng.uniform(0, math.pi)
    ux, uy, vx, vy = math.cos(a), math.sin(a), -math.sin(a), math.cos(a)
    return Polygon([(cx + sx * length / 2 * ux + sy * width / 2 * vx, cy + sx * length / 2 * uy + sy * width / 2 * vy)
                    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def random_area(seed: int, sensor: Sensor | None = None) -> Scenario:
    """Area `seed`: 40-70 cells of 25 m across, an irregular outline, 1-3 no-fly zones, 1-3 prior
    regions (TEP 0.6-0.95) over a background of TEP 0.05-0.5, 2-4 airports with ranges of 1-2.2
    times the area's width, and 10 targets drawn from the prior (a cell with probability
    proportional to its TEP). Redraws until every airport can leave and come back under 3OC."""
    rng = np.random.default_rng(seed)
    while True:
        scenario = _draw(rng, seed, sensor or Sensor())
        if scenario is not None:
            return scenario


def _draw(rng: np.random.Generator, seed: int, sensor: Sensor) -> Scenario | None:
    size = rng.uniform(40, 70) * CELL_M
    half = size / 2
    outline = _blob(rng, 0.0, 0.0, half * 0.95, int(rng.integers(8, 16)), 0.2)
    frame = LocalFrame(-35.0 + rng.uniform(-1, 1), 149.0 + rng.uniform(-1, 1))

    def lonlat(geometry):
        return shapely.transform(geometry, frame.local2lonlat_coords)

    def inside_point(margin: float) -> tuple[float, float]:
        for _ in range(1000):
            x, y = rng.uniform(-half, half, 2)
            if outline.buffer(-margin).contains(Point(x, y)):
                return float(x), float(y)
        raise RuntimeError("no point inside the outline")

    no_fly = []
    for _ in range(int(rng.integers(1, 4))):
        cx, cy = inside_point(0.1 * size)
        if rng.random() < 0.5:
            no_fly.append(_rectangle(rng, cx, cy, rng.uniform(0.1, 0.3) * size, rng.uniform(0.05, 0.12) * size))
        else:
            no_fly.append(_blob(rng, cx, cy, rng.uniform(0.04, 0.1) * size, 10, 0.2))
    priors = []
    for _ in range(int(rng.integers(1, 4))):
        cx, cy = inside_point(0.05 * size)
        shape = (_blob(rng, cx, cy, rng.uniform(0.06, 0.15) * size, 12, 0.3) if rng.random() < 0.6 else
                 _rectangle(rng, cx, cy, rng.uniform(0.2, 0.5) * size, rng.uniform(0.05, 0.12) * size))
        tep = float(rng.uniform(0.6, 0.95))
        priors.append((shape, tep, float(min(1.0, tep * rng.uniform(0.7, 1.0)))))
    default_tep = float(rng.uniform(0.05, 0.5))
    default_eu = float(rng.uniform(0.1, 0.5))
    area = build_area_grid(lonlat(outline), [lonlat(z) for z in no_fly], CELL_M)
    frame = local_frame_for(lonlat(outline))

    def to_local(geometry):
        return shapely.transform(lonlat(geometry), frame.lonlat2local_coords)

    uavs = []
    taken: set[tuple[int, int]] = set()
    for i in range(int(rng.integers(2, 5))):
        east, north = (float(v) for v in to_local(Point(*inside_point(0.02 * size))).coords[0])
        try:
            cell = airport_cell(area, east, north, f"airport {i + 1}")
        except ValueError:
            return None
        if cell in taken:
            return None
        taken.add(cell)
        range_m = rng.uniform(1.0, 2.2) * size * math.sqrt(2)
        units = range_units(range_m, CELL_M)
        heading = int(rng.integers(8))
        table = return_table(~area.free, cell, OC3, AREA_MOVE_COSTS)
        if not _can_leave(table, cell, heading, units, ~area.free):
            return None
        uavs.append(UavSpec(i + 1, cell, heading, units))
    prior_cells = [PriorCells(to_local(shape), tep, eu) for shape, tep, eu in priors]
    scenario = area_scenario(f"random {seed}", area, prior_cells, uavs, [], default_tep, default_eu, sensor)
    free = np.argwhere(~scenario.search_map.no_fly)
    weights = scenario.search_map.tep[free[:, 0], free[:, 1]]
    picks = rng.choice(len(free), size=TARGETS, replace=False, p=weights / weights.sum())
    scenario.targets = free[picks].astype(np.int64)
    return scenario


def _can_leave(table: np.ndarray, cell: tuple[int, int], heading: int, units: int, blocked: np.ndarray) -> bool:
    from planner.dtscs import first_step_feasible

    return first_step_feasible(table, OC3.successors, blocked, (cell[0], cell[1], heading), 0, units,
                               AREA_MOVE_COSTS)


def mission_scenario(name: str) -> Scenario:
    """The scenario `gcs plan --area missions/<name>.geojson` plans (its default options)."""
    from gcs.plans.planning import build_area_search

    return build_area_search(ROOT / "missions" / f"{name}.geojson").search.scenario
