"""The upper bound on expected finds (`planner.bound`) against the plans `gcs plan` makes, and
how tight the bound is against the exact optimum on tiny areas.

    .venv/bin/python benchmarks/success_bound.py figures [--areas 5] [--time 60] [--no-large]
    .venv/bin/python benchmarks/success_bound.py gap [--instances 12] [--time 120] [--dual-time 5]
    .venv/bin/python benchmarks/success_bound.py figures --smoke     # (and gap --smoke): a tiny run

`figures`: the paper scenario (`gcs plan --scenario paper`: paper CPIO), the areas of missions/
and `--areas` seeded random areas (`benchmarks/areas.py`, as `gcs plan --area` plans them with
DTSCS: CPIO + horizon value, before any whole-mission improvement), each with that plan's
expected finds, the bound (the smaller of the LP
optimum and the MIP's dual bound in `--time` seconds, the tightest model of at most `--arcs`
flow arcs; where that is not the per-heading model and the Lagrangian dual of it fits the time,
the LP and then the dual in the time left instead of the MIP, the smaller of the two) and the
plan's share of it;
with the dual, the floor its master LP reached: the per-heading LP is at least that, so no bound
of that model can be tighter.

`gap`: `--instances` tiny random areas (8-12 cells across, 2-3 UAVs, ranges of 10-16 cell sides
in metres, 3OC), each with the DTSCS plan (CPIO + horizon value), the improved plan `gcs plan
--area` makes by default (the same, then `planner.improve`), the exact optimum (`planner.bound.exact_optimum`:
the per-(step, cell, heading) model solved by HiGHS to optimality, separation aside) and the
LP bound `gcs plan` reports (the tightest model that fits); the LP-to-optimum gap is LP / optimum
- 1. Also the LPs of the looser models (the OC dropped; 2 x 2 blocks) over the optimum, and the
Lagrangian dual of the per-heading model after `--dual-time` seconds over its LP and over the
optimum."""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from planner.bound import DEFAULT_MAX_ARCS, Bound, BoundModel, exact_optimum, success_bound  # noqa: E402
from planner.dtscs import MissionConfig, fly, uavs_that_cannot_leave  # noqa: E402
from planner.environment import SearchMap, Sensor  # noqa: E402
from planner.horizon import HorizonValue  # noqa: E402
from planner.improve import ImproveSettings  # noqa: E402
from planner.motion import OC3, cell_lengths  # noqa: E402
from planner.scenario import Scenario, UavSpec, paper_scenario  # noqa: E402

AREA_CONFIG = MissionConfig(strategy="cpio", horizon=HorizonValue())   # gcs plan --area's DTSCS
IMPROVED_CONFIG = replace(AREA_CONFIG, improve=ImproveSettings())       # gcs plan --area's default
PAPER_CONFIG = MissionConfig(strategy="cpio")                          # gcs plan --scenario paper's default


@dataclass(frozen=True)
class Row:
    name: str
    expected: float
    available: float
    bound: Bound
    plan_s: float

    def cells(self) -> str:
        b = self.bound
        share = "-" if b.share(self.expected) is None else f"{b.share(self.expected):.1%}"
        mip = "-" if not math.isfinite(b.mip_dual) else f"{b.mip_dual:.1f}"
        model = b.model.value + (f" b={b.block}" if b.block > 1 else "")
        lp = "-" if not math.isfinite(b.lp) else f"{b.lp:.1f}"
        gap = "-" if not math.isfinite(b.mip_gap) else f"{b.mip_gap:.1%}"
        dual = "-" if not math.isfinite(b.lagrangian) else f"{b.lagrangian:.1f} ({b.iterations})"
        floor = "-" if not math.isfinite(b.floor) else f"{b.floor:.1f}"
        return (f"| {self.name} | {self.expected:.1f} | {b.value:.1f} | **{share}** | {lp} | {mip} | "
                f"{gap} | {dual} | {floor} | {model} | {b.seconds:.0f} |")


