"""Search scenarios: the grid, its priors, the UAVs with their airports and ranges, the targets.

`paper_scenario` is the reference case of Section 6.1; coordinates in its table are the paper's
1-based cell numbers, stored here 0-based."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from planner.environment import SearchMap, Sensor
from planner.motion import STEPS, MoveCosts

if TYPE_CHECKING:
    from planner.time_pricing import TimePricing


@dataclass(frozen=True)
class UavSpec:
    """One UAV: its airport cell (0-based x, y), start heading (0..7) and range T_i in the
    scenario's move-cost units (`Scenario.move_costs`: steps in the paper, thousandths of a cell
    side over a real area). `time_pricing`: a multicopter whose energy profile prices a path by
    its time (`planner.time_pricing`); the whole-mission improvement keeps its path within that
    budget too. None: its range is spent in metres (move costs) only."""

    uav_id: int
    airport: tuple[int, int]
    heading: int
    range_units: int
    time_pricing: TimePricing | None = None


@dataclass
class Scenario:
    """Everything the planner needs to fly a closed search.

    A later sortie of a campaign (`planner.campaign`) searches a `search_map` that is the belief
    the earlier sorties left; `p0` is then the campaign's first prior TEP and `looks_before` the
    earlier sorties' readings per cell, and the probability of success counts against them
    (`planner.success`). Both None: the search map is the prior, nothing was read before.
    `targets` are an exercise's true targets still missing; `found_before` (x, y, sortie) those
    earlier sorties found, out of this sortie's simulation."""

    name: str
    search_map: SearchMap
    uavs: list[UavSpec]
    targets: np.ndarray
    sensor: Sensor = field(default_factory=Sensor)
    p0: np.ndarray | None = None
    looks_before: np.ndarray | None = None
    move_costs: MoveCosts = STEPS
    unit_m: float | None = None
    found_before: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))

    def __post_init__(self) -> None:
        self.targets = np.asarray(self.targets, dtype=np.int64).reshape(-1, 2)
        self.found_before = np.asarray(self.found_before, dtype=np.int64).reshape(-1, 3)
        nx, ny = self.search_map.shape
        for name in ("p0", "looks_before"):
            value = getattr(self, name)
            if value is not None and np.shape(value) != (nx, ny):
                raise ValueError(f"{name} must be a {nx}x{ny} grid, got shape {np.shape(value)}")
        seen: set[tuple[int, int]] = set()
        for uav in self.uavs:
            x, y = uav.airport
            if not (0 <= x < nx and 0 <= y < ny):
                raise ValueError(f"UAV {uav.uav_id}: airport ({x + 1}, {y + 1}) is outside the {nx}x{ny} grid")
            if self.search_map.no_fly[x, y]:
                raise ValueError(f"UAV {uav.uav_id}: airport ({x + 1}, {y + 1}) is in a no-fly cell")
            if (x, y) in seen:
                raise ValueError(f"UAV {uav.uav_id}: airport ({x + 1}, {y + 1}) is shared with another UAV")
            if not 0 <= uav.heading < 8:
                raise ValueError(f"UAV {uav.uav_id}: heading must be 0..7, got {uav.heading}")
            if uav.range_units < self.move_costs.cheapest:
                raise ValueError(f"UAV {uav.uav_id}: range must be at least 1 step")
            seen.add((x, y))
        if len({u.uav_id for u in self.uavs}) != len(self.uavs):
            raise ValueError("UAV ids must be unique")
        for tx, ty in self.targets:
            if not (0 <= tx < nx and 0 <= ty < ny):
                raise ValueError(f"target ({tx + 1}, {ty + 1}) is outside the grid")

    @property
    def success_prior(self) -> np.ndarray:
        """P0 of the probability of success: the campaign's first prior, else the search map."""
        return self.search_map.tep if self.p0 is None else self.p0

    def target_grid(self) -> np.ndarray:
        grid = np.zeros(self.search_map.shape, dtype=np.int64)
        for tx, ty in self.targets:
            grid[tx, ty] += 1
        return grid


def _box(x0: int, x1: int, y0: int, y1: int) -> tuple[slice, slice]:
    """The paper's inclusive 1-based box x0<=x<=x1, y0<=y<=y1 as 0-based slices."""
    return slice(x0 - 1, x1), slice(y0 - 1, y1)


PAPER_SIZE = 50
PAPER_UAVS = ((1, 20, 2), (20, 50, 4), (27, 1, 0), (50, 26, 6))
PAPER_NO_FLY = ((5, 20, 30, 40), (30, 40, 5, 15))
PAPER_KNOWN = (30, 45, 20, 28)
PAPER_KEY = ((5, 24, 10, 25), (25, 45, 30, 35))
PAPER_TARGETS_PER_KEY_REGION = 5


def paper_scenario(seed: int = 0, range_steps: int = 130, sensor: Sensor | None = None) -> Scenario:
    """Section 6.1: 50x50 cells, four UAVs, two no-fly zones, a known region and two key
    regions holding 5 random targets each (drawn from `seed`, on distinct cells)."""
    tep = np.full((PAPER_SIZE, PAPER_SIZE), 0.5)
    eu = np.full((PAPER_SIZE, PAPER_SIZE), 0.5)
    no_fly = np.zeros((PAPER_SIZE, PAPER_SIZE), dtype=bool)
    tep[_box(*PAPER_KNOWN)] = 0.0
    eu[_box(*PAPER_KNOWN)] = 0.0
    rng = np.random.default_rng(seed)
    targets = []
    for box in PAPER_KEY:
        sx, sy = _box(*box)
        tep[sx, sy] = 0.9
        eu[sx, sy] = 0.9
        xs = np.arange(sx.start, sx.stop)
        ys = np.arange(sy.start, sy.stop)
        flat = rng.choice(len(xs) * len(ys), size=PAPER_TARGETS_PER_KEY_REGION, replace=False)
        targets += [(int(xs[i // len(ys)]), int(ys[i % len(ys)])) for i in flat]
    for box in PAPER_NO_FLY:
        no_fly[_box(*box)] = True
    uavs = [UavSpec(i + 1, (x - 1, y - 1), h, range_steps) for i, (x, y, h) in enumerate(PAPER_UAVS)]
    return Scenario("paper", SearchMap(tep, eu, no_fly), uavs, np.array(targets), sensor or Sensor())


SCENARIOS = {"paper": paper_scenario}
