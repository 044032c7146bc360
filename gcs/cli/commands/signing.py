"""`gcs signing`: give vehicles the station's MAVLink 2 signing key (SETUP_SIGNING), or take
it away, over a link you trust (USB, or a bench link before the flight), then check it took:
every vehicle must answer a signed request and sign what it sends.

    gcs signing --connect tcp:127.0.0.1:5760 --signing-key station.key
    gcs signing --connect /dev/ttyACM0,115200 --signing-passphrase "correct horse" --uav 2
    gcs signing --connect tcp:127.0.0.1:5760 --signing-key station.key --remove

Afterwards fly with the same `--signing-key`: the station signs everything and refuses what is
not signed with it. ArduPilot keeps accepting unsigned messages on its first port (USB; SITL's
SERIAL0), which it treats as secure. See docs/autopilots.md."""

from __future__ import annotations

import argparse
import asyncio

from gcs.autopilots.signing_setup import provision
from gcs.cli.link_options import add_link_arguments, connections_from, signing_from
from gcs.errors import UserError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("signing", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_link_arguments(p, connect_required=True)
    p.add_argument("--uav", type=int, action="append", default=[], metavar="ID",
                   help="only this system id (repeatable; default: every vehicle heard)")
    p.add_argument("--remove", action="store_true", help="remove the key (the vehicles must hold the key given)")
    p.add_argument("--wait", type=float, default=5.0, help="seconds to listen for vehicles (default 5)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    connections = connections_from(args)
    key = signing_from(args)
    if key is None:
        raise UserError("give --signing-key FILE or --signing-passphrase TEXT")
    outcome = asyncio.run(provision(connections, key, sorted(set(args.uav)), remove=args.remove, wait_s=args.wait))
    for uid, text in sorted(outcome.items()):
        print(f"UAV {uid}: {text}")
    good = sum(text.startswith("ok") for text in outcome.values())
    print(f"{good}/{len(outcome)} vehicles {'cleared' if args.remove else 'signing'}")
    return 0 if good == len(outcome) else 1