HEADER = ("| scenario | DTSCS plan E[found] | bound | plan / bound | LP | MIP dual | MIP gap | Lagrangian (iterations) "
          "| headings LP >= | model | bound s |\n"
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|")


def row(name: str, scenario: Scenario, config: MissionConfig, seconds: float, arcs: int) -> Row:
    start = time.perf_counter()
    plan = fly(scenario, config, seed=0)
    plan_s = time.perf_counter() - start
    assert plan.success is not None
    bound = success_bound(scenario, config.oc, seconds, max_arcs=arcs, dual_iterations=10**6)   # the time given
    if bound.finished and plan.success.expected > bound.value + 1e-6:
        raise AssertionError(f"{name}: the plan expects {plan.success.expected} > the bound {bound.value}")
    return Row(name, plan.success.expected, plan.success.available, bound, plan_s)


def figures(args: argparse.Namespace) -> None:
    from benchmarks.areas import mission_scenario, random_area

    cases: list[tuple[str, Scenario, MissionConfig]] = []
    if args.smoke:
        cases.append(("paper, range 12", paper_scenario(0, 12), PAPER_CONFIG))
        cases.append(("tiny", tiny_instance(1), AREA_CONFIG))
    else:
        cases.append(("paper (`--scenario paper`)", paper_scenario(0, 130), PAPER_CONFIG))
        for path in sorted((ROOT / "missions").glob("*.geojson")):
            if not (args.no_large and path.stem == "large"):
                cases.append((f"missions/{path.name}", mission_scenario(path.stem), AREA_CONFIG))
        cases += [(f"random area {seed}", random_area(seed), AREA_CONFIG) for seed in range(args.areas)]
    print(HEADER)
    rows = []
    for name, scenario, config in cases:
        rows.append(row(name, scenario, config, args.time, args.arcs))
        print(rows[-1].cells(), flush=True)
    shares = [s for r in rows if (s := r.bound.share(r.expected)) is not None]
    if shares:
        print(f"\nplan / bound: mean {statistics.mean(shares):.1%}, lowest {min(shares):.1%} over {len(shares)}")


def tiny_instance(seed: int) -> Scenario:
    """A tiny random area: 8-12 cells across, 10 % no-fly cells, a random prior, 2-3 UAVs with
    ranges of 10-16 cell sides charged in metres (diagonals sqrt 2), all able to leave under 3OC."""
    rng = np.random.default_rng(seed)
    costs = cell_lengths()
    while True:
        n = int(rng.integers(8, 13))
        no_fly = rng.random((n, n)) < 0.1
        free = np.argwhere(~no_fly)
        picks = rng.choice(len(free), size=int(rng.integers(2, 4)), replace=False)
        uavs = [UavSpec(i + 1, (int(free[p][0]), int(free[p][1])), int(rng.integers(8)),
                        int(rng.integers(10, 17)) * costs.straight) for i, p in enumerate(picks)]
        scenario = Scenario(f"tiny {seed}", SearchMap(rng.random((n, n)), rng.random((n, n)), no_fly), uavs,
                            np.zeros((0, 2)), Sensor(0.9, 0.1), move_costs=costs, unit_m=1.0 / costs.straight)
        if not uavs_that_cannot_leave(scenario, AREA_CONFIG):
            return scenario


def gap(args: argparse.Namespace) -> None:
    count = 1 if args.smoke else args.instances
    print("| instance | cells | UAVs | ranges (cells) | DTSCS plan | improved plan | exact optimum | LP bound | "
          "LP / optimum | plan / optimum | improved / optimum | improved / LP | LP cells / optimum | "
          "LP blocks b=2 / optimum | Lagrangian / LP headings | "
          "Lagrangian / optimum | MIP s |\n"
          "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    gaps, plans, improved_plans, lp_shares, duals = [], [], [], [], []
    for seed in range(count):
        scenario = tiny_instance(seed)
        plan = fly(scenario, AREA_CONFIG, seed=seed)
        improved = fly(scenario, IMPROVED_CONFIG, seed=seed).success
        assert plan.success is not None and improved is not None
        exact = exact_optimum(scenario, OC3, args.time)
        bound = success_bound(scenario, OC3, args.time, mip=False, max_arcs=args.arcs)
        looser = [success_bound(scenario, OC3, args.time, mip=False, model=model, block=2).lp
                  for model in (BoundModel.CELLS, BoundModel.BLOCKS)]
        headings = success_bound(scenario, OC3, args.time, mip=False, model=BoundModel.HEADINGS).lp
        dual = success_bound(scenario, OC3, args.dual_time, model=BoundModel.LAGRANGIAN, dual_iterations=10**6).value
        duals.append(dual / headings - 1)
        assert dual >= headings - 1e-6 * headings
        nx, ny = scenario.search_map.shape
        ranges = "/".join(f"{u.range_units / scenario.move_costs.straight:.0f}" for u in scenario.uavs)
        if exact.optimal:
            gaps.append(bound.lp / exact.mip_best - 1)
            plans.append(plan.success.expected / exact.mip_best)
            improved_plans.append(improved.expected / exact.mip_best)
            assert bound.lp + 1e-6 >= exact.mip_best >= max(plan.success.expected, improved.expected) - 1e-6
        lp_shares.append(improved.expected / bound.lp)
        best = f"{exact.mip_best:.2f}" if exact.optimal else f"<= {exact.mip_dual:.2f} (time)"
        print(f"| {seed} | {nx}x{ny} | {len(scenario.uavs)} | {ranges} | {plan.success.expected:.2f} | "
              f"{improved.expected:.2f} | {best} | {bound.lp:.2f} ({bound.model.value}) | "
              f"{(bound.lp / exact.mip_best if exact.optimal else math.nan):.3f} | "
              f"{(plan.success.expected / exact.mip_best if exact.optimal else math.nan):.1%} | "
              f"{(improved.expected / exact.mip_best if exact.optimal else math.nan):.1%} | "
              f"{improved.expected / bound.lp:.1%} | "
              + "".join(f"{(v / exact.mip_best if exact.optimal else math.nan):.3f} | " for v in looser)
              + f"{dual / headings:.4f} | {(dual / exact.mip_best if exact.optimal else math.nan):.3f} | "
              + f"{exact.seconds:.1f} |", flush=True)
    if gaps:
        print(f"\nLP bound over optimum: mean +{statistics.mean(gaps):.1%}, largest +{max(gaps):.1%}; DTSCS plan over "
              f"optimum: mean {statistics.mean(plans):.1%}, lowest {min(plans):.1%}; improved plan over optimum: "
              f"mean {statistics.mean(improved_plans):.1%}, lowest {min(improved_plans):.1%} "
              f"({len(gaps)} of {count} solved)")
    print(f"Improved plan over the LP bound: mean {statistics.mean(lp_shares):.1%}, lowest {min(lp_shares):.1%}")
    print(f"Lagrangian dual over the headings LP after {args.dual_time:g} s: mean +{statistics.mean(duals):.2%}, "
          f"largest +{max(duals):.2%}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=("figures", "gap"))
    parser.add_argument("--areas", type=int, default=5, help="seeded random areas (figures)")
    parser.add_argument("--instances", type=int, default=12, help="tiny areas (gap)")
    parser.add_argument("--time", type=float, default=60.0, help="seconds per bound (LP and MIP) or exact optimum")
    parser.add_argument("--dual-time", type=float, default=5.0, help="seconds for the Lagrangian dual (gap)")
    parser.add_argument("--arcs", type=int, default=DEFAULT_MAX_ARCS, help="largest model, in flow arcs")
    parser.add_argument("--no-large", action="store_true", help="leave out missions/large.geojson")
    parser.add_argument("--smoke", action="store_true", help="a tiny run that exercises every path (tests)")
    args = parser.parse_args(argv)
    if args.smoke:
        args.time = min(args.time, 20.0)
        args.dual_time = min(args.dual_time, 1.0)
    (figures if args.what == "figures" else gap)(args)


if __name__ == "__main__":
    main()
