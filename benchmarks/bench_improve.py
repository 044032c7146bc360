"""The whole-mission improvement (`planner.improve`, issue 37): expected finds and planning time of
today's default (CPIO + horizon value), the improved default (the same, then `planner.improve`)
and exhaustive + horizon value, with each one's share of the upper bound (`planner.bound`).

    .venv/bin/python benchmarks/bench_improve.py [--paper-seeds 5] [--areas 20] [--bound-time 20]
                                                 [--no-large] [--no-bound] [--smoke] [--copters]

Rows: the paper scenario (Section 6.1, range 130, `--paper-seeds` seeds), each `missions/*.geojson`
as `gcs plan --area` plans it (seed 0) and `--areas` seeded random areas (`benchmarks/areas.py`,
seeds 0..areas-1). Times are CPU seconds of the planner in this process (the machine is shared:
wall time would measure the others' load), DTSCS and improvement together. Per row: mean expected
finds, the improved default's gain over today's, on how many cases it is >= 5 % above today's and
>= exhaustive + horizon, and the mean share of the bound (the bound once per scenario, LP or MIP
within `--bound-time` s; `-` when it was not had).

`--copters`: every UAV of the examples and the random areas flown by the stock ArduCopter
(`gcs.plans.vehicle_file`), its path priced by its time (`planner.time_pricing`), as `gcs plan
--area` plans a copter: DTSCS's plan (CPIO + horizon value), the improvement pricing metres only
(as before the time pricing) and pricing the copter's time. Per row: mean expected finds and the
gains over DTSCS, the UAVs whose path through its cells' centres takes longer (`path_time_s`, as
the flight's energy account prices it) than the charge its range was sized with pays for, the
mean of those seconds over the charge's, and the median CPU seconds of each improvement."""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.areas import mission_scenario, random_area  # noqa: E402
from planner.dtscs import MissionConfig, fly  # noqa: E402
from planner.horizon import HorizonValue  # noqa: E402
from planner.improve import ImproveSettings  # noqa: E402
from planner.path_time import path_time_s  # noqa: E402
from planner.plan import Plan  # noqa: E402
from planner.scenario import Scenario, paper_scenario  # noqa: E402
from planner.time_pricing import time_pricing  # noqa: E402

OPTIONS = {"today": MissionConfig(strategy="cpio", horizon=HorizonValue()),
           "improved": MissionConfig(strategy="cpio", horizon=HorizonValue(), improve=ImproveSettings()),
           "exhaustive + horizon": MissionConfig(strategy="exhaustive", horizon=HorizonValue())}


@dataclass
class Row:
    name: str
    expected: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in OPTIONS})
    seconds: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in OPTIONS})
    shares: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in OPTIONS})

    def add(self, scenario: Scenario, seed: int, bound: float | None) -> None:
        for key, config in OPTIONS.items():
            start = time.process_time()
            plan = fly(scenario, config, seed=seed)
            self.seconds[key].append(time.process_time() - start)
            self.expected[key].append(plan.success.expected)
            if bound is not None and bound > 0:
                self.shares[key].append(plan.success.expected / bound)
        e = {k: v[-1] for k, v in self.expected.items()}
        print(f"    {self.name} seed {seed}: " + ", ".join(f"{k} {v:.2f}" for k, v in e.items()),
              file=sys.stderr, flush=True)

    def line(self) -> str:
        today, improved, exhaustive = (np.array(self.expected[k]) for k in OPTIONS)
        n = len(today)
        cells = [self.name, str(n)]
        for key in OPTIONS:
            cells.append(f"{np.mean(self.expected[key]):.2f}")
        cells.append(f"{np.mean(improved / today - 1):+.1%}")
        cells.append(f"{int(np.sum(improved >= 1.05 * today))}/{n}")
        cells.append(f"{int(np.sum(improved >= exhaustive))}/{n}")
        for key in OPTIONS:
            cells.append(f"{statistics.median(self.seconds[key]):.2f}")
        for key in OPTIONS:
            cells.append(f"{np.mean(self.shares[key]):.1%}" if self.shares[key] else "-")
        return "| " + " | ".join(cells) + " |"


HEADER = ("| scenario | cases | E today | E improved | E exhaustive + horizon | improved vs today | "
          ">= +5 % | >= exhaustive | CPU s today | CPU s improved | CPU s exhaustive | bound share today | "
          "bound share improved | bound share exhaustive |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
          "---:|---:|---:|")


def _bound(scenario: Scenario, seconds: float) -> float | None:
    if seconds <= 0:
        return None
    from planner.bound import success_bound

    b = success_bound(scenario, time_limit_s=seconds)
    print(f"    bound {scenario.name}: {b.value:.2f} ({b.model.value}, b = {b.block}, {b.seconds:.1f} s)",
          file=sys.stderr, flush=True)
    return b.value if b.finished else None


