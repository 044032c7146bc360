"""`gcs watch`: a second station on the MQTT fleet bus, or a look at vehicles straight over
their MAVLink links. On the bus it shows the live fleet table from the broker alone (retained
states and telemetry) or sends one command and prints its reply; over `--connect` it shows
every vehicle heard (mode, position, battery, GPS, what it still waits for before it can fly).

    gcs watch --mqtt mqtt://127.0.0.1:1883 --fleet demo              # live table, Ctrl-C stops
    gcs watch --mqtt mqtt://127.0.0.1:1883 --fleet demo --once       # print the table once
    gcs watch --mqtt mqtt://operator@broker:1883 --return 2          # order UAV 2 home
    gcs watch --mqtt ... --return all | --range 2=150 | --abort 3
    gcs watch --connect tcp:127.0.0.1:5760 --once                    # vehicles on a link
    gcs watch --connect /dev/ttyUSB0,57600 --connect udpin:0.0.0.0:14550
    gcs watch --mqtt mqtt://broker:1883 --fleet demo --tak tcp://tak.local:8087 --plan runs/demo
                                                    # the fleet on TAK too (docs/tak.md)

Exit 0 when the command was done, 2 with the reason when it was refused or not answered."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import math
import sys
import time
import uuid
from collections.abc import Callable

from gcs.bus import Command, CommandKind, FleetWatcher, TlsOptions, parse_broker_url, render_fleet
from gcs.cli.link_options import add_link_arguments, connections_from, signing_from
from gcs.cli.tak_options import add_tak_arguments, tak_setup_from
from gcs.errors import UserError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("watch", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mqtt", metavar="URL",
                   help="broker: mqtt://[user@]host[:port] or mqtts://... (password: --password or $GCS_MQTT_PASSWORD)")
    add_link_arguments(p)
    p.add_argument("--fleet", default="default", help="fleet name (topic gcs/FLEET/...; default: default)")
    p.add_argument("--username", help="broker user name (overrides the URL's)")
    p.add_argument("--password", help="broker password (prefer $GCS_MQTT_PASSWORD)")
    p.add_argument("--ca-file", help="mqtts: CA certificate that signed the broker's certificate")
    p.add_argument("--cert-file", help="mqtts: client certificate")
    p.add_argument("--key-file", help="mqtts: client key")
    p.add_argument("--tls-insecure", action="store_true", help="mqtts: do not check the broker's host name")
    what = p.add_mutually_exclusive_group()
    what.add_argument("--return", dest="return_uav", metavar="ID|all", help="order UAV ID (or all) home")
    what.add_argument("--range", dest="range_change", metavar="ID=METRES",
                      help="set UAV ID's range T_i: metres along its plan from take-off")
    what.add_argument("--abort", dest="abort_uav", metavar="ID|all", help="autopilot RTL for UAV ID (or all) at once")
    p.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for the reply (default 5)")
    p.add_argument("--once", action="store_true",
                   help="print the table once, after --duration-s (default 1 s on the bus, 3 s on links)")
    p.add_argument("--duration-s", type=float, default=None,
                   help="watch this long, print the table, exit (default: until Ctrl-C; 1 with --once)")
    p.add_argument("--every-s", type=float, default=1.0, help="refresh period of the live table (default 1 s)")
    add_tak_arguments(p, "the fleet name")
    p.add_argument("--plan", metavar="DIR", default=None,
                   help="with --tak: the flight's plan folder, to put its area, keep-out zones and paths on TAK too")
    p.set_defaults(func=run)


def _uav(value: str, option: str) -> int | None:
    if value == "all":
        return None
    try:
        uav = int(value)
    except ValueError:
        uav = 0
    if uav < 1:
        raise UserError(f"{option}: expected a UAV id (1, 2, ...) or 'all', not {value!r}")
    return uav


def command_from(args: argparse.Namespace) -> Command | None:
    request_id = f"watch-{uuid.uuid4().hex[:12]}"
    if args.return_uav is not None:
        return Command(request_id, CommandKind.RETURN, _uav(args.return_uav, "--return"), sender="gcs watch")
    if args.abort_uav is not None:
        return Command(request_id, CommandKind.ABORT, _uav(args.abort_uav, "--abort"), sender="gcs watch")
    if args.range_change is not None:
        uav_text, _, metres_text = args.range_change.partition("=")
        uav = _uav(uav_text, "--range")
        try:
            metres = float(metres_text)
        except ValueError:
            metres = 0.0
        if uav is None or not (math.isfinite(metres) and metres > 0):
            raise UserError("--range: expected ID=METRES with a UAV id and a positive number of metres, "
                            f"not {args.range_change!r}")
        return Command(request_id, CommandKind.RANGE, uav, range_m=metres, sender="gcs watch")
    return None


async def _show(render: Callable[[], str], duration_s: float | None, every_s: float,
                failure: Callable[[], str | None] = lambda: None) -> None:
    """Redraw `render()` every `every_s` until Ctrl-C (in place on a terminal); with a duration,
    print it once when the time is up. ConnectionError when `failure()` says why the source died."""
    live = sys.stdout.isatty() and duration_s is None
    end = None if duration_s is None else time.monotonic() + duration_s
    while end is None or time.monotonic() < end:
        if (error := failure()) is not None:
            raise ConnectionError(error)
        await asyncio.sleep(every_s if end is None else max(0.0, min(every_s, end - time.monotonic())))
        if end is None:
            sys.stdout.write(("\x1b[H\x1b[2J" if live else "") + render() + "\n\n")
            sys.stdout.flush()
    print(render(), flush=True)


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


async def _run(args: argparse.Namespace, command: Command | None, tak=None, plan=None) -> int:
    tls = None
    if any((args.ca_file, args.cert_file, args.key_file, args.tls_insecure)):
        tls = TlsOptions(args.ca_file, args.cert_file, args.key_file, args.tls_insecure)
    try:
        broker = parse_broker_url(args.mqtt, username=args.username, password=args.password, tls=tls)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    try:
        async with FleetWatcher(broker, fleet=args.fleet) as watcher, contextlib.AsyncExitStack() as stack:
            if tak is not None:
                from gcs.tak.bus_feed import tak_on_bus

                await stack.enter_async_context(tak_on_bus(watcher, *tak, plan=plan, say=_say))
            if command is None:
                duration = args.duration_s if args.duration_s is not None else (1.0 if args.once else None)
                await _show(lambda: render_fleet(watcher), duration, args.every_s, lambda: watcher.error)
                return 0
            try:
                reply = await watcher.command(command, args.timeout)
            except TimeoutError:
                raise UserError(f"no reply to {command.kind.value} within {args.timeout:g} s (is a station of fleet "
                                f"{args.fleet!r} on the bus, and may this user send commands?)") from None
    except ConnectionError as exc:
        raise UserError(str(exc)) from None
    if not reply.ok:
        raise UserError(f"{command.kind.value} refused by {reply.station}: {reply.reason}")
    target = "all UAVs" if command.uav is None else f"UAV {command.uav}"
    print(f"{command.kind.value} {target}: done (station {reply.station})", flush=True)
    return 0


async def _watch_links(args: argparse.Namespace) -> int:
    from gcs.telemetry.link_watch import LinkWatcher, render_vehicles

    async with LinkWatcher(connections_from(args), signing=signing_from(args)) as watcher:
        duration = args.duration_s if args.duration_s is not None else (3.0 if args.once else None)
        await _show(lambda: render_vehicles(watcher), duration, args.every_s)
    return 0


def run(args: argparse.Namespace) -> int:
    if args.duration_s is not None and args.duration_s < 0:
        raise UserError("--duration-s must be >= 0")
    if bool(args.mqtt) == bool(args.connect):
        raise UserError("give --mqtt URL (the fleet bus) or --connect CONN (vehicles' MAVLink links), one of them")
    if args.connect and (args.tak or args.plan):
        raise UserError("--tak puts the fleet on the bus on TAK: give --mqtt (gcs fly --tak does it from the links)")
    if args.plan and not args.tak:
        raise UserError("--plan goes with --tak (it puts the plan's area and paths on TAK)")
    if args.connect:
        if any(v is not None for v in (args.return_uav, args.range_change, args.abort_uav)):
            raise UserError("--return, --range and --abort go to the flying station over the bus: give --mqtt")
        try:
            return asyncio.run(_watch_links(args))
        except KeyboardInterrupt:
            return 130
    command = command_from(args)
    try:
        from gcs.bus.messages import check_name

        check_name(args.fleet, "--fleet")
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if command is not None and args.tak:
        raise UserError("--tak watches the fleet: it does not go with --return, --range or --abort")
    tak = tak_setup_from(args, args.fleet)
    plan = None
    if args.plan:
        from gcs.plans.plan_folder import load_plan_dir

        plan = load_plan_dir(args.plan)
    try:
        return asyncio.run(_run(args, command, tak, plan))
    except KeyboardInterrupt:
        return 130
