"""`gcs fly`: upload the plan to every vehicle, arm, start the missions, and watch the fleet
until every vehicle has landed (the controller is `gcs.flight`; the live DTSCS return trigger
and online mode are in docs/fly.md).

`gcs fly --plan DIR --connect udpout:127.0.0.1:14540 ...` flies a `gcs plan --area` folder;
`gcs fly --area AREA.geojson` plans first (the plan command's code path); `--sim` starts the
built-in simulated fleet at the plan's airports, so one command runs the whole job."""

from __future__ import annotations

import argparse
import asyncio
import sys
from pathlib import Path

from gcs.errors import UserError
from gcs.flight import FlyOptions, fly_async
from gcs.fleet import FleetPlan, Stage, load_plan_dir
from gcs.commands._links import add_link_arguments, connections_from, signing_from
from gcs.links import SigningKey
from gcs.sortie import SortieLog
from gcs.status_table import render_summary
from planner.campaign import sortie_seed

# ---- the simulated fleet ------------------------------------------------------------------


def start_sim(plan: FleetPlan, *, speedup: float, profile: str = "ardupilot", seed: int = 0, pc: float = 0.9,
              pf: float = 0.1, drain: dict[int, float] | None = None, loss: float = 0.0,
              endurance_s: float = 1200.0, signing: SigningKey | None = None):
    """The built-in simulated fleet on free loopback ports: vehicle i (system id i) at UAV i's
    airport with its start heading, the plan's targets, a sensor on the plan's grid."""
    from sim import BatteryConfig, FleetOptions, HomePose, LinkFaults, SimFleet, VehicleConfig
    from sim.detector import World

    ids = sorted(plan.uavs)
    if ids != list(range(1, len(ids) + 1)):
        raise UserError(f"--sim needs UAV ids 1..N, the plan has {ids}")
    homes = [HomePose(*plan.uavs[i].airport_lat_lon, 0.0, plan.uavs[i].start_heading * 45.0) for i in ids]
    world = World.of_plan(plan)  # the world `gcs detector` gives real vehicles
    vehicle = plan.uavs[ids[0]].vehicle.value
    config = VehicleConfig(vehicle_type=vehicle, profile=profile, sensor=world.sensor_config(pc, pf),
                           battery=BatteryConfig(endurance_s=endurance_s))
    fleet = SimFleet(homes, config, FleetOptions(base_port=0, speedup=speedup, targets=world.targets, seed=seed,
                                                 faults=LinkFaults(loss=loss, seed=seed),
                                                 signing_key=signing.secret if signing else None,
                                                 grid_origin=world.grid_origin))
    for uid, k in (drain or {}).items():
        fleet.vehicle(uid).set_drain_multiplier(k)
    return fleet


# ---- the command line ---------------------------------------------------------------------


def add_connection_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--plan", metavar="DIR", help="a gcs plan --area output folder")
    add_link_arguments(p)
    p.add_argument("--sim", action="store_true", help="start the built-in simulated fleet at the plan's airports")
    p.add_argument("--speedup", type=float, default=10.0, help="simulated time / real time with --sim")
    p.add_argument("--sim-profile", choices=("ardupilot", "px4"), default="ardupilot", help="autopilot the sim imitates")
    p.add_argument("--sim-loss", type=float, default=0.0, help="packet loss probability on every simulated link")
    p.add_argument("--no-fence", action="store_true", help="do not upload geofence and rally points")


