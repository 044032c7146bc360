"""`gcs fly`: upload the plan to every vehicle, arm, start the missions, and watch the fleet
until every vehicle has landed (the controller is `gcs.flight.controller`; the live DTSCS return trigger
and online mode are in docs/fly.md).

`gcs fly --plan DIR --connect udpout:127.0.0.1:14540 ...` flies a `gcs plan --area` folder;
`gcs fly --area AREA.geojson` plans first, as `gcs plan --area` does (`gcs.plans.make.plan_area`,
the same options and defaults); `--sim` starts the built-in simulated fleet at the plan's
airports, so one command runs the whole job.

`gcs fly --resume DIR` takes over a flight whose station died while the vehicles flew (the
journal it left in DIR, `gcs.flight.journal`; the reattachment, `gcs.flight.resume`)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from gcs.cli.bus_options import add_bus_arguments, bus_feed_from
from gcs.cli.fleet_options import add_fleet_arguments
from gcs.cli.link_options import connections_from, signing_from
from gcs.cli.plan_options import (
    add_area_arguments,
    add_bound_argument,
    add_output_arguments,
    add_search_arguments,
    output_options_from,
    plan_options_from,
)
from gcs.cli.sim_options import connections_or_sim, sim_sensor, simulated_fleet
from gcs.cli.tak_options import TAK_FLAGS, add_tak_arguments, tak_feed_from
from gcs.display.status_table import LiveTable, render_summary
from gcs.errors import UserError
from gcs.flight.controller import FlyOptions
from gcs.flight.fly import FlightOutcome, fly_plan, fly_resumed, resumed_options
from gcs.flight.journal import check_no_flight_in_progress
from gcs.flight.sortie import plan_sortie
from gcs.plans.options import OutputOptions
from gcs.plans.plan_folder import FleetPlan, load_plan_dir
from planner.campaign import sortie_seed
from planner.energy import EnergyProfile

if TYPE_CHECKING:
    from gcs.plans.planning import AreaSetup

# ---- the command line ---------------------------------------------------------------------


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("fly", formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    add_fleet_arguments(p, "fly")
    p.add_argument("--resume", metavar="DIR", help="take over the flight in progress in DIR after the station that "
                                                   "flew it died (its links, unless --connect is given again)")
    add_bus_arguments(p)
    add_tak_arguments(p, "the plan folder's name")
    p.add_argument("--fit-charge", action="store_true",
                   help="a vehicle whose charge cannot pay for its plan flies it until its battery calls it home "
                        "instead of staying on the ground")
    p.add_argument("--wind", metavar="M_S@FROM_DEG", type=wind_arg,
                   help="the wind at the launch site (e.g. 8@250: 8 m/s from 250 degrees): the check before arming "
                        "and the return trigger price each way in it until a vehicle reads its own")
    p.add_argument("--return-after", metavar="UAV:SECONDS", action="append", default=[],
                   help="order UAV home after SECONDS (real time), as the operator's 'r UAV' would")
    p.add_argument("--stdin-orders", action="store_true",
                   help="read return orders ('r ID') from stdin even when it is not a terminal")
    p.add_argument("--arm-timeout", type=float, default=FlyOptions.arm_timeout_s,
                   help="seconds to keep retrying arming while the autopilot refuses (its reasons are shown)")
    p.add_argument("--link-timeout", type=float, default=FlyOptions.link_timeout_s,
                   help="seconds without telemetry before a vehicle is lost")
    p.add_argument("--lost-giveup", type=float, default=FlyOptions.lost_giveup_s,
                   help="seconds a lost vehicle is waited for at the end")
    p.add_argument("--sim-endurance", type=float, default=1200.0,
                   help="with --sim: flight endurance of a full battery, s")
    p.add_argument("--sim-drain", metavar="UAV:K", action="append", default=[],
                   help="with --sim: UAV's battery drains K times faster than nominal")
    p.add_argument("--online", action="store_true",
                   help="planner in the loop: re-decide every step from live positions and readings (needs --area)")
    g = p.add_argument_group("planning with --area (the options of gcs plan, with its defaults)")
    add_search_arguments(g)
    g.add_argument("--out", default=None,
                   help="with --area: folder for the plan, missions and flight recording (default: runs/<area name>)")
    add_bound_argument(g)
    add_output_arguments(p, "the flight", "flight.rrd in the plan folder")
    add_area_arguments(p)
    p.set_defaults(func=run)


def wind_arg(text: str) -> tuple[float, float]:
    """`SPEED@FROM_DEG` as (east, north) m/s the air moves towards."""
    try:
        speed, source = (float(part) for part in text.split("@"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected SPEED@FROM_DEG, e.g. 8@250") from None
    if not (math.isfinite(speed) and math.isfinite(source) and 0 <= speed < 60):
        raise argparse.ArgumentTypeError(f"{text!r}: a wind speed in [0, 60) m/s from a direction in degrees")
    rad = math.radians(source)
    return -speed * math.sin(rad), -speed * math.cos(rad)


def _pairs(values: list[str], what: str, kind=float) -> dict[int, float]:
    out = {}
    for text in values:
        try:
            uid, value = text.split(":")
            out[int(uid)] = kind(value)
        except ValueError:
            raise UserError(f"{what} {text!r}: expected UAV:NUMBER") from None
    return out


def plan_for_flight(args: argparse.Namespace) -> tuple[FleetPlan, AreaSetup | None]:
    """`--plan DIR`; or `--area FILE` planned first, as `gcs plan --area` plans it (no Rerun
    recording of the planning), and its setup."""
    if args.area:
        from gcs.display.plan_tables import area_report, grounded_lines
        from gcs.plans.make import plan_area

        if args.plan:
            raise UserError("give --plan or --area, not both")
        area, search = plan_options_from(args)
        result = plan_area(args.area, area, search, args.out, OutputOptions(record=False, progress=not args.quiet,
                                                                                  bound_time_s=args.bound_time))
        for line in grounded_lines(result):
            print(line, file=sys.stderr)
        if not args.quiet:
            print(area_report(result))
        return load_plan_dir(result.out_dir), result.sorties[0].setup
    if not args.plan:
        raise UserError("give --plan DIR (a gcs plan --area folder) or --area FILE")
    return load_plan_dir(args.plan), None


def options_from(args: argparse.Namespace, plan: FleetPlan) -> FlyOptions:
    returns = _pairs(args.return_after, "--return-after")
    unknown = [u for u in returns if u not in plan.uavs]
    if unknown:
        raise UserError(f"--return-after: unknown UAV {unknown[0]} "
                        f"(the plan has {', '.join(map(str, sorted(plan.uavs)))})")
    if not 0 <= args.reserve_pct < 100:
        raise UserError("--reserve-pct must be in [0, 100)")
    vehicles = args.vehicles or planned_vehicles_file(plan)
    return FlyOptions(reserve_pct=args.reserve_pct, profiles=profiles_from(vehicles, plan),
                      vehicles_file=vehicles, fit_charge=args.fit_charge, wind_m_s=args.wind,
                      link_timeout_s=args.link_timeout, lost_giveup_s=args.lost_giveup, return_after_s=returns,
                      fence=not args.no_fence, check_home=not args.allow_home_offset,
                      ready_timeout_s=args.ready_timeout, arm_timeout_s=args.arm_timeout)


def planned_vehicles_file(plan: FleetPlan) -> str | None:
    """The vehicles file `plan` was planned with (`gcs plan --vehicles`, or the one `--continue`
    took from the flight before): its flight is priced with the profiles its ranges came from."""
    options = (plan.raw.get("campaign") or {}).get("options") or {}
    path = options.get("vehicles")
    if not isinstance(path, str):
        return None
    if not Path(path).is_file():
        raise UserError(f"{plan.folder} was planned with the energy profiles of {path}, which is gone: give "
                        f"--vehicles FILE")
    return path


def profiles_from(path: str | None, plan: FleetPlan) -> dict[int, EnergyProfile]:
    """The energy profile of each UAV's vehicle in the vehicles file at `path` (none without one)."""
    if path is None:
        return {}
    from gcs.plans.vehicle_file import load_vehicles, profile_for_uav

    records = load_vehicles(path)
    return {uid: record.profile for uid in plan.uavs if (record := profile_for_uav(records, uid)) is not None}


