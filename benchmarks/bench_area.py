"""How long `gcs plan --area` takes on the large example, and how it grows with cells and UAVs.

    .venv/bin/python benchmarks/bench_area.py [--strategy NAME] [--quick] [--uavs N,N,...] [--fleet-only]

Prints: the end-to-end wall time of the command (a fresh process, imports and JIT cache loads
included), then per configuration the time of each phase in one process: setup (read, project,
rasterise, edge checks, return tables), search (the closed search), outputs (missions, files).

Big fleets (issue 39): the rows of 8, 32 and 64 UAVs (`--uavs`) on the 50 m grid (200x200 cells)
compare the search's ms per UAV-step as the fleet grows. The large example has 8 airports; a fleet
bigger than that keeps them and adds airports of the same kind (`endurance_s` 2400, heading to the
area's centre), spread evenly along the area's outline 500 m inside it and clear of the no-fly
zones (`extra_airports`: plain geometry, the same points on every run). `--fleet-only` runs just
those rows (no end-to-end run, no other grid or fleet)."""

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

import math  # noqa: E402

import shapely  # noqa: E402
from shapely.geometry import Point, shape  # noqa: E402
from shapely.ops import unary_union  # noqa: E402

from gcs.plans.options import AreaOptions, SearchOptions  # noqa: E402
from gcs.plans.planning import area_outputs, build_area_search, write_outputs  # noqa: E402
from planner.area_grid import local_frame_for  # noqa: E402
from planner.motion import COMPASS  # noqa: E402

LARGE = ROOT / "missions" / "large.geojson"

#: The big-fleet rows: UAV counts on FLEET_CELL_M cells, beside the file's own 8 airports.
FLEETS = (32, 64)
FLEET_CELL_M = 50.0
#: Generated airports lie on the area's outline moved this far inward, at least AIRPORT_CLEAR_M
#: from every no-fly zone and from every other airport.
AIRPORT_INSET_M = 500.0
AIRPORT_CLEAR_M = 200.0
AIRPORT_ENDURANCE_S = 2400


def extra_airports(doc: dict, count: int) -> list[dict]:
    """`count` airport features to add to `doc`'s: evenly spaced along the area's outline
    AIRPORT_INSET_M inside it, those within AIRPORT_CLEAR_M of a no-fly zone or of another
    airport left out, each heading to the compass point nearest the direction of the area's
    centre. Deterministic (geometry only). ValueError when the outline has no room for them."""
    if count <= 0:
        return []
    by_role: dict[str, list] = {}
    for f in doc["features"]:
        by_role.setdefault(f["properties"]["role"], []).append(f)
    area_ll = unary_union([shape(f["geometry"]) for f in by_role["area"]])
    frame = local_frame_for(area_ll)

    def local(geometry):
        return shapely.transform(geometry, frame.lonlat2local_coords)

    area = local(area_ll)
    no_fly = unary_union([local(shape(f["geometry"])) for f in by_role.get("no_fly", [])])
    taken = [local(shape(f["geometry"])) for f in by_role.get("airport", [])]
    inner = area.buffer(-AIRPORT_INSET_M)
    ring = max(getattr(inner, "geoms", [inner]), key=lambda p: p.area).exterior
    centre = area.centroid
    for slots in range(count, 50 * count):
        points = [ring.interpolate(ring.length * i / slots) for i in range(slots)]
        clear = [p for p in points if (no_fly.is_empty or p.distance(no_fly) >= AIRPORT_CLEAR_M)
                 and all(p.distance(q) >= AIRPORT_CLEAR_M for q in taken)]
        if len(clear) >= count:
            break
    else:
        raise ValueError(f"no room for {count} more airports along the area's outline")
    chosen = [clear[(i * len(clear)) // count] for i in range(count)]
    first = len(taken) + 1
    features = []
    for k, p in enumerate(chosen):
        bearing = math.degrees(math.atan2(centre.x - p.x, centre.y - p.y)) % 360.0
        lat, lon = frame.local2geodetic(p.x, p.y)
        features.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [
            round(float(lon), 9), round(float(lat), 9)]}, "properties": {
            "role": "airport", "name": f"team {first + k}", "heading": COMPASS[round(bearing / 45.0) % 8],
            "endurance_s": AIRPORT_ENDURANCE_S}})
    assert all(Point(f["geometry"]["coordinates"]).within(area_ll) for f in features)
    return features


def _with_uavs(doc: dict, count: int) -> dict:
    """`doc` with its first `count` airports, or all of them and `extra_airports` up to `count`."""
    kept, airports = [], 0
    for f in doc["features"]:
        if f["properties"]["role"] == "airport":
            airports += 1
            if airports > count:
                continue
        kept.append(f)
    return {**doc, "features": kept + extra_airports(doc, count - airports)}


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


def _counts(text: str) -> tuple[int, ...]:
    try:
        counts = tuple(int(c) for c in text.split(",") if c.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected UAV counts like 32,64, got {text!r}") from None
    if any(c < 1 for c in counts):
        raise argparse.ArgumentTypeError(f"UAV counts must be at least 1, got {text!r}")
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--strategy", default=None, help="search strategy (default: gcs plan's default)")
    parser.add_argument("--quick", action="store_true",
                        help="fewer configurations (and no big-fleet rows unless --uavs asks for them)")
    parser.add_argument("--uavs", type=_counts, default=None, metavar="N,N,...",
                        help=f"big-fleet rows: these UAV counts on the {FLEET_CELL_M:g} m grid, beside its 8-UAV row "
                             f"(default {','.join(map(str, FLEETS))}; with --quick none)")
    parser.add_argument("--fleet-only", action="store_true",
                        help=f"only the {FLEET_CELL_M:g} m grid's rows of 8 UAVs and --uavs (no end-to-end run)")
    opts = parser.parse_args()
    extra = ["--strategy", opts.strategy] if opts.strategy else []
    search = SearchOptions(strategy=opts.strategy) if opts.strategy else SearchOptions()
    fleets = opts.uavs if opts.uavs is not None else () if opts.quick else FLEETS
    doc = json.loads(LARGE.read_text())
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if not opts.fleet_only:
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
        print(header, flush=True)
        if opts.fleet_only:   # untimed: load the JIT cache, as the full run's first row does
            path = tmp / "large_warm.geojson"
            path.write_text(json.dumps(_with_uavs(doc, 2)))
            phases(path, tmp / "out_warm", AreaOptions(cell_size_m=100), search)
            runs = [(FLEET_CELL_M, 8)]
        else:
            sizes = (100, 50, 25) if opts.quick else (100, 50, 35, 25)
            uav_counts = (1, 8) if opts.quick else (1, 2, 4, 8)
            runs = [(size, 8) for size in sizes] + [(25, k) for k in uav_counts if k != 8]
        runs += [(FLEET_CELL_M, k) for k in fleets if (FLEET_CELL_M, k) not in runs]
        for size, count in runs:
            path = tmp / f"large_{count}.geojson"
            path.write_text(json.dumps(_with_uavs(doc, count)))
            r = phases(path, tmp / f"out_{size:g}_{count}", AreaOptions(cell_size_m=size), search)
            print(f"{r['grid']:>9} {r['cells']:>7} {r['uavs']:>4} {r['uav_steps']:>9} {r['setup']:>8.2f} "
                  f"{r['search']:>8.2f} {r['outputs']:>9.2f} {r['total']:>8.2f} "
                  f"{1000 * r['search'] / max(r['uav_steps'], 1):>11.2f}", flush=True)


if __name__ == "__main__":
    main()
