"""A plane landing from outside its search area, on real ArduPlane SITL with its geofence on
(FENCE_ENABLE 1, FENCE_ACTION 1 = RTL, polygon fence as `gcs fly` uploads it): the meadow of
`tests/peers/site.py` (a 1.5 km square of 100 m cells, the runway on its south edge landing
northwards, so the 500 m approach lies wholly outside the area), flown at each speed-up.

    .venv/bin/python benchmarks/fly_approach.py [--speedup 10 30 50] [--runs 3] [--area-fence]

Per run: wall time of `gcs fly` (SITL start to exit), where the plane stopped from its airport,
how far it flew outside the area, how close it came to the fence's edge outside the area,
FENCE_STATUS's breach count at the end, and how it went home. `--area-fence` is the control: the
same flight with the inclusion fence cut back to the area's own outline (as before the corridor),
which the approach breaches. Needs ArduPilot SITL from the peers folder."""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import Polygon

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.gcs.autopilots.flights import fly, recorded  # noqa: E402
from tests.peers.ardupilot import ArduPilotSitl, require_ardupilot  # noqa: E402
from tests.peers.site import MEADOW  # noqa: E402

PARAMS = {"NAVL1_PERIOD": 10, "FENCE_ENABLE": 1}


def _area_only_fence(plan_dir: Path) -> None:
    """Replace the UAV's inclusion ring by the area's outline (the fence before approach corridors)."""
    path = plan_dir / "uav1.plan"
    doc = json.loads(path.read_text())
    outline = MEADOW.geojson()["features"][0]["geometry"]["coordinates"][0][:-1]
    doc["geoFence"]["polygons"][0]["polygon"] = [[lat, lon] for lon, lat in reversed(outline)]
    path.write_text(json.dumps(doc))


def run(folder: Path, speedup: float, area_fence: bool) -> str:
    plan_dir = MEADOW.plan(folder, "--vehicle", "plane")
    if area_fence:
        _area_only_fence(plan_dir)
    started = time.monotonic()
    with ArduPilotSitl("plane", home=MEADOW.home(0), speedup=speedup, params=PARAMS) as sitl:
        done = fly(plan_dir, sitl.gcs_port)
        wall = time.monotonic() - started
        fence = sitl.fence_status()
    if done.returncode != 0:
        return f"| {speedup:g} | failed ({done.returncode}): {done.stdout[-300:]!r} |"
    plan, tracks, _ = recorded(plan_dir)
    task = plan.uavs[1]
    track = shapely.points(np.array([plan.local_m(*p) for p in tracks[1]]))
    airport = shapely.Point(plan.local_m(*task.airport_lat_lon))
    h = MEADOW.half_m
    area = Polygon([(-h, -h), (h, -h), (h, h), (-h, h)])
    inclusion = Polygon([plan.local_m(*v) for v in task.fence[0][1]])
    outside = track[~shapely.covers(area, track)]
    edge = shapely.distance(inclusion.exterior, outside).min() if len(outside) else float("nan")
    row = next(line.split() for line in done.stdout.splitlines() if line.startswith("  1 "))
    breaches = "-" if fence is None else f"{fence.breach_count}"
    returned = re.search(r"return - going home \((\w+)\)", done.stdout)
    return (f"| {speedup:g} | {wall:.1f} s | {shapely.distance(airport, track[-1]):.1f} m | "
            f"{shapely.distance(area, track).max():.0f} m | {edge:.0f} m | {breaches} | "
            f"{returned.group(1) if returned else row[5]} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--speedup", type=float, nargs="+", default=[10.0, 30.0, 50.0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--area-fence", action="store_true", help="control: the inclusion fence is the area alone")
    args = parser.parse_args()
    require_ardupilot()
    print("| SPEEDUP | wall | stopped from its airport | furthest outside the area | "
          "closest to the fence's edge outside the area | fence breaches | went home by |")
    print("|---:|---:|---:|---:|---:|---:|---|")
    for speedup in args.speedup:
        for _ in range(args.runs):
            with tempfile.TemporaryDirectory() as tmp:
                print(run(Path(tmp), speedup, args.area_fence), flush=True)


if __name__ == "__main__":
    main()