def run(args: argparse.Namespace) -> int:
    if args.resume:
        return resume(args)
    if args.online and not args.area:
        raise UserError("--online needs --area (the priors of the search map live in the area file)")
    drains = _pairs(args.sim_drain, "--sim-drain")
    if args.plan and not Path(args.plan).is_dir() and not args.area:
        raise UserError(f"plan folder {args.plan} does not exist "
                        f"(make one with: gcs plan --area AREA.geojson --out {args.plan})")
    connections = connections_or_sim(args)
    signing = signing_from(args)
    bus = bus_feed_from(args)
    folder = None
    if args.plan:
        folder = Path(args.plan)
    elif args.area:
        from gcs.plans.planning import area_out_dir

        folder = area_out_dir(args.area, args.out)
    tak = tak_feed_from(args, folder.name if folder is not None else "gcs")
    if folder is not None:
        check_no_flight_in_progress(folder)
    plan, setup = plan_for_flight(args)
    options = options_from(args, plan)
    if any(u not in plan.uavs for u in drains):
        raise UserError("--sim-drain: unknown UAV")
    online = None
    if args.online and setup is not None:  # the planned search, flown again on the vehicles' readings
        from gcs.flight.online import observed_search

        online = observed_search(setup.search.scenario, setup.search.config, seed=setup.search.seed)
    recorder, rrd = None, output_options_from(args).recording_path(Path(plan.folder) / "flight.rrd")
    if rrd is not None or args.rerun_connect is not None:  # rerun is imported only then
        from gcs.recording.flight import new_flight_recorder

        recorder = new_flight_recorder(plan, rrd, args.rerun_connect)
    fleet = None
    if args.sim:
        # a later sortie's readings draw new noise (planner.campaign.sortie_seed)
        pc, pf = sim_sensor(args, plan)  # the plan's (its camera's Pc) unless --pc / --pf are given
        fleet = simulated_fleet(plan, speedup=args.speedup, profile=args.sim_profile,
                                seed=sortie_seed(args.seed, plan_sortie(plan)), pc=pc, pf=pf, drain=drains,
                                loss=args.sim_loss, endurance_s=args.sim_endurance, signing=signing)
        connections = fleet.start().connection_strings()
        print(f"simulated fleet: {len(connections)} vehicles ({args.sim_profile}), speedup {args.speedup:g}, "
              f"sensor Pc {pc:.3g} Pf {pf:.3g}", flush=True)
    try:
        outcome = fly_plan(plan, connections, options, signing=signing, simulated=args.sim, online=online,
                           recorder=recorder, bus=bus, display=_display(), stdin_orders=_stdin_orders(args),
                           watchers=[tak] if tak is not None else [])
    finally:
        if fleet is not None:
            fleet.stop()
    return _ending(outcome)


