"""Command-line options shared by every command that talks to vehicles (`fly`, `upload`,
`watch`, `signing`): where the links go and how they are signed."""

from __future__ import annotations

import argparse
import os

from gcs.errors import UserError
from gcs.links import SigningKey, parse_connection

CONNECT_HELP = ("udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial device "
                "(/dev/ttyUSB0[,BAUD], COM3[,BAUD]; 57600 baud by default); repeatable. Vehicles are told "
                "apart by MAVLink system id, so one link may carry several (a router, MAVProxy, SITLs pushing "
                "to one port)")
PASSPHRASE_ENV = "GCS_SIGNING_PASSPHRASE"


def add_link_arguments(p: argparse.ArgumentParser, *, connect_required: bool = False) -> None:
    p.add_argument("--connect", metavar="CONN", action="append", default=[], required=connect_required,
                   help=CONNECT_HELP)
    add_signing_arguments(p)


def add_signing_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("MAVLink 2 signing (docs/autopilots.md)")
    g.add_argument("--signing-key", metavar="FILE",
                   help="sign everything sent with the key in FILE (64 hex digits, 32 raw bytes, or a passphrase "
                        "on its first line) and refuse unsigned or wrongly signed traffic")
    g.add_argument("--signing-passphrase", metavar="TEXT",
                   help=f"the same with a passphrase (SHA-256, as MAVProxy and QGroundControl); ${PASSPHRASE_ENV} "
                        "is read when neither option is given")


def connections_from(args: argparse.Namespace) -> list[str]:
    """The `--connect` strings, each checked; UserError naming the first bad one."""
    for text in args.connect:
        try:
            parse_connection(text)
        except ValueError as exc:
            raise UserError(str(exc)) from None
    return list(args.connect)


def signing_from(args: argparse.Namespace) -> SigningKey | None:
    """The signing key the options name, or None; UserError when it cannot be read."""
    if args.signing_key and args.signing_passphrase:
        raise UserError("give --signing-key or --signing-passphrase, not both")
    try:
        if args.signing_key:
            return SigningKey.from_file(args.signing_key)
        passphrase = args.signing_passphrase or os.environ.get(PASSPHRASE_ENV)
        return SigningKey.from_passphrase(passphrase) if passphrase else None
    except ValueError as exc:
        raise UserError(str(exc)) from None
