"""The optimisers (CPIO, PIO, PSO, GA) against exhaustive choice: speed, per-decision quality,
targets found, determinism.

Run: .venv/bin/python benchmarks/bench_optimisers.py [--repeat 5] [--quality-seeds 5] [--target-runs 100]

1. Mission time: the whole paper mission (Table 1, 3OC, range 130) per strategy at Np = 5 and 7,
   median of `--repeat` seeds after a JIT warm-up, on one core (numba runs single-threaded).
2. Cost per decision: paths scored and time per UAV decision, beside exhaustive's K^Np paths.
3. Quality: along each optimiser's own missions, every decision's chosen path and the exact
   optimum are both scored against the same other vehicles (the others' final choices, soft;
   returning UAVs, hard); reports J1(chosen) / J1(optimum).
4. Targets found over `--target-runs` seeded missions per strategy (as `gcs experiment fig8`).
5. Same seed, same plan."""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from planner.dtscs import ClosedSearch, MissionConfig, fly
from planner.motion import OC3
from planner.scenario import paper_scenario
from planner.search import make_strategy
from planner.search.competition import fixed_others
from planner.search.exhaustive import ExhaustiveStrategy, all_choices
from planner.search.flock import path_cells
from planner.search.problem import PathScorer

OPTIMISERS = ("cpio", "pio", "pso", "ga")


def mission_time(strategy: str, np_steps: int, seed: int) -> tuple[float, list[int]]:
    search = ClosedSearch(paper_scenario(seed, 130), MissionConfig(np_steps=np_steps, strategy=strategy), seed=seed)
    evaluations = []
    start = time.perf_counter()
    for record in search.run():
        evaluations += [d.evaluations for d in record.decisions.values()]
    return time.perf_counter() - start, evaluations


class QualityProbe:
    """Wraps a strategy; after each decision, scores the chosen path and the exact optimum
    against the same others."""

    def __init__(self, name: str) -> None:
        self.inner = make_strategy(name)
        self.name = name
        self.exact = ExhaustiveStrategy()
        self.ratios: list[float] = []
        self.totals = [0.0, 0.0]

    def best_path(self, *args):
        return self.inner.best_path(*args)

    def decide(self, problem, rng):
        out = self.inner.decide(problem, rng)
        choices = all_choices(problem.branching, problem.np_steps)
        for s in problem.searchers:
            d = out.get(s.uav_id)
            if d is None:
                continue
            soft = {u: path_cells(o, problem.np_steps) for u, o in out.items() if u != s.uav_id and o is not None}
            others, hard = fixed_others(problem, {s.uav_id}, None, soft)
            optimum = self.exact.best_path(problem, s, others, hard)
            scores, depths, cells = PathScorer(problem, s, others, hard)(choices)
            chosen = next(i for i in range(len(scores))
                          if depths[i] == len(d.path) and np.array_equal(cells[i, : depths[i]], d.path))
            if optimum.j1 > 0:
                self.ratios.append(scores[chosen] / optimum.j1)
                self.totals[0] += scores[chosen]
                self.totals[1] += optimum.j1
        return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--quality-seeds", type=int, default=5)
    parser.add_argument("--target-runs", type=int, default=100)
    args = parser.parse_args()

    for name in (*OPTIMISERS, "exhaustive"):
        for np_steps in (5, 7):
            mission_time(name, np_steps, 0)
    print("1-2. paper mission (3OC, range 130), median of", args.repeat, "seeds after warm-up, one core")
    print(f"{'strategy':>10} {'Np':>3} {'mission s':>10} {'paths/decision':>15} {'us/decision':>12} {'K^Np':>6}")
    for np_steps in (5, 7):
        for name in (*OPTIMISERS, "exhaustive"):
            times, evaluations = [], []
            for seed in range(1, args.repeat + 1):
                t, e = mission_time(name, np_steps, seed)
                times.append(t)
                evaluations += e
            per = statistics.median(times) / max(1, len(evaluations) / args.repeat) * 1e6
            print(f"{name:>10} {np_steps:>3} {statistics.median(times):>10.3f} {np.mean(evaluations):>15.0f} "
                  f"{per:>12.0f} {OC3.branching ** np_steps:>6}")

    print(f"\n3. J1 of the chosen path / exact optimum, same decision states ({args.quality_seeds} missions each)")
    print(f"{'strategy':>10} {'mean ratio':>11} {'sum ratio':>10} {'worst':>7} {'< 99%':>7} {'decisions':>10}")
    for name in OPTIMISERS:
        probe = QualityProbe(name)
        for seed in range(args.quality_seeds):
            search = ClosedSearch(paper_scenario(seed, 130), MissionConfig(strategy=name), seed=seed, strategy=probe)
            for _ in search.run():
                pass
        r = np.array(probe.ratios)
        print(f"{name:>10} {r.mean():>11.4f} {probe.totals[0] / probe.totals[1]:>10.4f} {r.min():>7.3f} "
              f"{(r < 0.99).mean():>7.1%} {len(r):>10}")

    print(f"\n4. targets found of 10, {args.target_runs} seeded missions each (mean ± std, standard error)")
    for name in (*OPTIMISERS, "exhaustive"):
        found = [fly(paper_scenario(seed, 130), MissionConfig(strategy=name), seed=seed).targets_found
                 for seed in range(args.target_runs)]
        se = np.std(found) / np.sqrt(len(found))
        print(f"{name:>10} {np.mean(found):5.2f} ± {np.std(found):4.2f}  (se {se:.2f})")

    print("\n5. same seed, same plan")
    for name in OPTIMISERS:
        a = fly(paper_scenario(5, 130), MissionConfig(strategy=name), seed=5)
        b = fly(paper_scenario(5, 130), MissionConfig(strategy=name), seed=5)
        same = [u.trajectory for u in a.uavs] == [u.trajectory for u in b.uavs]
        print(f"{name:>10} {'identical' if same else 'DIFFERENT'}")


if __name__ == "__main__":
    main()
