"""Probability of success (`planner.success`) and planning time per search option, with an upper
bound from a solver (`planner.bound`, HiGHS).

    .venv/bin/python benchmarks/bench_success.py [--paper-seeds 100] [--areas 20] [--mission-seeds 3]
                                                 [--bound-time 20] [--no-bound] [--no-large]

Options compared, all with DTSCS, Np = 5, 3OC, exact return, the one-cell sensor (Pc 0.9):
paper CPIO (Table 1), CPIO with the horizon value (`planner.horizon`, default settings),
exhaustive choice with and without it, the lawnmower, and the bound (no plan: the most any closed
plan of the same airports and ranges can expect to find).

1. The paper scenario (Section 6.1, range 130) over `--paper-seeds` seeds (targets and sensor
   noise from the seed; the prior, so the bound, is the same for all).
2. The areas of missions/ as `gcs plan --area` plans them, `--mission-seeds` seeds each.
3. `--areas` seeded random areas (`benchmarks/areas.py`: 40-70 cells across, no-fly zones,
   1-3 prior regions, 2-4 airports, 10 targets drawn from the prior), one run each.

Columns: expected targets found (E) and its share of the area's expected total, simulated
targets found (of those placed), planning time of the whole mission (median, seconds); for the
random areas also on how many areas the horizon value beat the same strategy without it."""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.areas import mission_scenario, random_area  # noqa: E402
from planner.dtscs import MissionConfig, fly  # noqa: E402
from planner.horizon import HorizonValue  # noqa: E402
from planner.scenario import Scenario, paper_scenario  # noqa: E402

OPTIONS = (("paper CPIO", "cpio", None), ("CPIO + horizon", "cpio", HorizonValue()),
           ("exhaustive", "exhaustive", None), ("exhaustive + horizon", "exhaustive", HorizonValue()),
           ("lawnmower", "lawnmower", None))


@dataclass
class Tally:
    expected: list[float] = field(default_factory=list)
    share: list[float] = field(default_factory=list)
    found: list[int] = field(default_factory=list)
    targets: list[int] = field(default_factory=list)
    seconds: list[float] = field(default_factory=list)

    def add(self, scenario: Scenario, strategy: str, horizon: HorizonValue | None, seed: int) -> float:
        start = time.perf_counter()
        plan = fly(scenario, MissionConfig(strategy=strategy, horizon=horizon), seed=seed)
        self.seconds.append(time.perf_counter() - start)
        self.expected.append(plan.success.expected)
        self.share.append(plan.success.share)
        self.found.append(plan.targets_found)
        self.targets.append(len(plan.targets))
        return plan.success.share

    def row(self, name: str, option: str) -> str:
        n = len(self.found)
        found = "-"
        if sum(self.targets):
            se = np.std(self.found) / np.sqrt(n) if n > 1 else 0.0
            found = f"{np.mean(self.found):.2f} ± {se:.2f} of {np.mean(self.targets):.0f}"
        return (f"| {name} | {option} | {np.mean(self.expected):.1f} | {np.mean(self.share):.1%} | {found} | "
                f"{statistics.median(self.seconds):.2f} |")


def bound_row(name: str, scenarios: list[Scenario], seconds: float) -> str:
    from planner.bound import success_bound

    values, shares, times = [], [], []
    for scenario in scenarios:
        b = success_bound(scenario, time_limit_s=seconds)
        m = scenario.search_map
        available = float(m.tep[~m.no_fly].sum())
        values.append(b.value)
        shares.append(b.value / available)
        times.append(b.seconds)
        print(f"    bound {scenario.name}: {b.value:.1f} (LP {b.lp:.1f}, MIP dual {b.mip_dual:.1f}, b = {b.block}, "
              f"{b.columns} columns, {b.seconds:.0f} s)", file=sys.stderr, flush=True)
    return (f"| {name} | upper bound (LP / MIP, HiGHS) | {np.mean(values):.1f} | {np.mean(shares):.1%} | - | "
            f"{statistics.median(times):.1f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--paper-seeds", type=int, default=100)
    parser.add_argument("--areas", type=int, default=20)
    parser.add_argument("--mission-seeds", type=int, default=3)
    parser.add_argument("--bound-time", type=float, default=20.0, help="seconds for the MIP per bound")
    parser.add_argument("--no-bound", action="store_true")
    parser.add_argument("--no-large", action="store_true", help="leave out missions/large.geojson")
    args = parser.parse_args()

    fly(paper_scenario(0, 40), MissionConfig(strategy="cpio", horizon=HorizonValue()), seed=0)   # JIT warm-up
    print("| scenario | option | E[found] | share | simulated targets found | plan s |")
    print("|---|---|---:|---:|---:|---:|")

    papers = [paper_scenario(seed, 130) for seed in range(args.paper_seeds)]
    for option, strategy, horizon in OPTIONS:
        tally = Tally()
        for seed, scenario in enumerate(papers):
            tally.add(scenario, strategy, horizon, seed)
        print(tally.row(f"paper ({args.paper_seeds} seeds)", option), flush=True)
    if not args.no_bound:
        print(bound_row("paper", papers[:1], args.bound_time), flush=True)

    names = ["paper", "irregular"] + ([] if args.no_large else ["large"])
    for name in names:
        scenario = mission_scenario(name)
        for option, strategy, horizon in OPTIONS:
            tally = Tally()
            for seed in range(args.mission_seeds):
                tally.add(scenario, strategy, horizon, seed)
            print(tally.row(f"missions/{name}.geojson", option), flush=True)
        if not args.no_bound:
            print(bound_row(f"missions/{name}.geojson", [scenario], args.bound_time), flush=True)

    areas = [random_area(seed) for seed in range(args.areas)]
    shares: dict[str, list[float]] = {}
    for option, strategy, horizon in OPTIONS:
        tally = Tally()
        for seed, scenario in enumerate(areas):
            tally.add(scenario, strategy, horizon, seed)
        shares[option] = tally.share
        print(tally.row(f"{args.areas} random areas", option), flush=True)
    if not args.no_bound:
        print(bound_row(f"{args.areas} random areas", areas, args.bound_time), flush=True)
    for base, better in (("paper CPIO", "CPIO + horizon"), ("exhaustive", "exhaustive + horizon")):
        a, b = np.array(shares[base]), np.array(shares[better])
        print(f"\n{better} vs {base} on the random areas: higher share on {int((b > a).sum())} of {len(a)}, "
              f"lower on {int((b < a).sum())}; mean share {a.mean():.2%} -> {b.mean():.2%}")


if __name__ == "__main__":
    main()