def _display() -> LiveTable | None:
    return LiveTable() if sys.stdout.isatty() else None


def _stdin_orders(args: argparse.Namespace) -> bool:
    return args.stdin_orders or sys.stdin.isatty()


def _ending(outcome: FlightOutcome) -> int:
    """The summary; the exit code."""
    print(render_summary(outcome.controller))
    print(outcome.sortie.report())
    if outcome.learned:
        print(outcome.learned)
    if outcome.recording is not None:
        print(f"recording {outcome.recording}")
    return outcome.exit_code


# ---- taking over a flight whose station died ----------------------------------------------

#: the flags of the options a flight's journal keeps (`gcs.flight.journal.JOURNALED_OPTIONS`): a resumed
#: flight flies with the journal's values unless they are given again
RESUMED_OPTIONS = {"--reserve-pct": "reserve_pct",
                   "--link-timeout": "link_timeout_s", "--lost-giveup": "lost_giveup_s",
                   "--arm-timeout": "arm_timeout_s", "--ready-timeout": "ready_timeout_s", "--no-fence": "fence",
                   "--allow-home-offset": "check_home"}
RESUME_FLAGS = {"--resume", "--connect", "--signing-key", "--signing-passphrase", "--mqtt", "--fleet", "--mqtt-station",
                "--mqtt-telemetry-hz", "--mqtt-ca-file", "--mqtt-tls-insecure", "--return-after", "--stdin-orders",
                "--no-rrd", "--rerun-connect", "--quiet", *TAK_FLAGS, *RESUMED_OPTIONS}


def _flags_given(args: argparse.Namespace) -> list[str]:
    return [word.split("=", 1)[0] for word in getattr(args, "argv", []) if word.startswith("--")]


def resume(args: argparse.Namespace) -> int:
    """`gcs fly --resume DIR`: read the journal, reconnect, reattach every vehicle and fly on."""
    from gcs.flight.resume import resumable_flight

    given = _flags_given(args)
    foreign = [flag for flag in given if flag not in RESUME_FLAGS]
    if foreign:
        raise UserError(f"--resume flies the flight as it was started: leave out {', '.join(dict.fromkeys(foreign))}")
    folder = Path(args.resume)
    state, plan = resumable_flight(folder)
    connections = connections_from(args) if args.connect else list(state.start.connections)
    signing = signing_from(args)
    if state.start.signed and signing is None:
        raise UserError(f"--resume {folder}: the flight's links were signed: give --signing-key or "
                        "--signing-passphrase again")
    bus = bus_feed_from(args)
    tak = tak_feed_from(args, folder.resolve().name)
    options = resumed_options(options_from(args, plan), state,
                              {name for flag, name in RESUMED_OPTIONS.items() if flag in given})
    recorder = None
    if (state.start.rrd is not None and not args.no_rrd) or args.rerun_connect is not None:
        from gcs.recording.flight import resumed_flight_recorder

        recorder = resumed_flight_recorder(plan, state, record=not args.no_rrd, connect=args.rerun_connect)
    print(f"resuming the flight started {state.start.utc} in {folder} over {', '.join(connections)}", flush=True)
    return _ending(fly_resumed(plan, state, connections, options, signing=signing, recorder=recorder, bus=bus,
                               display=_display(), stdin_orders=_stdin_orders(args),
                               watchers=[tak] if tak is not None else []))