def register(sub: argparse._SubParsersAction) -> None:
    from gcs.missions import planning as area_plan

    p = sub.add_parser("fly", help="upload, fly and watch the whole fleet until it has landed",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter, description=__doc__)
    add_connection_arguments(p)
    from gcs.bus.flight import add_bus_arguments

    add_bus_arguments(p)
    p.add_argument("--reserve-pct", type=float, default=30.0, help="battery kept back by the return trigger")
    p.add_argument("--cruise-speed", type=float, default=10.0, help="vehicles' cruise speed, m/s (range estimate)")
    p.add_argument("--descent-speed", type=float, default=1.5, help="vehicles' landing descent rate, m/s")
    p.add_argument("--return-after", metavar="UAV:SECONDS", action="append", default=[],
                   help="order UAV home after SECONDS (real time), as the operator's 'r UAV' would")
    p.add_argument("--stdin-orders", action="store_true",
                   help="read return orders ('r ID') from stdin even when it is not a terminal")
    p.add_argument("--allow-home-offset", action="store_true",
                   help="fly even when a vehicle's home is more than a cell from its UAV's airport")
    p.add_argument("--arm-timeout", type=float, default=60.0,
                   help="seconds to keep retrying arming while the autopilot refuses (its reasons are shown)")
    p.add_argument("--ready-timeout", type=float, default=180.0,
                   help="seconds to wait for each vehicle's GPS fix, position estimate and home")
    p.add_argument("--link-timeout", type=float, default=3.0, help="seconds without telemetry before a vehicle is lost")
    p.add_argument("--lost-giveup", type=float, default=20.0, help="seconds a lost vehicle is waited for at the end")
    p.add_argument("--sim-endurance", type=float, default=1200.0, help="with --sim: flight endurance of a full battery, s")
    p.add_argument("--sim-drain", metavar="UAV:K", action="append", default=[],
                   help="with --sim: UAV's battery drains K times faster than nominal")
    p.add_argument("--online", action="store_true",
                   help="planner in the loop: re-decide every step from live positions and readings (needs --area)")
    # planning options for --area (the plan command's own arguments)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--np", dest="np_steps", type=int, default=5)
    p.add_argument("--oc", default="3")
    p.add_argument("--range", dest="range_steps", type=int, default=130)
    p.add_argument("--strategy", default="exhaustive")
    p.add_argument("--return", dest="return_planner", default="exact")
    p.add_argument("--reserve", type=int, default=0)
    p.add_argument("--range-aware-search", action="store_true")
    p.add_argument("--pc", type=float, default=0.9)
    p.add_argument("--pf", type=float, default=0.1)
    p.add_argument("--footprint", type=int, default=0)
    p.add_argument("--out", default=None, help="with --area: folder for the plan, missions and flight recording (default: runs/<area name>)")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--rrd", metavar="PATH", help="Rerun recording of the flight (default: flight.rrd in the plan folder)")
    p.add_argument("--no-rrd", action="store_true", help="write no Rerun recording")
    p.add_argument("--rerun-connect", nargs="?", const="rerun+http://127.0.0.1:9876/proxy", metavar="ADDR",
                   help="also stream the flight to a running Rerun viewer (ADDR default: %(const)s)")
    area_plan.add_arguments(p)
    p.set_defaults(func=run)


def _pairs(values: list[str], what: str, kind=float) -> dict[int, float]:
    out = {}
    for text in values:
        try:
            uid, value = text.split(":")
            out[int(uid)] = kind(value)
        except ValueError:
            raise UserError(f"{what} {text!r}: expected UAV:NUMBER") from None
    return out


def plan_namespace(args: argparse.Namespace) -> argparse.Namespace:
    """The `gcs plan --area` arguments for this flight: the plan command's own parser and
    defaults, overlaid with the planning options given to `gcs fly` (no Rerun recording)."""
    from gcs.cli import build_parser

    ns = build_parser().parse_args(["plan", "--area", args.area])
    for name, value in vars(args).items():
        if hasattr(ns, name) and name not in ("func", "command"):
            setattr(ns, name, value)
    if hasattr(ns, "no_rrd"):
        ns.no_rrd = True
        ns.rerun_connect = None
    return ns


def resolve_plan(args: argparse.Namespace) -> FleetPlan:
    """`--plan DIR`, or `--area FILE` planned first by the plan command itself."""
    if getattr(args, "area", None):
        from gcs.commands import plan as plan_command

        if args.plan:
            raise UserError("give --plan or --area, not both")
        from gcs.missions.planning import area_out_dir

        args.out = str(area_out_dir(args))
        plan_command.run(plan_namespace(args))
        return load_plan_dir(args.out)
    if not args.plan:
        raise UserError("give --plan DIR (a gcs plan --area folder) or --area FILE")
    return load_plan_dir(args.plan)


def check_connections(args: argparse.Namespace) -> list[str]:
    """`--sim` or well-formed `--connect` strings, checked before any planning or upload."""
    if args.sim and args.connect:
        raise UserError("--sim starts its own vehicles: leave out --connect")
    if not args.sim and not args.connect:
        raise UserError("give --connect (e.g. udpin:127.0.0.1:14550, tcp:127.0.0.1:5760, /dev/ttyUSB0,57600) or --sim")
    return connections_from(args)


