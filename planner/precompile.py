"""Compile every numba kernel into its on-disk cache (`planner.config.CACHE`) before the first
plan needs it: short closed searches of the paper scenario with every strategy and return
planner, in the paper's unit steps and in metres with the horizon value (what `gcs plan --area`
flies), reach every kernel with the argument types a plan gives it. A fresh install's first plan
then loads the kernels instead of spending some 25 s compiling them (`tools/setup` runs this).

`python -m planner.precompile`"""

from __future__ import annotations

from dataclasses import replace

from planner.area_grid import AREA_MOVE_COSTS
from planner.dtscs import ClosedSearch, MissionConfig
from planner.horizon import HorizonValue
from planner.scenario import Scenario, paper_scenario
from planner.search import STRATEGIES

#: long enough for a search stage, a return stage and a landing on every UAV of the paper scenario
RANGE_STEPS = 12


def _in_metres(scenario: Scenario) -> Scenario:
    """`scenario` with its moves costed as `gcs plan --area` costs them (`AREA_MOVE_COSTS`)."""
    unit = AREA_MOVE_COSTS.cheapest
    uavs = [replace(u, range_units=u.range_units * unit) for u in scenario.uavs]
    return replace(scenario, uavs=uavs, move_costs=AREA_MOVE_COSTS)


def precompile(seed: int = 0) -> None:
    """Fly the short searches that reach every kernel (`planner.config.njit` compiles each on
    its first call and writes it to the cache)."""
    steps = paper_scenario(seed, RANGE_STEPS)
    metres = _in_metres(steps)
    searches = [(steps, MissionConfig(strategy=name)) for name in sorted(STRATEGIES)]
    searches += [(steps, MissionConfig(return_planner="st")),
                 (metres, MissionConfig(strategy="cpio", horizon=HorizonValue())),
                 (metres, MissionConfig(strategy="cpio", horizon=HorizonValue(), return_planner="st"))]
    for scenario, config in searches:
        for _ in ClosedSearch(scenario, config, seed=seed).run():
            pass


if __name__ == "__main__":
    precompile()
