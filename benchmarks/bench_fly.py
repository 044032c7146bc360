"""Ground-station speed: fleet upload time, and the GCS loop's per-step latency with 4, 16 and 64
vehicles against the simulated fleet over loopback UDP (docs/fly.md).

    .venv/bin/python benchmarks/bench_fly.py [--runs 5] [--counts 4,16,64] [--seconds 8]

Upload: the 4-UAV paper plan (mission + fence + rally, verified by read-back), whole fleet
concurrently, at 0 % and 20 % packet loss. Loop: the plan's UAVs are cloned up to N vehicles
(same airports and paths, ids 1..N), flown at speedup 5 for a few seconds; every GCS tick
(telemetry bookkeeping, track, the return decision for every vehicle) is timed, then every
vehicle is ordered home at once and the command latency (hold, upload the return leg, verify,
start) is timed per vehicle."""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
import time
from contextlib import AsyncExitStack
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gcs.autopilots import Autopilot  # noqa: E402
from gcs.cli import main as gcs_main  # noqa: E402
from gcs.flight.controller import FlightController, FlyOptions  # noqa: E402
from gcs.flight.fly import upload_plan  # noqa: E402
from gcs.links import MavLink  # noqa: E402
from gcs.plans.plan_folder import FleetPlan, load_plan_dir  # noqa: E402
from sim.plan_fleet import fleet_for_plan  # noqa: E402


def make_plan() -> FleetPlan:
    out = Path(tempfile.mkdtemp(prefix="bench-fly-")) / "paper"
    gcs_main(["plan", "--area", str(ROOT / "missions" / "paper.geojson"), "--strategy", "exhaustive", "--out", str(out),
              "--quiet"])
    return load_plan_dir(out)


def cloned(plan: FleetPlan, n: int) -> FleetPlan:
    base = [plan.uavs[k] for k in sorted(plan.uavs)]
    uavs = {i + 1: replace(base[i % len(base)], uav_id=i + 1) for i in range(n)}
    return replace(plan, uavs=uavs, _tables={})


def pct(values: list[float], q: float) -> float:
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))]


def bench_upload(plan: FleetPlan, runs: int, loss: float) -> tuple[list[float], list[float]]:
    """Whole-fleet wall time (connect, stream set-up, uploads), and per vehicle the transfers
    alone (mission + fence + rally, each uploaded and read back)."""
    times, transfers = [], []
    for r in range(runs):
        fleet = fleet_for_plan(plan, speedup=1.0, loss=loss, seed=r).start()
        try:
            opts = FlyOptions(fly=False, transfer_timeout_s=0.05 if loss else 0.5)
            start = time.perf_counter()
            controller = asyncio.run(upload_plan(plan, fleet.connection_strings(), opts, out=lambda line: None))
            times.append(time.perf_counter() - start)
            uploads = [v.upload_reports for v in controller.vehicles.values() if v.upload_reports]
            assert len(uploads) == len(plan.uavs), "an upload failed"
            transfers += [sum(r.elapsed_s for r in reports.values()) for reports in uploads]
        finally:
            fleet.stop()
    return times, transfers


def _return_latencies(controller: FlightController) -> list[float]:
    """Seconds from each return's decision to its leg flying, for the vehicles sent home so far."""
    return [v.return_latency_s for v in controller.vehicles.values() if v.return_latency_s is not None]


async def _loop(plan: FleetPlan, connections: list[str], seconds: float) -> FlightController:
    async with AsyncExitStack() as stack:
        links = [await stack.enter_async_context(MavLink(c)) for c in connections]
        controller = FlightController(plan, links, FlyOptions(tick_s=0.05, transfer_timeout_s=0.2,
                                                              connect_timeout_s=30), out=lambda line: None)
        runner = asyncio.create_task(controller.run())
        await asyncio.sleep(seconds)
        controller.loop_latency_s.clear()  # measure the steady state, after the launch
        await asyncio.sleep(seconds)
        for uid in plan.uavs:
            controller.order_return(uid)
        end = time.monotonic() + 30
        while len(_return_latencies(controller)) < len(plan.uavs) and time.monotonic() < end:
            await asyncio.sleep(0.05)
        controller.interrupt()
        await runner
    return controller


def bench_loop(plan: FleetPlan, n: int, seconds: float) -> tuple[FlightController, float]:
    fleet_plan = cloned(plan, n)
    fleet = fleet_for_plan(fleet_plan, speedup=5.0).start()
    try:
        start = time.perf_counter()
        controller = asyncio.run(_loop(fleet_plan, fleet.connection_strings(), seconds))
        return controller, time.perf_counter() - start
    finally:
        fleet.stop()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--counts", default="4,16,64")
    ap.add_argument("--seconds", type=float, default=8.0)
    args = ap.parse_args()
    plan = make_plan()
    items = sum(len(t.mission_wire(Autopilot.ARDUPILOT))
                + len(t.fence_wire()) + len(t.rally_wire()) for t in plan.uavs.values())
    print(f"upload: {len(plan.uavs)} vehicles, {items} items in all (mission + fence + rally), read back and compared")
    for loss in (0.0, 0.2):
        t, per_vehicle = bench_upload(plan, args.runs, loss)
        print(f"  loss {loss:.0%}: fleet median {statistics.median(t):.3f} s (min {min(t):.3f}, max {max(t):.3f}) "
              f"over {len(t)} runs; transfers per vehicle median {statistics.median(per_vehicle):.3f} s, "
              f"max {max(per_vehicle):.3f} s")
    print()
    print(f"{'vehicles':>8} {'ticks':>6} {'tick p50 ms':>11} {'tick p95 ms':>11} {'tick max ms':>11} "
          f"{'per vehicle us':>14} {'return p50 ms':>13} {'return max ms':>13} {'returned':>8}")
    for n in (int(c) for c in args.counts.split(",") if c):
        controller, _ = bench_loop(plan, n, args.seconds)
        ticks = controller.loop_latency_s
        ret = _return_latencies(controller) or [float("nan")]
        print(f"{n:>8} {len(ticks):>6} {pct(ticks, .5) * 1e3:>11.3f} {pct(ticks, .95) * 1e3:>11.3f} "
              f"{max(ticks) * 1e3:>11.3f} {statistics.median(ticks) / n * 1e6:>14.1f} "
              f"{statistics.median(ret) * 1e3:>13.1f} {max(ret) * 1e3:>13.1f} {len(_return_latencies(controller)):>8}")


if __name__ == "__main__":
    main()