def options_from(args: argparse.Namespace, plan: FleetPlan) -> FlyOptions:
    returns = _pairs(args.return_after, "--return-after")
    unknown = [u for u in returns if u not in plan.uavs]
    if unknown:
        raise UserError(f"--return-after: unknown UAV {unknown[0]} (the plan has {', '.join(map(str, sorted(plan.uavs)))})")
    if not 0 <= args.reserve_pct < 100:
        raise UserError("--reserve-pct must be in [0, 100)")
    return FlyOptions(speed_m_s=args.cruise_speed, reserve_pct=args.reserve_pct, descent_m_s=args.descent_speed,
                      link_timeout_s=args.link_timeout, lost_giveup_s=args.lost_giveup, return_after_s=returns,
                      fence=not args.no_fence, live_table=sys.stdout.isatty(), check_home=not args.allow_home_offset,
                      ready_timeout_s=args.ready_timeout, arm_timeout_s=args.arm_timeout)


def flight_recorder(args: argparse.Namespace, plan: FleetPlan):
    """The flight's Rerun recorder (`flight.rrd` in the plan folder unless `--rrd` / `--no-rrd`),
    or None when nothing is recorded; rerun is imported only then."""
    from gcs.commands.plan import recording_path

    rrd = recording_path(args, Path(plan.folder) / "flight.rrd")
    if rrd is None and args.rerun_connect is None:
        return None
    from gcs.flight_recording import FlightRecorder

    recorder = FlightRecorder(rrd, args.rerun_connect, plan, name=f"flight {Path(plan.folder).name}")
    if args.rerun_connect is not None:
        from gcs.recording import check_viewer

        check_viewer(args.rerun_connect)
    return recorder


def run(args: argparse.Namespace) -> int:
    if args.online and not getattr(args, "area", None):
        raise UserError("--online needs --area (the priors of the search map live in the area file)")
    drains = _pairs(args.sim_drain, "--sim-drain")
    if args.plan and not Path(args.plan).is_dir() and not getattr(args, "area", None):
        raise UserError(f"plan folder {args.plan} does not exist (make one with: gcs plan --area AREA.geojson --out {args.plan})")
    connections = check_connections(args)
    signing = signing_from(args)
    bus = None
    if args.mqtt:
        from gcs.bus.flight import bus_options

        try:
            bus = bus_options(args)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    plan = resolve_plan(args)
    options = options_from(args, plan)
    recorder = flight_recorder(args, plan)
    if any(u not in plan.uavs for u in drains):
        raise UserError("--sim-drain: unknown UAV")
    online = None
    if args.online:
        from gcs.missions import planning as area_plan
        from gcs.online import observed_search

        setup = area_plan.build_area_search(plan_namespace(args))
        online = observed_search(setup.search.scenario, setup.search.config, seed=args.seed)
    sortie = SortieLog(plan)
    fleet = None
    if args.sim:
        # a later sortie's readings draw new noise (planner.campaign.sortie_seed)
        fleet = start_sim(plan, speedup=args.speedup, profile=args.sim_profile,
                          seed=sortie_seed(args.seed, sortie.sortie), pc=args.pc,
                          pf=args.pf, drain=drains, loss=args.sim_loss,
                          endurance_s=args.sim_endurance, signing=signing).start()
        connections = fleet.connection_strings()
        print(f"simulated fleet: {len(connections)} vehicles ({args.sim_profile}), speedup {args.speedup:g}", flush=True)
    try:
        controller = asyncio.run(fly_async(plan, connections, options, stdin_orders=args.stdin_orders or sys.stdin.isatty(), online=online,
                                           recorder=recorder, bus=bus, signing=signing, watchers=[sortie]))
    finally:
        if fleet is not None:
            fleet.stop()
    print(render_summary(controller))
    print(sortie.report())
    if recorder is not None and recorder.rrd_path is not None:
        print(f"recording {recorder.rrd_path}")
    if controller._interrupted:
        return 130
    return 0 if all(st.stage is Stage.LANDED for st in controller.status.values()) else 1
