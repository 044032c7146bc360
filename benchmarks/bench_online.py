"""Online mode against the precomputed plan: targets found by `gcs fly --sim` flying the plan and
by `gcs fly --sim --online` (the planner in the loop), over many seeds, as mean ± standard error.

On one seed both flights meet the same world (targets, and sensor noise drawn per UAV, cell and
visit), so nominal flights find exactly what the plan predicted, online or not. `--sim-drain UAV:K`
makes the world depart from the plan (UAV's battery drains K times faster): the precomputed plan
loses that UAV's remaining cells, online mode re-decides with what is left.

Run: .venv/bin/python benchmarks/bench_online.py [--seeds 10] [--speedup 60] [--sim-drain 2:3]"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOUND = re.compile(r"targets found (\d+)/(\d+)")


def targets_found(seed: int, speedup: float, online: bool, extra: list[str]) -> int:
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "gcs.cli", "fly", "--area", str(ROOT / "missions" / "paper.geojson"), "--sim",
               "--speedup", str(speedup), "--seed", str(seed), "--no-rrd", "--out", out,
               "--strategy", "exhaustive"]  # the strategy docs/fly.md's figures were measured with
        run = subprocess.run(cmd + extra + (["--online"] if online else []), capture_output=True, text=True,
                             timeout=600)
        found = FOUND.findall(run.stdout)  # the planning summary comes first, the flight's last
        if run.returncode != 0 or not found:
            raise RuntimeError(f"seed {seed} online={online} failed: {run.stderr[-500:]}")
        return int(found[-1][0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--speedup", type=float, default=60.0)
    parser.add_argument("--sim-drain", metavar="UAV:K", action="append", default=[])
    args = parser.parse_args()
    extra = [a for d in args.sim_drain for a in ("--sim-drain", d)]
    rows = []
    for seed in range(args.seeds):
        rows.append((seed, targets_found(seed, args.speedup, False, extra),
                     targets_found(seed, args.speedup, True, extra)))
        print(f"seed {seed}: plan {rows[-1][1]}, online {rows[-1][2]}", flush=True)
    for name, column in (("plan", 1), ("online", 2)):
        values = [r[column] for r in rows]
        se = statistics.stdev(values) / len(values) ** 0.5 if len(values) > 1 else 0.0
        print(f"{name:>6}: {statistics.mean(values):.2f} ± {se:.2f} targets of 10 (mean ± s.e., {len(values)} seeds)")
    diffs = [r[2] - r[1] for r in rows]
    se = statistics.stdev(diffs) / len(diffs) ** 0.5 if len(diffs) > 1 else 0.0
    print(f"online - plan: {statistics.mean(diffs):+.2f} ± {se:.2f}; online >= plan on {sum(d >= 0 for d in diffs)} "
          f"of {len(diffs)} seeds, equal on {sum(d == 0 for d in diffs)}")


if __name__ == "__main__":
    main()
