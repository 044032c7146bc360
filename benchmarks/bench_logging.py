"""Cost of the Rerun recording: the paper scenario's closed search with logging off and on.

Two measurements, medians of --repeats runs, each with its ratio to logging off (target: under
1.5x) and the .rrd size per step per UAV:
- in process: the search loop alone, warm (imports done, numba compiled);
- whole process: a fresh Python that does what `gcs plan` does (imports, search, plan JSON,
  and the recording unless off), so the import of rerun counts.
Usage: python benchmarks/bench_logging.py [--repeats 7]"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from planner.dtscs import ClosedSearch, MissionConfig
from planner.scenario import paper_scenario


def fake_geo(cells):
    """About 30 m cells near Zurich: only to time the geographic entities."""
    return np.column_stack([47.37 + 2.7e-4 * cells[:, 1], 8.54 + 4.0e-4 * cells[:, 0]])


def timed_run(seed: int, range_steps: int, rrd: Path | None, **options) -> tuple[float, int, int]:
    from gcs.recording.plan import PlanRecorder

    scenario = paper_scenario(seed, range_steps=range_steps)
    start = time.perf_counter()
    search = ClosedSearch(scenario, MissionConfig(), seed=seed)
    with PlanRecorder(rrd, None, scenario, **options) as rec:
        for record in search.run():
            rec.log_step(record)
        plan = search.plan()
        rec.log_plan(plan)
    return time.perf_counter() - start, plan.steps, len(plan.uavs)


def child(seed: int, range_steps: int, out: Path, record: bool) -> None:
    """One `gcs plan`-like run in this fresh process: search, plan JSON, recording if asked."""
    from gcs.atomic import write_json_atomic
    from gcs.plans.plan_file import plan_to_dict

    scenario = paper_scenario(seed, range_steps=range_steps)
    search = ClosedSearch(scenario, MissionConfig(), seed=seed)
    if record:
        from gcs.recording.plan import PlanRecorder

        with PlanRecorder(out.with_suffix(".rrd"), None, scenario) as rec:
            for step in search.run():
                rec.log_step(step)
            rec.log_plan(search.plan())
    else:
        for _ in search.run():
            pass
    write_json_atomic(out, plan_to_dict(search.plan(), seed=seed))


def whole_process(args: argparse.Namespace) -> None:
    times: dict[str, list[float]] = {"off": [], "on": []}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "plan.json"
        for _ in range(args.repeats):
            for mode in times:
                start = time.perf_counter()
                subprocess.run([sys.executable, __file__, "--child", mode, "--seed", str(args.seed),
                                "--range", str(args.range_steps), "--out", str(out)], check=True)
                times[mode].append(time.perf_counter() - start)
        size = out.with_suffix(".rrd").stat().st_size
    off, on = statistics.median(times["off"]), statistics.median(times["on"])
    print(f"\nwhole process (python start, imports, search, plan JSON), median of {args.repeats}")
    print(f"{'variant':<26} {'wall s':>8} {'ratio':>6} {'rrd KiB':>8}")
    print(f"{'off':<26} {off:>8.3f} {1:>5.2f}x {'-':>8}")
    print(f"{'on (default)':<26} {on:>8.3f} {on / off:>5.2f}x {size / 1024:>8.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--range", dest="range_steps", type=int, default=130)
    parser.add_argument("--child", choices=("on", "off"), help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.seed, args.range_steps, args.out, args.child == "on")
        return
    in_process(args)
    whole_process(args)


def in_process(args: argparse.Namespace) -> None:
    variants = {
        "off": (False, {}),
        "on (default)": (True, {}),
        "on, maps every 5 steps": (True, {"map_every": 5}),
        "on, with geo entities": (True, {"cells_to_lat_lon": fake_geo}),
    }
    with tempfile.TemporaryDirectory() as tmp:
        timed_run(args.seed, args.range_steps, Path(tmp) / "warm.rrd")  # numba caches, imports
        times: dict[str, list[float]] = {name: [] for name in variants}
        sizes: dict[str, float] = {}
        steps = uavs = 0
        for _ in range(args.repeats):
            for i, (name, (on, options)) in enumerate(variants.items()):
                rrd = Path(tmp) / f"v{i}.rrd" if on else None
                elapsed, steps, uavs = timed_run(args.seed, args.range_steps, rrd, **options)
                times[name].append(elapsed)
                if rrd is not None:
                    sizes[name] = rrd.stat().st_size
    base = statistics.median(times["off"])
    print(f"paper scenario, seed {args.seed}, range {args.range_steps}: {steps} steps, {uavs} UAVs")
    print(f"\nin process (search loop, warm), median of {args.repeats}")
    print(f"{'variant':<26} {'wall s':>8} {'ratio':>6} {'rrd KiB':>8} {'B/step/UAV':>11}")
    for name in variants:
        wall = statistics.median(times[name])
        size = sizes.get(name)
        size_text = f"{size / 1024:>8.0f} {size / (steps * uavs):>11.0f}" if size else f"{'-':>8} {'-':>11}"
        print(f"{name:<26} {wall:>8.3f} {wall / base:>5.2f}x {size_text}")


if __name__ == "__main__":
    main()
