"""`gcs upload`: send every UAV's mission (plus geofence and rally point) from a `gcs plan
--area` folder to its vehicle over MAVLink and verify it by reading it back.

UAV N goes to the vehicle whose HEARTBEAT carries MAVLink system id N, on whichever of the
`--connect` links it is heard (one link for all, or one per UAV). See docs/fly.md."""

from __future__ import annotations

import argparse
import asyncio
from pathlib import Path

from gcs.cli.fleet_options import add_fleet_arguments
from gcs.cli.link_options import signing_from
from gcs.cli.sim_options import connections_or_sim, simulated_fleet
from gcs.errors import UserError
from gcs.flight.controller import FlyOptions
from gcs.flight.fly import upload_plan
from gcs.flight.journal import check_no_flight_in_progress
from gcs.plans.plan_folder import load_plan_dir
from gcs.telemetry.status import Stage


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("upload", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    add_fleet_arguments(p, "upload")
    p.add_argument("--timeout", type=float, default=FlyOptions.transfer_timeout_s,
                   help="seconds before a mission message is re-sent")
    p.add_argument("--connect-timeout", type=float, default=FlyOptions.connect_timeout_s,
                   help="seconds to wait for each vehicle's HEARTBEAT")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not args.plan:
        raise UserError("give --plan DIR (a gcs plan --area folder)")
    connections = connections_or_sim(args)
    signing = signing_from(args)
    plan = load_plan_dir(args.plan)
    if not args.sim:  # an upload goes to vehicles that may be flying that flight
        check_no_flight_in_progress(Path(args.plan))
    options = FlyOptions(transfer_timeout_s=args.timeout, connect_timeout_s=args.connect_timeout,
                         fence=not args.no_fence, fly=False, ready_timeout_s=args.ready_timeout,
                         check_home=not args.allow_home_offset)
    fleet = None
    if args.sim:
        fleet = simulated_fleet(plan, speedup=args.speedup, profile=args.sim_profile, loss=args.sim_loss,
                          signing=signing).start()
        connections = fleet.connection_strings()
    try:
        controller = asyncio.run(upload_plan(plan, connections, options, signing=signing))
    finally:
        if fleet is not None:
            fleet.stop()
    ok = 0
    for uid, st in sorted(controller.status.items()):
        reports = controller.vehicles[uid].upload_reports
        if reports and st.stage is not Stage.FAILED:
            ok += 1
            parts = [f"{kind} {r.items} items ({r.resends} re-sends)" for kind, r in reports.items()]
            print(f"UAV {uid}: verified: {', '.join(parts)}")
        else:
            print(f"UAV {uid}: FAILED: {st.note}")
    print(f"{ok}/{len(controller.status)} vehicles verified")
    return 0 if ok == len(controller.status) else 1
