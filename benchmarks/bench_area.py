"""How long `gcs plan --area` takes on the large example, and how it grows with cells and UAVs.

    .venv/bin/python benchmarks/bench_area.py [--strategy NAME] [--quick]

Prints: the end-to-end wall time of the command (a fresh process, imports and JIT cache loads
included), then per configuration the time of each phase in one process: setup (read, project,
rasterise, edge checks, return tables), search (the closed search), outputs (missions, files)."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gcs.plans.options import AreaOptions, SearchOptions  # noqa: E402
from gcs.plans.planning import area_outputs, build_area_search, write_outputs  # noqa: E402

LARGE = ROOT / "missions" / "large.geojson"


def _with_uavs(doc: dict, count: int) -> dict:
    kept, airports = [], 0
    for f in doc["features"]:
        if f["properties"]["role"] == "airport":
            airports += 1
            if airports > count:
                continue
        kept.append(f)
    return {**doc, "features": kept}


def phases(area_path: Path, out: Path, area: AreaOptions, search: SearchOptions) -> dict[str, float]:
    t0 = time.perf_counter()
    setup = build_area_search(area_path, area, search)
    t1 = time.perf_counter()
    for _ in setup.search.run():
        pass
    plan = setup.search.plan()
    t2 = time.perf_counter()
    write_outputs(out, area_outputs(setup, plan, search.seed, area.speed_m_s))
    t3 = time.perf_counter()
    g = setup.area.grid
    steps = sum(len(u.trajectory) - 1 for u in plan.uavs)
    return {"cells": g.cells, "grid": f"{g.nx}x{g.ny}", "uavs": len(plan.uavs), "uav_steps": steps,
            "setup": t1 - t0, "search": t2 - t1, "outputs": t3 - t2, "total": t3 - t0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--strategy", default=None, help="search strategy (default: gcs plan's default)")
    parser.add_argument("--quick", action="store_true", help="fewer configurations")
    opts = parser.parse_args()
    extra = ["--strategy", opts.strategy] if opts.strategy else []
    search = SearchOptions(strategy=opts.strategy) if opts.strategy else SearchOptions()
    doc = json.loads(LARGE.read_text())
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cmd = [str(ROOT / ".venv" / "bin" / "gcs"), "plan", "--area", str(LARGE), "--out", str(tmp / "e2e"),
               "--quiet", *extra]
        subprocess.run(cmd, check=True)   # warm the JIT cache
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True)
        shown = " ".join(["gcs", *cmd[1:3], "missions/large.geojson", *extra])
        print(f"end to end: {shown}: {time.perf_counter() - t0:.2f} s wall")
        print()
        header = f"{'grid':>9} {'cells':>7} {'UAVs':>4} {'UAV-steps':>9} {'setup s':>8} {'search s':>8} " \
                 f"{'outputs s':>9} {'total s':>8} {'ms/UAV-step':>11}"
        print(header)
        sizes = (100, 50, 25) if opts.quick else (100, 50, 35, 25)
        uav_counts = (1, 8) if opts.quick else (1, 2, 4, 8)
        runs = [(size, 8) for size in sizes] + [(25, k) for k in uav_counts if k != 8]
        for size, count in runs:
            path = tmp / f"large_{count}.geojson"
            path.write_text(json.dumps(_with_uavs(doc, count)))
            r = phases(path, tmp / f"out_{size}_{count}", AreaOptions(cell_size_m=size), search)
            print(f"{r['grid']:>9} {r['cells']:>7} {r['uavs']:>4} {r['uav_steps']:>9} {r['setup']:>8.2f} "
                  f"{r['search']:>8.2f} {r['outputs']:>9.2f} {r['total']:>8.2f} "
                  f"{1000 * r['search'] / max(r['uav_steps'], 1):>11.2f}")


if __name__ == "__main__":
    main()
