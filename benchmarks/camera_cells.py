"""Which cells a camera's plan should be laid on, judged by what the camera would see.

    .venv/bin/python benchmarks/camera_cells.py [--areas hiker,irregular,paper] [--fov 45]
        [--cells 50,swath,third] [--reference 8] [--seeds 3]
    .venv/bin/python benchmarks/camera_cells.py --smoke       # one area, one grid, a coarse reference

Each `missions/NAME.geojson` is planned as `gcs plan --area FILE --camera-fov FOV` plans it (every
other option the default: the footprint and Pc per look follow from the camera at each cell side,
`planner.camera`), its own `cell_size_m` taken out and each `--cells` side given instead: metres,
`swath` (the camera's swath at the lowest layer) or `third` (a third of it: a 3 x 3 footprint).
Every plan is then judged on one grid for all, `--reference` metres fine, independently of the
cells it was planned on: the subject's probability (the IPP's or raster's mass, else the TEPs) in
the reference cells whose centres lie within half a swath of a UAV's flown path (paths.geojson,
each UAV's swath at its own altitude; a definite-range camera: what passes under it is seen).
A plan moves with small changes (a cell side a millimetre longer can move what it sees by several
per cent), so each is planned with `--seeds` seeds (`gcs plan --seed`) and the seen share given as
their mean, least and greatest. Also the plan's own expected finds and probability of success
(seed 0's, in its own cells, so not comparable across sides for TEP priors) and its CPU seconds
per plan (the mean)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import shape

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from gcs.plans.make import plan_area  # noqa: E402
from gcs.plans.options import AreaOptions, OutputOptions, SearchOptions  # noqa: E402
from gcs.plans.planning import AreaSetup, build_area_search  # noqa: E402
from planner.camera import Camera  # noqa: E402


def without_cell_size(name: str, folder: Path) -> Path:
    """missions/`name`.geojson without its `cell_size_m`, written into `folder`."""
    doc = json.loads((ROOT / "missions" / f"{name}.geojson").read_text())
    doc.get("properties", {}).pop("cell_size_m", None)
    for feature in doc["features"]:
        feature.get("properties", {}).pop("cell_size_m", None)
    path = folder / f"{name}.geojson"
    path.write_text(json.dumps(doc))
    return path


def cell_side(option: str, camera: Camera, altitude_m: float) -> float:
    swath = camera.swath_m(altitude_m)
    return {"swath": swath, "third": swath / 3}.get(option) or float(option)


def seen_share(reference: AreaSetup, paths: dict, fov_deg: float) -> tuple[float, float]:
    """(the share of the reference's probability within half a swath of the paths, the km2 seen)."""
    g, scenario = reference.area.grid, reference.search.scenario
    weight = scenario.p0 if scenario.p0 is not None else scenario.search_map.tep
    mass = np.asarray(weight, dtype=float).ravel() * reference.area.free.ravel()
    east, north = (a.ravel() for a in g.centres_m())
    seen = np.zeros(mass.size, dtype=bool)
    for feature in paths["features"]:
        line = shapely.transform(shape(feature["geometry"]), reference.area.frame.lonlat2local_coords)
        half = feature["properties"]["altitude_m"] * math.tan(math.radians(fov_deg) / 2)
        seen |= shapely.contains_xy(line.buffer(half, cap_style="flat"), east, north)
    return float(mass[seen].sum() / mass.sum()), float(seen.sum() * g.cell_size_m ** 2 / 1e6)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--areas", default="hiker,irregular,paper", help="missions/NAME.geojson, comma-separated")
    parser.add_argument("--fov", type=float, default=45.0, help="the camera's field of view across track, degrees")
    parser.add_argument("--cells", default="50,swath,third", help="cell sides: metres, swath or third")
    parser.add_argument("--reference", type=float, default=8.0, help="the judging grid's cell side, metres")
    parser.add_argument("--seeds", type=int, default=3, help="plans per area and cell side (seeds 0, 1, ...)")
    parser.add_argument("--smoke", action="store_true", help="hiker, 50 m cells, one seed, judged on 25 m cells")
    args = parser.parse_args(argv)
    if args.smoke:
        args.areas, args.cells, args.reference, args.seeds = "hiker", "50", 25.0, 1
    camera = Camera(args.fov)
    altitude = AreaOptions().altitude_m
    quiet = OutputOptions(record=False, progress=False, bound_time_s=0.0)
    print("| area | cells m | footprint | E (own cells) | PoS (own cells) | seen of the prior (mean) | least "
          "| greatest | seen km2 (mean) | CPU s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.areas.split(","):
            area_file = without_cell_size(name, Path(tmp))
            reference = build_area_search(area_file, AreaOptions(cell_size_m=args.reference), SearchOptions())
            for option in args.cells.split(","):
                side = cell_side(option, camera, altitude)
                shares, areas, seconds, first = [], [], [], None
                for seed in range(args.seeds):
                    out = Path(tmp) / f"{name}-{option}-{seed}"
                    start = time.process_time()
                    result = plan_area(area_file, AreaOptions(cell_size_m=side),
                                       SearchOptions(camera_fov_deg=args.fov, seed=seed), out, quiet)
                    seconds.append(time.process_time() - start)
                    share, km2 = seen_share(reference, json.loads((out / "paths.geojson").read_text()), args.fov)
                    shares.append(share)
                    areas.append(km2)
                    if first is None:
                        first = (result, json.loads((out / "plan.json").read_text())["summary"])
                assert first is not None
                radius = first[0].sorties[-1].setup.search.scenario.sensor.footprint_radius
                summary = first[1]
                print(f"| {name} | {side:.2f} ({option}) | {radius} | {summary['expected_targets_found']:.2f} | "
                      f"{summary['probability_of_success']:.1%} | {np.mean(shares):.4f} | {min(shares):.4f} | "
                      f"{max(shares):.4f} | {np.mean(areas):.3f} | {np.mean(seconds):.1f} |")

if __name__ == "__main__":
    main()
