"""Safety stress run: many closed plans on crowded random grids, each checked against the plan
invariants (in the grid, out of no-fly cells, OC, range, airports, no shared cell at a step).

Run: .venv/bin/python benchmarks/stress_safety.py [--seeds 400]"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the plan checker lives with the tests

from planner.dtscs import MissionConfig, fly
from planner.motion import OC3, OC4, OC8
from tests.planner.helpers import assert_plan_safe, random_scenario


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=400)
    args = parser.parse_args()
    for nx, ny in ((10, 9), (16, 14)):
        bad = total = 0
        for seed in tqdm(range(args.seeds), desc=f"{nx}x{ny}", leave=False):
            for oc in (OC3, OC4, OC8):
                scenario = random_scenario(seed, nx=nx, ny=ny, n_uavs=4, range_steps=40, oc=oc)
                if scenario is None:
                    continue
                for planner in ("exact", "st"):
                    total += 1
                    plan = fly(scenario, MissionConfig(np_steps=3, oc=oc, return_planner=planner), seed=seed)
                    try:
                        assert_plan_safe(plan, scenario, oc)
                    except AssertionError as exc:
                        bad += 1
                        print(f"seed {seed} {oc.name} {planner}: {exc}")
        print(f"{nx}x{ny} cells, 4 UAVs, 12% obstacles, range 40: {bad} unsafe of {total} plans")


if __name__ == "__main__":
    main()
