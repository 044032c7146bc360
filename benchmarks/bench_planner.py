"""Planner core speed: the paper scenario end to end with the exhaustive strategy at Np = 1..7,
the exact return table on a 500x500 grid, and the cold start of `gcs plan`.

Run: .venv/bin/python benchmarks/bench_planner.py [--repeat 5]
Figures are medians after a JIT warm-up, on whatever machine runs this."""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from planner.dtscs import ClosedSearch, MissionConfig
from planner.motion import OC3
from planner.return_exact import return_table
from planner.scenario import paper_scenario


def mission(np_steps: int, seed: int = 7) -> tuple[float, int]:
    """Wall time of one whole paper mission (scenario, tables, search, returns) and the number
    of candidate cells it scored."""
    start = time.perf_counter()
    search = ClosedSearch(paper_scenario(seed, 130), MissionConfig(np_steps=np_steps), seed=seed)
    cells = 0
    for record in search.run():
        cells += sum(d.evaluations for d in record.decisions.values()) * np_steps
    return time.perf_counter() - start, cells


def kernel_ns_per_cell(np_steps: int, repeat: int) -> float:
    """Time of the J1 kernel alone per scored candidate cell (all 3^Np paths of one UAV)."""
    from planner.reward import airport_reward_map, score_paths
    from planner.search.exhaustive import all_choices

    sc = paper_scenario(7, 130)
    m = sc.search_map
    table = return_table(m.no_fly, sc.uavs[0].airport, OC3)
    choices = all_choices(3, np_steps)
    n = len(choices)
    fa = airport_reward_map(m.shape, np.array([u.airport for u in sc.uavs]))
    others = np.full((3, np_steps, 2), -1, dtype=np.int64)
    others[:, :, 0] = 30
    others[:, :, 1] = np.arange(np_steps)
    hard = np.zeros(3, dtype=np.bool_)
    w = np.array([0.3, 0.3, 0.3, 0.1])
    out = (np.empty(n), np.empty(n, np.int64), np.zeros((n, np_steps, 3), np.int64))
    args = (choices, 25, 25, 0, OC3.successors, m.tep, m.eu, m.no_fly, fa, others, hard, w, 0, -1, table, False)
    score_paths(*args, *out)
    loops = max(1, 200_000 // (n * np_steps))
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(loops):
            score_paths(*args, *out)
        best = min(best, (time.perf_counter() - t) / loops)
    return best / (n * np_steps) * 1e9


def cold_start() -> tuple[float, float]:
    """`gcs plan` wall time with an empty numba cache, then again with the cache filled."""
    env = dict(os.environ, NUMBA_CACHE_DIR=tempfile.mkdtemp(prefix="numba-cache-"))
    times = []
    with tempfile.TemporaryDirectory() as out:
        for _ in range(2):
            t = time.perf_counter()
            subprocess.run([sys.executable, "-m", "gcs.cli", "plan", "--quiet", "--out", str(Path(out) / "p.json")],
                           check=True, env=env)
            times.append(time.perf_counter() - t)
    return times[0], times[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    mission(5)
    print("| Np | paths/UAV | mission (ms, median) | candidate cells scored | ns per cell (mission) "
          "| ns per cell (kernel) |")
    print("|---:|---:|---:|---:|---:|---:|")
    for np_steps in range(1, 8):
        mission(np_steps)
        runs = [mission(np_steps) for _ in range(args.repeat)]
        wall = statistics.median(r[0] for r in runs)
        cells = runs[0][1]
        print(f"| {np_steps} | {3 ** np_steps} | {wall * 1e3:.1f} | {cells:,} | {wall / cells * 1e9:.0f} | "
              f"{kernel_ns_per_cell(np_steps, args.repeat):.1f} |")
    blocked = np.zeros((500, 500), dtype=bool)
    blocked[100:200, 150:400] = True
    return_table(blocked, (0, 0), OC3)
    t = []
    for _ in range(args.repeat):
        s = time.perf_counter()
        return_table(blocked, (250, 10), OC3)
        t.append(time.perf_counter() - s)
    print(f"\nexact return table, 500x500 grid, 3OC (2,000,000 states): {statistics.median(t) * 1e3:.0f} ms")
    cold, warm = cold_start()
    print(f"`gcs plan` (paper, Np 5) as a new process: {cold:.2f} s with an empty numba cache, {warm:.2f} s cached")


if __name__ == "__main__":
    main()