@dataclass
class CopterRow:
    """One row of the copters' table (`--copters`)."""

    name: str
    expected: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in COPTER_PLANS})
    seconds: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in COPTER_PLANS})
    over: dict[str, list[float]] = field(default_factory=lambda: {k: [] for k in COPTER_PLANS})  # path s / charge s

    def add(self, scenario: Scenario, seed: int) -> None:
        from gcs.plans.vehicle_file import stock_profile

        profile = stock_profile("ardupilot", "copter")
        assert scenario.unit_m is not None and profile.cornering is not None and profile.moving_mah_per_s is not None
        cell_m = scenario.unit_m * scenario.move_costs.straight
        pricing = time_pricing(profile, cell_m, scenario.move_costs)
        priced = replace(scenario, uavs=[replace(u, time_pricing=pricing) for u in scenario.uavs])
        for key, (plan_scenario, config) in {"DTSCS": (priced, COPTER_PLANS["DTSCS"]),
                                             "improved, metres": (replace(scenario, uavs=[
                                                 replace(u, time_pricing=None) for u in scenario.uavs]),
                                                 COPTER_PLANS["improved, metres"]),
                                             "improved, time": (priced, COPTER_PLANS["improved, time"])}.items():
            start = time.process_time()
            plan: Plan = fly(plan_scenario, config, seed=seed)
            self.seconds[key].append(time.process_time() - start)
            self.expected[key].append(plan.success.expected)
            for u in plan.uavs:
                points = [(p.x * cell_m, p.y * cell_m) for p in u.trajectory]
                flies_s = path_time_s(points, profile.cruise_speed_m_s, profile.cornering)
                pays_s = u.range_units * scenario.unit_m * profile.cruise_mah_per_m / profile.moving_mah_per_s
                self.over[key].append(flies_s / pays_s)
        e = {k: v[-1] for k, v in self.expected.items()}
        print(f"    {self.name} seed {seed}: " + ", ".join(f"{k} {v:.2f}" for k, v in e.items()),
              file=sys.stderr, flush=True)

    def line(self) -> str:
        dtscs, metres, timed = (np.array(self.expected[k]) for k in COPTER_PLANS)
        cells = [self.name, str(len(dtscs)), str(len(self.over["DTSCS"]))]
        cells += [f"{np.mean(v):.2f}" for v in (dtscs, metres, timed)]
        cells += [f"{np.mean(metres / dtscs - 1):+.1%}", f"{np.mean(timed / dtscs - 1):+.1%}"]
        for key in COPTER_PLANS:
            ratios = np.array(self.over[key])
            cells.append(f"{int(np.sum(ratios > 1.0))} ({np.mean(ratios):.3f})")
        cells += [f"{statistics.median(self.seconds[k]):.2f}" for k in ("improved, metres", "improved, time")]
        return "| " + " | ".join(cells) + " |"


COPTER_PLANS = {"DTSCS": MissionConfig(strategy="cpio", horizon=HorizonValue()),
                "improved, metres": OPTIONS["improved"],
                "improved, time": OPTIONS["improved"]}

COPTER_HEADER = ("| scenario | cases | UAVs | E DTSCS | E improved, metres | E improved, time | metres vs DTSCS | "
                 "time vs DTSCS | UAVs over their charge (mean path s / charge s): DTSCS | improved, metres | "
                 "improved, time | CPU s improved, metres | CPU s improved, time |\n"
                 "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def copters(args: argparse.Namespace) -> None:
    """The copters' table (`--copters`): the examples (seed 0) and `--areas` random areas."""
    fly(paper_scenario(0, 30), OPTIONS["improved"], seed=0)  # JIT warm-up
    print(COPTER_HEADER)
    if not args.smoke:
        for name in sorted(p.stem for p in (ROOT / "missions").glob("*.geojson")):
            if name == "large" and args.no_large:
                continue
            row = CopterRow(f"missions/{name}.geojson")
            row.add(mission_scenario(name), 0)
            print(row.line(), flush=True)
    row = CopterRow(f"{args.areas} random areas")
    for seed in range(args.areas):
        row.add(random_area(seed), seed)
    print(row.line(), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--paper-seeds", type=int, default=5)
    parser.add_argument("--areas", type=int, default=20)
    parser.add_argument("--bound-time", type=float, default=20.0)
    parser.add_argument("--no-bound", action="store_true")
    parser.add_argument("--no-large", action="store_true", help="leave out missions/large.geojson")
    parser.add_argument("--smoke", action="store_true", help="one paper seed, one random area, no missions, no bound")
    parser.add_argument("--copters", action="store_true",
                        help="every UAV a stock ArduCopter, its path priced by its time: the improvement pricing "
                             "metres against pricing time (no paper scenario, no bound)")
    args = parser.parse_args()
    if args.smoke:
        args.paper_seeds, args.areas, args.no_bound = 1, 1, True
    if args.copters:
        copters(args)
        return
    seconds = 0.0 if args.no_bound else args.bound_time

    fly(paper_scenario(0, 30), OPTIONS["improved"], seed=0)  # JIT warm-up
    print(HEADER)
    row = Row(f"paper scenario ({args.paper_seeds} seeds)")
    bound = _bound(paper_scenario(0, 130), seconds)
    for seed in range(args.paper_seeds):
        row.add(paper_scenario(seed, 130), seed, bound)
    print(row.line(), flush=True)
    if not args.smoke:
        names = sorted(p.stem for p in (ROOT / "missions").glob("*.geojson"))
        for name in names:
            if name == "large" and args.no_large:
                continue
            scenario = mission_scenario(name)
            row = Row(f"missions/{name}.geojson")
            row.add(scenario, 0, _bound(scenario, seconds))
            print(row.line(), flush=True)
    row = Row(f"{args.areas} random areas")
    for seed in range(args.areas):
        scenario = random_area(seed)
        row.add(scenario, seed, _bound(scenario, seconds))
    print(row.line(), flush=True)


if __name__ == "__main__":
    main()
