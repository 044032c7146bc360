"""A downward-looking detector: one noisy reading per grid cell the vehicle flies over.

The grid is shared by the fleet (square cells of `cell_size_m` in the fleet's local frame), so
cell (i, j) means the same ground for every vehicle. Entering a cell while airborne yields one
observation: a target in the cell is reported with probability Pc, an empty cell is reported
(a false alarm) with probability Pf. The draws come from a seeded generator, so runs repeat.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

from sim.geo import LocalFrame


@dataclass(frozen=True, slots=True, kw_only=True)
class SensorConfig:
    cell_size_m: float = 20.0
    pc: float = 0.9
    pf: float = 0.05
    min_alt_m: float = 2.0


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
        targets_en: frozenset[tuple[int, int]],
        rng: random.Random,
    ) -> None:
        self.config = config
        self.frame = frame
        self._target_cells = targets_en
        self._rng = rng
        self._last_cell: tuple[int, int] | None = None
        self.observations: list[Observation] = []

    @staticmethod
    def cells_of(targets: list[tuple[float, float]], frame: LocalFrame, cell_size_m: float) -> frozenset[tuple[int, int]]:
        """Grid cells holding the given (lat, lon) targets."""
        return frozenset(_cell(*frame.geodetic2en(lat, lon), cell_size_m) for lat, lon in targets)

    def cell_center(self, cell: tuple[int, int]) -> tuple[float, float]:
        size = self.config.cell_size_m
        return self.frame.en2geodetic((cell[0] + 0.5) * size, (cell[1] + 0.5) * size)

    def update(self, east_m: float, north_m: float, alt_m: float, time_s: float) -> Observation | None:
        """A new observation when the vehicle has just entered a cell, else None."""
        if alt_m < self.config.min_alt_m:
            self._last_cell = None
            return None
        cell = _cell(east_m, north_m, self.config.cell_size_m)
        if cell == self._last_cell:
            return None
        self._last_cell = cell
        present = cell in self._target_cells
        reported = self._rng.random() < (self.config.pc if present else self.config.pf)
        lat, lon = self.cell_center(cell)
        obs = Observation(len(self.observations), cell, lat, lon, reported, present, time_s)
        self.observations.append(obs)
        return obs


def _cell(east_m: float, north_m: float, size_m: float) -> tuple[int, int]:
    return (math.floor(east_m / size_m), math.floor(north_m / size_m))
