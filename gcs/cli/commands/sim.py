"""`gcs sim`: run simulated MAVLink vehicles on loopback UDP until interrupted.

With `--area` the vehicles stand at the area's airports and sense the world `gcs plan --area`
lays out from the same file and options: its grid (cell size, south-west corner) and its target
cells, so a plan of that area flown against them reads the cells it planned. With `--plan` they
stand at a plan folder's airports and sense its world as `gcs fly --sim` does. The sensor's Pc
and Pf default to the planner's; with `--plan`, to the plan's (its camera's Pc when it was made
with `--camera-fov`)."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import ipaddress
import signal
import sys
from dataclasses import dataclass

from gcs.errors import UserError
from gcs.plans.options import DEFAULT_CELL_SIZE_M, SearchOptions

DEFAULT_HOME = "-35.363261,149.165230,353"  # ArduPilot SITL's default location (CMAC)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "sim", description="Start N kinematic MAVLink vehicles; vehicle i listens on UDP BASE+i-1.",
    )
    p.add_argument("--vehicles", type=int, default=1, metavar="N", help="number of vehicles (default 1)")
    p.add_argument("--home", action="append", metavar="LAT,LON[,HEADING]",
                   help=f"home pose, once per vehicle or once for all (default {DEFAULT_HOME})")
    p.add_argument("--area", default=None, metavar="FILE",
                   help="one vehicle per airport of an area file (home, heading), with its targets")
    p.add_argument("--plan", default=None, metavar="DIR",
                   help="or one vehicle per airport of a gcs plan --area folder, in its world (grid, targets, and "
                        "the plan's Pc and Pf unless --pc / --pf are given)")
    p.add_argument("--home-alt-m", type=float, default=0.0, help="ground altitude AMSL of every home")
    p.add_argument("--base-port", type=int, default=14540, help="UDP port of vehicle 1 (default 14540)")
    p.add_argument("--bind", default="127.0.0.1", help="address to listen on (default loopback only)")
    p.add_argument("--out", action="append", default=[], metavar="udp:HOST:PORT",
                   help="also push every vehicle's traffic to this ground station address")
    p.add_argument("--speedup", type=float, default=1.0, metavar="K", help="simulated time runs K times faster")
    p.add_argument("--duration-s", type=float, default=None, help="exit after this many real seconds")
    p.add_argument("--vehicle-type", choices=("copter", "plane"), default="copter")
    p.add_argument("--profile", choices=("ardupilot", "px4"), default="ardupilot",
                   help="autopilot to imitate: modes, heartbeat, mission item 0 as home (ardupilot)")
    p.add_argument("--telemetry-hz", type=float, default=4.0, help="position/attitude/HUD rate (default 4)")
    p.add_argument("--cruise-speed-m-s", type=float, default=None)
    p.add_argument("--turn-rate-deg-s", type=float, default=None)
    p.add_argument("--endurance-s", type=float, default=1200.0, help="flight time on a full battery")
    p.add_argument("--low-battery-pct", type=float, default=20.0, help="RTL failsafe threshold")
    p.add_argument("--drain-multiplier", type=float, default=1.0, help="battery drains K times faster")
    p.add_argument("--fail-battery", action="append", type=int, default=[], metavar="SYSID",
                   help="this vehicle's battery fails at start (critical failsafe)")
    p.add_argument("--loss", type=float, default=0.0, help="datagram loss probability per direction")
    p.add_argument("--duplicate", type=float, default=0.0, help="datagram duplication probability")
    p.add_argument("--delay-ms", type=float, default=0.0, help="extra one-way latency")
    p.add_argument("--jitter-ms", type=float, default=0.0, help="random extra latency, uniform 0..J")
    p.add_argument("--seed", type=int, default=0, help="seed for faults and sensor draws")
    p.add_argument("--silent", action="append", default=[], metavar="SYSID[@SECONDS]",
                   help="vehicle stops answering (after SECONDS of simulated time)")
    p.add_argument("--target", action="append", default=[], metavar="LAT,LON", help="a target on the ground")
    p.add_argument("--cell-size", "--cell-size-m", dest="cell_size_m", metavar="METRES", type=float, default=None,
                   help=f"sensor grid cell side (default: with --area the file's cell_size_m, else "
                        f"{DEFAULT_CELL_SIZE_M:g}, as gcs plan)")
    p.add_argument("--margin", dest="margin_m", metavar="METRES", type=float, default=0.0,
                   help="with --area: the safety margin the plan uses (it shapes the grid)")
    p.add_argument("--pc", type=float, default=SearchOptions.pc,
                   help=f"sensor detection probability (default {SearchOptions.pc:g}, as gcs plan; with --plan the "
                        f"plan's, its camera's Pc when it was made with --camera-fov)")
    p.add_argument("--pf", type=float, default=SearchOptions.pf,
                   help=f"sensor false-alarm probability (default {SearchOptions.pf:g}, as gcs plan; with --plan the "
                        f"plan's)")
    p.add_argument("--signing-key", default=None, metavar="HEX|PASSPHRASE",
                   help="MAVLink 2 signing: 64 hex digits, or a passphrase (SHA-256, as MAVProxy)")
    p.set_defaults(func=run)


@dataclass(frozen=True, slots=True)
class _Silent:
    sysid: int
    after_s: float


def run(args: argparse.Namespace) -> int:
    if args.plan is not None:
        if args.home or args.area is not None:
            raise UserError("give one of --plan, --area or --home")
        homes, world = _plan_world(args)
        args.vehicles = len(homes)
        return serve(homes, args, world)
    if args.area is not None:
        if args.home:
            raise UserError("give either --area or --home, not both")
        homes, world = _area_world(args)
        args.vehicles = len(homes)
        return serve(homes, args, world)
    homes = [_parse_home(text, args.home_alt_m) for text in (args.home or [DEFAULT_HOME])]
    return serve(homes, args)


def _area_world(args: argparse.Namespace):
    """Home poses at an area file's airports (in file order: vehicle i flies UAV i) and the world
    `gcs plan --area` lays out from it (`sim.detector.World.of_area`)."""
    from gcs.plans.options import AreaOptions
    from gcs.plans.planning import build_area_search
    from sim import HomePose
    from sim.detector import World

    setup = build_area_search(args.area, AreaOptions(cell_size_m=args.cell_size_m, margin_m=args.margin_m))
    homes = [HomePose(a.lat_deg, a.lon_deg, args.home_alt_m, a.heading * 45.0) for a in setup.source.airports]
    return homes, World.of_area(setup)


def _plan_world(args: argparse.Namespace):
    """Home poses at a plan folder's airports (vehicle i flies UAV i, as `gcs fly --sim` puts
    them) and its world (`sim.detector.World.of_plan`); `args.pc`, `args.pf` and
    `args.vehicle_type` become the plan's unless given (`gcs.cli.sim_options.sim_sensor`)."""
    from gcs.cli import given_options
    from gcs.cli.sim_options import sim_sensor
    from gcs.plans.plan_folder import load_plan_dir
    from sim.detector import World
    from sim.plan_fleet import plan_homes

    plan = load_plan_dir(args.plan)
    try:
        homes = plan_homes(plan, args.home_alt_m)
    except ValueError as exc:
        raise UserError(f"--plan: {exc}") from None
    args.pc, args.pf = sim_sensor(args, plan)
    if "vehicle_type" not in given_options(args):
        args.vehicle_type = next(iter(plan.uavs.values())).vehicle.value
    return homes, World.of_plan(plan)


