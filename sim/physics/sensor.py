"""A downward-looking detector: one noisy reading per grid cell the vehicle flies over.

The grid is shared by the fleet: square cells of `cell_size_m` counted from the fleet's grid
origin (its south-west corner, in the fleet's local frame), so cell (i, j) means the same ground
for every vehicle. A vehicle reads a cell once as it comes within `view_radius_cells` of the
cell's centre while airborne (0.5: over the circle inside the cell, so a diagonal that only
clips a neighbour's corner does not read it). A target in the cell is reported with probability
Pc, an empty cell (a false alarm) with Pf. The noise of each reading is
`planner.sensor_noise.reading_draw(seed, vehicle, cell, visit)`: the same world the planner
simulates on the same seed, and the same readings however the flight's timing falls.

The reading on the wire (CAMERA_IMAGE_CAPTURED) is `sim.autopilot.telemetry.reading_message`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from planner.georef import LocalFrame
from planner.sensor_noise import reading_draw


@dataclass(frozen=True, slots=True, kw_only=True)
class SensorConfig:
    """The grid cell side and the sensor's Pc and Pf, by default those `gcs plan` uses (the
    planner's `planner.environment.Sensor`, `gcs.plans.options.DEFAULT_CELL_SIZE_M`; a test
    keeps them equal)."""

    cell_size_m: float = 50.0
    pc: float = 0.9
    pf: float = 0.1
    min_alt_m: float = 2.0
    view_radius_cells: float = 0.5


@dataclass(frozen=True, slots=True)
class Observation:
    """One reading of one cell; `reported` is what the sensor says, `present` the truth."""

    index: int
    cell: tuple[int, int]
    lat_deg: float
    lon_deg: float
    reported: bool
    present: bool
    time_s: float


class DownwardSensor:
    def __init__(
        self,
        config: SensorConfig,
        frame: LocalFrame,
        targets: Iterable[tuple[float, float]],
        *,
        seed: int,
        vehicle_id: int,
        origin_en: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        self.config = config
        self.frame = frame
        self.origin_en = origin_en
        self.seed = seed
        self.vehicle_id = vehicle_id
        self._target_cells = frozenset(self.cell_of(*frame.geodetic2en(lat, lon)) for lat, lon in targets)
        self._last_cell: tuple[int, int] | None = None
        self._visits: dict[tuple[int, int], int] = {}
        self.observations: list[Observation] = []

    def cell_of(self, east_m: float, north_m: float) -> tuple[int, int]:
        size = self.config.cell_size_m
        return (math.floor((east_m - self.origin_en[0]) / size), math.floor((north_m - self.origin_en[1]) / size))

    def cell_center_en(self, cell: tuple[int, int]) -> tuple[float, float]:
        size = self.config.cell_size_m
        return (self.origin_en[0] + (cell[0] + 0.5) * size, self.origin_en[1] + (cell[1] + 0.5) * size)

    def update(self, east_m: float, north_m: float, alt_m: float, time_s: float) -> Observation | None:
        """A new observation when the vehicle has just come over a cell, else None."""
        if alt_m < self.config.min_alt_m:
            self._last_cell = None
            return None
        cell = self.cell_of(east_m, north_m)
        centre = self.cell_center_en(cell)
        view_radius_m = self.config.view_radius_cells * self.config.cell_size_m
        if cell == self._last_cell or math.dist(centre, (east_m, north_m)) > view_radius_m:
            return None
        self._last_cell = cell
        visit = self._visits.get(cell, 0)
        self._visits[cell] = visit + 1
        present = cell in self._target_cells
        reported = reading_draw(self.seed, self.vehicle_id, cell[0], cell[1], visit) < (
            self.config.pc if present else self.config.pf)
        lat, lon = self.frame.en2geodetic(*centre)
        obs = Observation(len(self.observations), cell, lat, lon, reported, present, time_s)
        self.observations.append(obs)
        return obs
