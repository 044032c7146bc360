"""Environment model of Section 2.1: target existence probability (TEP), environmental
uncertainty (EU), no-fly mask, the airborne sensor and its Bayesian map updates.

Arrays are indexed [x, y] (x east, y north, 0-based)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.config import njit


@dataclass(frozen=True)
class Sensor:
    """Downward sensor: detection probability `pc`, false-alarm rate `pf`, and a square
    footprint of `footprint_radius` cells around the vehicle's cell (0 = the cell only)."""

    pc: float = 0.9
    pf: float = 0.1
    footprint_radius: int = 0

    def __post_init__(self) -> None:
        if not (0.0 <= self.pf < self.pc <= 1.0):
            raise ValueError(f"sensor needs 0 <= pf < pc <= 1, got pc={self.pc}, pf={self.pf}")
        if self.footprint_radius < 0:
            raise ValueError("sensor footprint radius must be >= 0")


@dataclass
class SearchMap:
    """The shared probability map: TEP `tep`, EU `eu`, visit counts and the no-fly mask."""

    tep: np.ndarray
    eu: np.ndarray
    no_fly: np.ndarray

    def __post_init__(self) -> None:
        self.tep = np.ascontiguousarray(self.tep, dtype=np.float64)
        self.eu = np.ascontiguousarray(self.eu, dtype=np.float64)
        self.no_fly = np.ascontiguousarray(self.no_fly, dtype=np.bool_)
        if not (self.tep.shape == self.eu.shape == self.no_fly.shape) or self.tep.ndim != 2:
            raise ValueError("tep, eu and no_fly must be 2-D arrays of one shape")
        if self.tep.min(initial=0) < 0 or self.tep.max(initial=0) > 1:
            raise ValueError("tep must lie in [0, 1]")
        if self.eu.min(initial=0) < 0 or self.eu.max(initial=0) > 1:
            raise ValueError("eu must lie in [0, 1]")
        self.visits = np.zeros(self.tep.shape, dtype=np.int64)

    @property
    def shape(self) -> tuple[int, int]:
        nx, ny = self.tep.shape
        return nx, ny

    def copy(self) -> SearchMap:
        out = SearchMap(self.tep.copy(), self.eu.copy(), self.no_fly.copy())
        out.visits = self.visits.copy()
        return out

    def observe(self, x: int, y: int, reported: bool, pc: float, pf: float) -> None:
        """Fold one reading of cell (x, y) into the map: eq. (2) after a report, eq. (3) after
        none, eq. (4) for the EU, and one more visit. The planner in the loop and a flight's
        posterior (`gcs.flight.sortie`) both update through here.

        A reading the model rules out (a report where P = 0 and Pf = 0, none where P = 1 and
        Pc = 1: the Bayes denominator is 0) leaves the TEP as it is; the EU still halves."""
        p = self.tep[x, y]
        if reported and (pc - pf) * p + pf > 0:
            self.tep[x, y] = tep_after_report(p, pc, pf)
        elif not reported and (pf - pc) * p + 1.0 - pf > 0:
            self.tep[x, y] = tep_after_no_report(p, pc, pf)
        self.eu[x, y] = eu_after_visit(self.eu[x, y])
        self.visits[x, y] += 1


@njit
def tep_after_report(p: float, pc: float, pf: float) -> float:
    """Eq. (2): TEP after the sensor reported a target, P Pc / ((Pc - Pf) P + Pf).

    With Pc > Pf a report never lowers the belief; the result is kept in [P, 1], which rounding
    can leave at the edge (P = 1 gave 1.0000000000000002 with some Pc, Pf)."""
    return min(max(p * pc / ((pc - pf) * p + pf), p), 1.0)


@njit
def tep_after_no_report(p: float, pc: float, pf: float) -> float:
    """Eq. (3): TEP after the sensor reported nothing, P (1 - Pc) / ((Pf - Pc) P + 1 - Pf).

    With Pc > Pf a look that sees nothing never raises the belief; the result is kept in [0, P],
    which rounding can leave at the edge (P = 1, Pc = 0.875, Pf = 0.4885 gave 1.0000000000000004
    after one look and 1.0000000000000018 after two)."""
    return min(max(p * (1.0 - pc) / ((pf - pc) * p + 1.0 - pf), 0.0), p)


@njit
def eu_after_visit(chi: float) -> float:
    """Eq. (4) for one visit: each visit halves the EU, so after Nf visits chi = chi0 / 2^Nf."""
    return 0.5 * chi


@njit
def _sense(tep: np.ndarray, eu: np.ndarray, visits: np.ndarray, target_grid: np.ndarray, cells: np.ndarray,
           draws: np.ndarray, radius: int, pc: float, pf: float, reports: np.ndarray) -> int:
    """Update the map for every observed cell of `cells` (k x 2) and record its report.

    `draws` holds one uniform number per observed cell, in the same order, so a caller and a
    reference implementation see the same randomness. `target_grid[x, y]` counts targets."""
    nx, ny = tep.shape
    n = 0
    for i in range(cells.shape[0]):
        cx = cells[i, 0]
        cy = cells[i, 1]
        for x in range(cx - radius, cx + radius + 1):
            for y in range(cy - radius, cy + radius + 1):
                if x < 0 or y < 0 or x >= nx or y >= ny:
                    continue
                present = target_grid[x, y] > 0
                reported = draws[n] < (pc if present else pf)
                reports[n, 0] = x
                reports[n, 1] = y
                reports[n, 2] = 1 if reported else 0
                reports[n, 3] = 1 if present else 0
                if reported:
                    tep[x, y] = tep_after_report(tep[x, y], pc, pf)
                else:
                    tep[x, y] = tep_after_no_report(tep[x, y], pc, pf)
                eu[x, y] = eu_after_visit(eu[x, y])
                visits[x, y] += 1
                n += 1
    return n


def footprint_cells(x: int, y: int, radius: int, shape: tuple[int, int]) -> list[tuple[int, int]]:
    """The in-grid cells one reading from cell (x, y) covers, in the order `sense` takes its draws."""
    nx, ny = shape
    return [(cx, cy) for cx in range(x - radius, x + radius + 1) for cy in range(y - radius, y + radius + 1)
            if 0 <= cx < nx and 0 <= cy < ny]


def sense(search_map: SearchMap, target_grid: np.ndarray, cells: np.ndarray, sensor: Sensor,
          draws: np.ndarray) -> np.ndarray:
    """Observe `cells` (k x 2, one per vehicle), update the map in place and return the reports
    as rows (x, y, reported, target_present). `draws` holds one uniform number per in-grid
    footprint cell, in `footprint_cells` order."""
    cells = np.ascontiguousarray(cells, dtype=np.int64).reshape(-1, 2)
    draws = np.ascontiguousarray(draws, dtype=np.float64)
    observed = sum(len(footprint_cells(x, y, sensor.footprint_radius, search_map.shape)) for x, y in cells)
    if observed != len(draws):
        raise ValueError(f"{len(draws)} draws for {observed} observed cells")
    reports = np.zeros((len(draws), 4), dtype=np.int64)
    n = _sense(search_map.tep, search_map.eu, search_map.visits, target_grid, cells, draws,
               sensor.footprint_radius, sensor.pc, sensor.pf, reports)
    return reports[:n]
