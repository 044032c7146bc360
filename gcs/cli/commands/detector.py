"""`gcs detector`: the simulated downward sensor for a real vehicle (ArduPilot SITL or a real
flight over a simulated world), as a MAVLink camera (component 100) on the vehicle's companion
port. It reads the vehicle's position and reports the readings the simulated vehicle of the same
UAV would (CAMERA_IMAGE_CAPTURED, same seed, same noise); ArduPilot forwards them to the ground
station, so `gcs fly` and `gcs fly --online` get readings from real flights. Runs until
interrupted (Ctrl-C or SIGTERM). See docs/detector.md.

`--uav` and `--connect` pair up in order: one process may serve several vehicles."""

from __future__ import annotations

import argparse
import asyncio
import signal
import time

from gcs.cli.link_options import add_link_arguments, connections_from, signing_from
from gcs.errors import UserError
from gcs.plans.options import SearchOptions


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("detector", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    p.add_argument("--plan", metavar="DIR", help="a gcs plan --area folder: grid, targets and (by default) seed")
    p.add_argument("--area", metavar="FILE",
                   help="or an area file, laid out as gcs plan --area does (grid and target features)")
    p.add_argument("--cell-size", dest="cell_size_m", metavar="METRES", type=float, default=None,
                   help="with --area: the cell size the plan uses (default: the file's, else the plan command's)")
    p.add_argument("--margin", dest="margin_m", metavar="METRES", type=float, default=0.0,
                   help="with --area: the safety margin the plan uses")
    p.add_argument("--uav", metavar="ID", type=int, action="append", default=[],
                   help="UAV id = the vehicle's MAVLink system id; repeatable, paired with --connect in order")
    add_link_arguments(p)
    p.add_argument("--seed", type=int, default=None,
                   help="seed of the sensor noise (default: the plan's, 0 with --area)")
    p.add_argument("--pc", type=float, default=SearchOptions.pc,
                   help="probability of reporting a target in the cell (default with --plan: the plan's, its "
                        "camera's Pc when it was made with --camera-fov)")
    p.add_argument("--pf", type=float, default=SearchOptions.pf,
                   help="probability of reporting an empty cell, a false alarm (default with --plan: the plan's)")
    p.set_defaults(func=run)


def _world(args: argparse.Namespace):
    """The simulated world, the default seed and the sensor's Pc and Pf, from --plan (the plan's
    sensor unless --pc / --pf are given) or --area."""
    from sim.detector import World

    if bool(args.plan) == bool(args.area):
        raise UserError("give --plan DIR (a gcs plan --area folder) or --area FILE")
    if args.plan:
        from gcs.cli.sim_options import sim_sensor
        from gcs.plans.plan_folder import load_plan_dir

        plan = load_plan_dir(args.plan)
        return World.of_plan(plan), sorted(plan.uavs), int(plan.raw.get("seed") or 0), sim_sensor(args, plan)
    from gcs.plans.options import AreaOptions
    from gcs.plans.planning import build_area_search

    setup = build_area_search(args.area, AreaOptions(cell_size_m=args.cell_size_m, margin_m=args.margin_m))
    return World.of_area(setup), [ap.index + 1 for ap in setup.source.airports], 0, (args.pc, args.pf)


def run(args: argparse.Namespace) -> int:
    from sim.detector import Detector

    connections = connections_from(args)
    if not args.uav:
        raise UserError("give --uav ID (the vehicle's system id) and --connect CONN (its companion port)")
    if len(args.uav) != len(connections):
        raise UserError(f"give one --connect per --uav: {len(args.uav)} --uav, {len(connections)} --connect")
    if len(set(args.uav)) != len(args.uav):
        raise UserError("--uav: each UAV once")
    for name in ("pc", "pf"):
        if not 0.0 <= getattr(args, name) <= 1.0:
            raise UserError(f"--{name} must be a probability in [0, 1], got {getattr(args, name):g}")
    signing = signing_from(args)
    world, uav_ids, plan_seed, (pc, pf) = _world(args)
    unknown = [u for u in args.uav if u not in uav_ids]
    if unknown:
        raise UserError(f"--uav {unknown[0]}: not a UAV of the plan (it has {', '.join(map(str, uav_ids))})")
    seed = plan_seed if args.seed is None else args.seed
    detectors = [Detector(world.sensor(uid, seed=seed, pc=pc, pf=pf), uid) for uid in args.uav]
    t0 = time.monotonic()

    def say(uid: int, line: str) -> None:
        print(f"[{time.monotonic() - t0:6.1f}s] UAV {uid}: {line}", flush=True)

    print(f"world of {args.plan or args.area}: {world.cell_size_m:g} m cells, {len(world.targets)} targets, "
          f"seed {seed}, pc {pc:.3g}, pf {pf:.3g}", flush=True)
    asyncio.run(_serve(list(zip(connections, detectors)), signing, say))
    for det in detectors:
        hits = sum(obs.reported for obs in det.observations)
        say(det.sysid, f"{len(det.observations)} readings ({hits} positive) from {det.positions} positions")
    return 0


async def _serve(pairs, signing, say) -> None:
    from sim.detector import run_detectors

    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        await run_detectors(pairs, stop, signing=signing, say=say)
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)
