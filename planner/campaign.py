"""Campaigns: one search area flown in several closed sorties, each planned from what the
earlier ones left.

A `Belief` is what the campaign knows before a sortie: the TEP/EU map the planner searches
(after every earlier reading, eq. 2-4), the campaign's first prior P0 and the readings per cell
of every earlier sortie. The probability of success of a campaign is the paper's model over all
its looks (`planner.success`): E = sum P0 (1 - (1 - Pc)^n) with n every sortie's readings of the
cell, so a sortie's own E is what its looks add after the earlier ones, and the sorties' parts add
up to the campaign's.

Two ways to the next sortie's belief:

- a flown sortie folds its real readings in, positive or not (`SearchMap.observe`, the update
  online mode uses; `gcs.flight.sortie` does it during the flight);
- a sortie only planned is *predicted* by `predicted_after`: every look of the plan folded in as a
  reading without a report. That is the belief the crew holds when the sortie comes back with
  nothing, the case in which a next sortie is flown at all (search theory's posterior of an
  unsuccessful search). The expected posterior over the readings' outcomes would not do: the
  TEP is a martingale, its expectation after any look is the TEP before, so the next sortie would
  fly the same cells again. Neither would the plan's simulated readings: they are drawn against
  the scenario's true targets, which a real crew does not know.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from planner.environment import SearchMap, Sensor
from planner.plan import Plan
from planner.scenario import Scenario
from planner.success import expected_finds, plan_looks

__all__ = ["Belief", "SORTIE_SEED_STRIDE", "look_counts", "predicted_after", "sortie_seed"]

#: Sortie k of a campaign on seed s draws its optimiser and sensor noise from seed
#: s + (k - 1) * SORTIE_SEED_STRIDE: the noise of one UAV's reading of one cell is fixed by
#: (seed, UAV, cell, visit) (`planner.sensor_noise`), so without it a UAV re-reading a cell in a
#: later sortie would repeat the earlier miss or false alarm instead of drawing anew.
SORTIE_SEED_STRIDE = 1_000_003


def sortie_seed(seed: int, sortie: int) -> int:
    """The seed of sortie `sortie` (1-based) of a campaign on `seed`; sortie 1 keeps `seed`."""
    if sortie < 1:
        raise ValueError(f"sorties count from 1, got {sortie}")
    return seed + (sortie - 1) * SORTIE_SEED_STRIDE


@dataclass
class Belief:
    """The campaign's knowledge before (or during) a sortie.

    `search_map`: TEP, EU and no-fly now; its `visits` count the readings folded in since this
    belief started. `p0`: the campaign's first prior TEP. `looks_before`: readings per cell of
    the sorties before this belief started. `sortie`: the sortie this belief is for. `found`:
    (x, y, sortie) of the exercise's true targets earlier sorties found (the simulation's
    ground truth, not the belief: a later sortie's simulation leaves them out)."""

    search_map: SearchMap
    p0: np.ndarray
    looks_before: np.ndarray
    sortie: int = 1
    found: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))

    def __post_init__(self) -> None:
        shape = self.search_map.shape
        self.p0 = np.ascontiguousarray(self.p0, dtype=np.float64)
        self.looks_before = np.ascontiguousarray(self.looks_before, dtype=np.int64)
        self.found = np.asarray(self.found, dtype=np.int64).reshape(-1, 3)
        if self.p0.shape != shape or self.looks_before.shape != shape:
            raise ValueError(f"p0 and looks_before must be {shape[0]}x{shape[1]} grids like the map")
        if self.looks_before.min(initial=0) < 0:
            raise ValueError("looks must be >= 0")
        if self.sortie < 1:
            raise ValueError(f"sorties count from 1, got {self.sortie}")

    @classmethod
    def prior(cls, search_map: SearchMap) -> Belief:
        """The first sortie's belief: the prior map, nothing read."""
        return cls(search_map.copy(), search_map.tep.copy(), np.zeros(search_map.shape, dtype=np.int64))

    @property
    def looks(self) -> np.ndarray:
        """Readings per cell of the whole campaign so far."""
        return self.looks_before + self.search_map.visits

    @property
    def searchable(self) -> np.ndarray:
        return ~self.search_map.no_fly

    def available(self) -> float:
        """The targets P0 puts in the area (searchable cells)."""
        return float(self.p0[self.searchable].sum())

    def expected(self, pc: float) -> float:
        """The campaign's expected targets found by every reading so far."""
        return expected_finds(self.p0, self.searchable, pc, self.looks)

    def next_sortie(self) -> Belief:
        """The belief the next sortie starts from: this map, every reading so far counted before it."""
        m = self.search_map
        return Belief(SearchMap(m.tep.copy(), m.eu.copy(), m.no_fly.copy()), self.p0.copy(), self.looks.copy(),
                      self.sortie + 1, self.found.copy())

    def with_found(self, cells: list[tuple[int, int]]) -> Belief:
        """This belief, the targets at `cells` found by its sortie."""
        known = {(int(x), int(y)) for x, y, _ in self.found}
        new = [(x, y, self.sortie) for x, y in sorted(set(cells)) if (x, y) not in known]
        return replace(self, found=np.concatenate([self.found, np.array(new, dtype=np.int64).reshape(-1, 3)]))

    def scenario(self, scenario: Scenario) -> Scenario:
        """`scenario` (the same grid, UAVs and sensor) searching this belief."""
        if scenario.search_map.shape != self.search_map.shape:
            raise ValueError(f"the belief is a {self.search_map.shape[0]}x{self.search_map.shape[1]} grid, the "
                             f"scenario {scenario.search_map.shape[0]}x{scenario.search_map.shape[1]}")
        if not np.array_equal(scenario.search_map.no_fly, self.search_map.no_fly):
            raise ValueError("the belief's no-fly cells are not the scenario's")
        m = self.search_map
        found = {(int(x), int(y)) for x, y, _ in self.found}
        missing = [(int(x), int(y)) for x, y in scenario.targets if (int(x), int(y)) not in found]
        return replace(scenario, search_map=SearchMap(m.tep.copy(), m.eu.copy(), m.no_fly.copy()), p0=self.p0.copy(),
                       looks_before=self.looks.copy(), targets=np.array(missing, dtype=np.int64).reshape(-1, 2),
                       found_before=self.found.copy())


