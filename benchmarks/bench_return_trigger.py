"""The live return trigger's cost: one range check (`gcs.flight.return_trigger.fuel_decision`,
what every vehicle's flight runs on each station tick) on the paper plan's tracks, in still air
and in an 8 m/s wind, with a gauge that has learned a search's worth of cruise.

    .venv/bin/python benchmarks/bench_return_trigger.py [--checks 2000] [--lookahead 2]

It runs on the station's event loop, beside every vehicle's MAVLink traffic: milliseconds spent
here are milliseconds the station answers no vehicle (a mission upload's requests included)."""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gcs.cli import main as gcs_main  # noqa: E402
from gcs.flight.fuel import FlightPhase, FuelGauge  # noqa: E402
from gcs.flight.return_trigger import fuel_decision  # noqa: E402
from gcs.flight.vehicle_track import PlanTrack  # noqa: E402
from gcs.plans.plan_folder import load_plan_dir  # noqa: E402
from gcs.plans.vehicle_file import stock_profile  # noqa: E402
from planner.energy import Airframe  # noqa: E402


def learned_gauge(wind: tuple[float, float] | None) -> FuelGauge:
    """A copter's gauge after 1500 m of settled cruise in legs of every direction."""
    gauge = FuelGauge(stock_profile("ardupilot", Airframe.COPTER))
    if wind is not None:
        gauge.set_wind(*wind)
    used = 0.0
    for second in range(160):
        phase = FlightPhase.LAUNCH if second < 5 else FlightPhase.CRUISE
        heading = math.radians(90.0 * (second // 15))
        step = (10.0 * math.sin(heading), 10.0 * math.cos(heading))
        gauge.moved(float(second), *step, phase)
        used += 10.0 * gauge.profile.cruise_mah_per_m * gauge.factor(*step)
        gauge.battery(float(second), phase, used, None)
    return gauge


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--checks", type=int, default=2000)
    parser.add_argument("--lookahead", type=int, default=2, help="poses ahead checked (gcs fly's default: 2)")
    args = parser.parse_args()
    out = Path(tempfile.mkdtemp(prefix="bench-trigger-")) / "paper"
    gcs_main(["plan", "--area", str(ROOT / "missions" / "paper.geojson"), "--strategy", "exhaustive", "--out", str(out),
              "--quiet"])
    plan = load_plan_dir(out)
    checks = []
    for uid in sorted(plan.uavs):
        track = PlanTrack(plan, uid)
        for index, pose in enumerate(plan.uavs[uid].trajectory):
            steps, home = track.look_ahead(index, pose.lat_deg, pose.lon_deg, args.lookahead)
            if steps:
                checks.append((steps, home, track.circuit_legs()))
    print(f"{len(checks)} search poses on {len(plan.uavs)} tracks; look-ahead {args.lookahead}")
    for name, wind in (("still air", None), ("8 m/s wind", (8.0 * math.sin(math.radians(71)), -2.6))):
        gauge = learned_gauge(wind)
        times = []
        for k in range(args.checks):
            steps, home, circuit = checks[k % len(checks)]
            start = time.perf_counter()
            fuel_decision(gauge, reserve_pct=30.0, landing_mah=300.0, steps_ahead=steps, home_legs=home,
                          circuit_legs=circuit)
            times.append(time.perf_counter() - start)
        print(f"{name:>11}: {1e6 * statistics.median(times):7.0f} us median, "
              f"{1e6 * sorted(times)[int(0.99 * len(times))]:7.0f} us p99 per check")


if __name__ == "__main__":
    main()
