"""`gcs upload`: send every UAV's mission (plus geofence and rally point) from a `gcs plan
--area` folder to its vehicle over MAVLink and verify it by reading it back.

UAV N goes to the vehicle whose HEARTBEAT carries MAVLink system id N, on whichever of the
`--connect` links it is heard (one link for all, or one per UAV). See docs/fly.md."""

from __future__ import annotations

import argparse
import asyncio
from contextlib import AsyncExitStack

from gcs.commands.fly import add_connection_arguments, check_connections, connection_strings, start_sim
from gcs.errors import UserError
from gcs.flight import FlightController, FlyOptions
from gcs.fleet import FleetPlan, load_plan_dir
from gcs.link import MavLink


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("upload", help="upload and verify every UAV's mission, fence and rally point",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    add_connection_arguments(p)
    p.add_argument("--timeout", type=float, default=0.5, help="seconds before a mission message is re-sent")
    p.add_argument("--connect-timeout", type=float, default=15.0, help="seconds to wait for each vehicle's HEARTBEAT")
    p.set_defaults(func=run)


async def upload_fleet(plan: FleetPlan, connections: list[str], options: FlyOptions, out=None) -> FlightController:
    async with AsyncExitStack() as stack:
        links = [await stack.enter_async_context(MavLink(c)) for c in connections]
        controller = FlightController(plan, links, options, out)
        await controller.upload_all()
    return controller


def run(args: argparse.Namespace) -> int:
    if not args.plan:
        raise UserError("give --plan DIR (a gcs plan --area folder)")
    check_connections(args)
    plan = load_plan_dir(args.plan)
    connections = connection_strings(args, plan)
    options = FlyOptions(transfer_timeout_s=args.timeout, connect_timeout_s=args.connect_timeout,
                         fence=not args.no_fence, fly=False)
    fleet = None
    if args.sim:
        fleet = start_sim(plan, speedup=args.speedup, profile=args.sim_profile, loss=args.sim_loss).start()
        connections = fleet.connection_strings()
    try:
        controller = asyncio.run(upload_fleet(plan, connections, options))
    finally:
        if fleet is not None:
            fleet.stop()
    ok = 0
    for uid, st in sorted(controller.status.items()):
        reports = controller.upload_reports.get(uid)
        if reports:
            ok += 1
            parts = [f"{kind} {r.items} items ({r.resends} re-sends)" for kind, r in reports.items()]
            print(f"UAV {uid}: verified: {', '.join(parts)}")
        else:
            print(f"UAV {uid}: FAILED: {st.note}")
    print(f"{ok}/{len(controller.status)} vehicles verified")
    return 0 if ok == len(controller.status) else 1
