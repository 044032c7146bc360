"""Compile every numba kernel into its on-disk cache (`planner.config.CACHE`) before the first
plan needs it: short closed searches of the paper scenario with every strategy and return
planner, in the paper's unit steps and in metres with the horizon value and the improvement (what
`gcs plan --area` flies, its best responses also in tubes), and a few evaluations of the bound's Lagrangian dual
(`planner.bound.scenario_dual`) reach every kernel with the argument types a plan gives it. A fresh install's first plan
then loads the kernels instead of spending some 25 s compiling them (`tools/setup` runs this).
Kernels compiled before any planner source changed are dropped first (`drop_stale_kernels`).

`python -m planner.precompile`"""

from __future__ import annotations

import hashlib
from dataclasses import replace
from pathlib import Path

from planner.area_grid import AREA_MOVE_COSTS
from planner.best_response import ResponseSettings
from planner.bound import scenario_dual
from planner.dtscs import ClosedSearch, MissionConfig
from planner.horizon import HorizonValue
from planner.improve import ImproveSettings
from planner.scenario import Scenario, paper_scenario
from planner.search import STRATEGIES

#: long enough for a search stage, a return stage and a landing on every UAV of the paper scenario
RANGE_STEPS = 12


def _in_metres(scenario: Scenario) -> Scenario:
    """`scenario` with its moves costed as `gcs plan --area` costs them (`AREA_MOVE_COSTS`)."""
    unit = AREA_MOVE_COSTS.cheapest
    uavs = [replace(u, range_units=u.range_units * unit) for u in scenario.uavs]
    return replace(scenario, uavs=uavs, move_costs=AREA_MOVE_COSTS)


PLANNER = Path(__file__).resolve().parent

#: Where the planner's sources' digest is kept when its kernels are compiled (beside the caches).
STAMP = Path("__pycache__") / "kernel-sources.sha256"


def sources_digest(root: Path = PLANNER) -> str:
    """SHA-256 of every source file under `root`, names and contents."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def drop_stale_kernels(root: Path = PLANNER) -> int:
    """Remove the compiled kernels under `root` unless they were compiled from its sources as
    they are (the digest `stamp_sources` left): numba checks a cached kernel against its own
    file only, so a kernel whose callee in another file changed (pio's flocks calling reward's
    scoring) would load the old code. The number of cache files removed."""
    stamp = root / STAMP
    if stamp.exists() and stamp.read_text().strip() == sources_digest(root):
        return 0
    stale = [p for pattern in ("*.nbi", "*.nbc") for p in root.rglob(f"__pycache__/{pattern}")]
    for path in stale:
        path.unlink(missing_ok=True)
    return len(stale)


def stamp_sources(root: Path = PLANNER) -> None:
    """Record that the kernels under `root` are compiled from its sources as they are."""
    (root / STAMP).parent.mkdir(exist_ok=True)
    (root / STAMP).write_text(sources_digest(root) + "\n")


def precompile(seed: int = 0) -> None:
    """Fly the short searches that reach every kernel (`planner.config.njit` compiles each on
    its first call and writes it to the cache)."""
    steps = paper_scenario(seed, RANGE_STEPS)
    metres = _in_metres(steps)
    searches = [(steps, MissionConfig(strategy=name)) for name in sorted(STRATEGIES)]
    searches += [(steps, MissionConfig(return_planner="st")),
                 (metres, MissionConfig(strategy="cpio", horizon=HorizonValue(), improve=ImproveSettings())),
                 (metres, MissionConfig(strategy="cpio", horizon=HorizonValue(),  # the best responses in tubes
                                        improve=ImproveSettings(response=ResponseSettings(states=1)))),
                 (metres, MissionConfig(strategy="cpio", horizon=HorizonValue(), return_planner="st"))]
    for scenario, config in searches:
        search = ClosedSearch(scenario, config, seed=seed)
        for _ in search.run():
            pass
        search.plan()
    scenario_dual(metres, MissionConfig().oc, time_limit_s=60.0, max_iterations=2)


if __name__ == "__main__":
    drop_stale_kernels()
    precompile()
    stamp_sources()