def serve(poses: list, args: argparse.Namespace, world=None) -> int:
    """Validate the rest of `args` and run the fleet from `poses` (1 or N HomePose), sensing
    `world` (a `sim.detector.World`: grid and targets) when given."""
    from sim import BatteryConfig, FleetOptions, LinkFaults, SensorConfig, SimFleet, VehicleConfig, homes_for
    from sim.vehicle_link import signing_key_from

    n = args.vehicles
    if not 1 <= n <= 250:
        raise UserError(f"--vehicles must be between 1 and 250, got {n}")
    if len(poses) not in (1, n):
        raise UserError(f"give --home once or {n} times (once per vehicle), got {len(poses)}")
    if not 1 <= args.base_port <= 65536 - n:
        raise UserError(f"--base-port {args.base_port} leaves no room for {n} vehicles below 65536")
    _check_address(args.bind)
    _positive("--speedup", args.speedup)
    _positive("--telemetry-hz", args.telemetry_hz)
    _positive("--endurance-s", args.endurance_s)
    for name in ("cruise_speed_m_s", "turn_rate_deg_s"):
        if getattr(args, name) is not None:
            _positive("--" + name.replace("_", "-"), getattr(args, name))
    if args.duration_s is not None:
        _positive("--duration-s", args.duration_s)
    cell_size_m = world.cell_size_m if world is not None else args.cell_size_m or DEFAULT_CELL_SIZE_M
    if cell_size_m <= 0:
        raise UserError(f"--cell-size must be positive, got {cell_size_m:g}")
    for name in ("pc", "pf", "duplicate"):
        if not 0.0 <= getattr(args, name) <= 1.0:
            raise UserError(f"--{name} must be a probability in [0, 1], got {getattr(args, name):g}")
    if not 0.0 <= args.loss < 1.0:
        raise UserError(f"--loss must be in [0, 1), got {args.loss:g}")
    if not 0.0 <= args.low_battery_pct < 100.0:
        raise UserError(f"--low-battery-pct must be in [0, 100), got {args.low_battery_pct:g}")
    if args.drain_multiplier < 0 or args.delay_ms < 0 or args.jitter_ms < 0:
        raise UserError("--drain-multiplier, --delay-ms and --jitter-ms must not be negative")
    silent = [_parse_silent(text, n) for text in args.silent]
    for sysid in args.fail_battery:
        _check_sysid("--fail-battery", sysid, n)
    targets = tuple(_parse_latlon("--target", text) for text in args.target) + (world.targets if world else ())
    out = tuple(_parse_out(text) for text in args.out)
    key = None
    if args.signing_key is not None:
        try:
            key = signing_key_from(args.signing_key)
        except ValueError as exc:
            raise UserError(f"--signing-key: {exc}") from None

    config = VehicleConfig(
        vehicle_type=args.vehicle_type, profile=args.profile, telemetry_hz=args.telemetry_hz,
        cruise_speed_m_s=args.cruise_speed_m_s, turn_rate_deg_s=args.turn_rate_deg_s,
        battery=BatteryConfig(endurance_s=args.endurance_s, low_pct=args.low_battery_pct,
                              critical_pct=min(5.0, args.low_battery_pct)),
        sensor=SensorConfig(cell_size_m=cell_size_m, pc=args.pc, pf=args.pf),
    )
    options = FleetOptions(
        base_port=args.base_port, bind=args.bind, out=out, speedup=args.speedup, signing_key=key,
        faults=LinkFaults(loss=args.loss, duplicate=args.duplicate, delay_s=args.delay_ms / 1000,
                          jitter_s=args.jitter_ms / 1000, seed=args.seed),
        targets=targets, seed=args.seed, grid_origin=world.grid_origin if world is not None else None,
    )
    fleet = SimFleet(homes_for(n, poses), config, options)
    for v in fleet.vehicles:
        v.set_drain_multiplier(args.drain_multiplier)
        if v.sysid in args.fail_battery:
            v.fail_battery()
    for s in silent:
        fleet.stop_answering(s.sysid, s.after_s)
    try:
        asyncio.run(_serve(fleet, args.duration_s))
    except OSError as exc:
        raise UserError(f"cannot listen on {args.bind} ports {args.base_port}-{args.base_port + n - 1}: "
                        f"{exc.strerror or exc}") from None
    return 0