def _plan_looks(plan: Plan, footprint_radius: int) -> list[tuple[int, int, int, int]]:
    trajectories = {u.uav_id: [(p.step, p.x, p.y) for p in u.trajectory] for u in plan.uavs}
    return plan_looks(trajectories, footprint_radius, (plan.nx, plan.ny))


def look_counts(plan: Plan, footprint_radius: int) -> np.ndarray:
    """Readings per cell of a plan's trajectories (every cell flown and each airport at step 0,
    with the footprint), as `planner.success` counts them."""
    counts = np.zeros((plan.nx, plan.ny), dtype=np.int64)
    for _, _, x, y in _plan_looks(plan, footprint_radius):
        counts[x, y] += 1
    return counts


def predicted_after(belief: Belief, plan: Plan, sensor: Sensor) -> Belief:
    """The belief the next sortie starts from when `plan` (flown from `belief`) reports nothing:
    every look of the plan folded in as a reading without a report (eq. 3 and eq. 4); the targets
    its simulation found are out of the next sortie's."""
    flown = Belief(belief.search_map.copy(), belief.p0, belief.looks_before, belief.sortie, belief.found)
    for _, _, x, y in _plan_looks(plan, sensor.footprint_radius):
        flown.search_map.observe(x, y, False, sensor.pc, sensor.pf)
    return flown.with_found([(t.x, t.y) for t in plan.targets if t.found_step is not None]).next_sortie()