async def _serve(fleet, duration_s: float | None) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    async with fleet:
        cfg, opts = fleet.config, fleet.options
        print(f"gcs sim: {len(fleet.vehicles)} {cfg.vehicle_type}(s), profile {cfg.profile}, "
              f"speedup {opts.speedup:g}, sensor Pc {cfg.sensor.pc:.3g} Pf {cfg.sensor.pf:.3g}"
              f"{', signing on' if opts.signing_key else ''}", flush=True)
        for v, (host, port) in zip(fleet.vehicles, fleet.addresses, strict=True):
            print(f"vehicle {v.sysid}: sysid {v.sysid} comp 1  udpout:{host}:{port}  "
                  f"(MAVSDK: udpout://{host}:{port})", flush=True)
        for host, port in opts.out:
            print(f"pushing to ground station udp:{host}:{port}", flush=True)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(duration_s):
                await stop.wait()
    print("gcs sim: stopped", file=sys.stderr, flush=True)


def _positive(flag: str, value: float) -> None:
    if not value > 0:
        raise UserError(f"{flag} must be positive, got {value:g}")


def _floats(flag: str, text: str) -> list[float]:
    try:
        return [float(part) for part in text.split(",")]
    except ValueError:
        raise UserError(f"{flag}: expected numbers separated by commas, got {text!r}") from None


def _parse_latlon(flag: str, text: str) -> tuple[float, float]:
    values = _floats(flag, text)
    if len(values) != 2:
        raise UserError(f"{flag}: expected LAT,LON, got {text!r}")
    _check_latlon(flag, *values)
    return values[0], values[1]


def _check_latlon(flag: str, lat: float, lon: float) -> None:
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise UserError(f"{flag}: latitude must be in [-90, 90] and longitude in [-180, 180], got {lat:g},{lon:g}")


def _parse_home(text: str, alt_m: float):
    from sim import HomePose

    values = _floats("--home", text)
    if len(values) not in (2, 3):
        raise UserError(f"--home: expected LAT,LON[,HEADING], got {text!r}")
    _check_latlon("--home", values[0], values[1])
    heading = values[2] % 360.0 if len(values) == 3 else 0.0
    return HomePose(values[0], values[1], alt_m, heading)


def _parse_out(text: str) -> tuple[str, int]:
    scheme, _, rest = text.partition(":")
    host, _, port = rest.rpartition(":")
    if scheme not in ("udp", "udpout") or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise UserError(f"--out: expected udp:HOST:PORT, got {text!r}")
    _check_address(host, "--out")
    return host, int(port)


def _check_address(host: str, flag: str = "--bind") -> None:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        if host != "localhost":
            raise UserError(f"{flag}: not an IP address: {host!r}") from None


def _check_sysid(flag: str, sysid: int, n: int) -> None:
    if not 1 <= sysid <= n:
        raise UserError(f"{flag}: no vehicle with system id {sysid} (have 1..{n})")


def _parse_silent(text: str, n: int) -> _Silent:
    sysid_text, _, after = text.partition("@")
    try:
        silent = _Silent(int(sysid_text), float(after) if after else 0.0)
    except ValueError:
        raise UserError(f"--silent: expected SYSID[@SECONDS], got {text!r}") from None
    _check_sysid("--silent", silent.sysid, n)
    if silent.after_s < 0:
        raise UserError(f"--silent: SECONDS must not be negative, got {text!r}")
    return silent
