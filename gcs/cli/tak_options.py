"""The TAK options of `gcs fly` and `gcs watch` (`--tak` and its companions, docs/tak.md). pytak
is loaded only when `--tak` is given."""

from __future__ import annotations

import argparse
import os
import re
from typing import TYPE_CHECKING

from gcs.errors import UserError
from gcs.tak.settings import TakSettings

if TYPE_CHECKING:
    from gcs.tak.destination import TakDestination
    from gcs.tak.flight_feed import TakFeed

_NAME = re.compile(r"^[A-Za-z0-9_-]{1,32}$")
_NEEDS_TAK = {"tak_cert": "--tak-cert", "tak_key": "--tak-key", "tak_ca": "--tak-ca", "tak_insecure": "--tak-insecure",
              "tak_interface": "--tak-interface"}
#: the flags `gcs fly --resume` takes again
TAK_FLAGS = ("--tak", "--tak-name", "--tak-every-s", "--tak-stale-s", "--tak-cert", "--tak-key", "--tak-ca",
             "--tak-insecure", "--tak-interface", "--tak-protocol")


def add_tak_arguments(p: argparse.ArgumentParser, name_default: str) -> None:
    g = p.add_argument_group("TAK (Cursor-on-Target for ATAK, WinTAK, iTAK and TAK servers, docs/tak.md)")
    g.add_argument("--tak", metavar="URL", action="append", default=[],
                   help="put the fleet on TAK: tcp://HOST[:8087] (a TAK server's CoT input), tls://HOST[:8089] (with "
                        "--tak-cert), udp://239.2.3.1[:6969] (the mesh's SA group); repeat for several")
    g.add_argument("--tak-name", default=None,
                   help=f"name on every TAK item: uids gcs.NAME.*, callsigns 'NAME UAV1' (default: {name_default})")
    g.add_argument("--tak-every-s", type=float, default=TakSettings.every_s,
                   help=f"seconds between a vehicle's positions on TAK (default {TakSettings.every_s:g})")
    g.add_argument("--tak-stale-s", type=float, default=TakSettings.stale_s,
                   help=f"a vehicle not heard for this long fades on the map (default {TakSettings.stale_s:g})")
    g.add_argument("--tak-cert", metavar="FILE", default=None,
                   help="tls: client certificate: PEM (its key in it or --tak-key) or .p12 "
                        "(password: $GCS_TAK_CERT_PASSWORD)")
    g.add_argument("--tak-key", metavar="FILE", default=None, help="tls: the client certificate's key (PEM)")
    g.add_argument("--tak-ca", metavar="FILE", default=None,
                   help="tls: CA certificate that signed the TAK server's (default: the system's)")
    g.add_argument("--tak-insecure", action="store_true", help="tls: do not check the TAK server's host name")
    g.add_argument("--tak-interface", metavar="ADDR", default=None,
                   help="udp: this machine's address the multicast leaves from (default: the system's choice)")
    g.add_argument("--tak-protocol", choices=("xml", "protobuf"), default="xml",
                   help="CoT XML, or TAK protocol 1 (protobuf) (default xml: every TAK client reads it)")


def tak_setup_from(args: argparse.Namespace, name_default: str) -> tuple[list[TakDestination], TakSettings] | None:
    """The checked destinations and settings, None without `--tak`; a bad setting is one error
    line before anything flies."""
    if not args.tak:
        given = [flag for attr, flag in _NEEDS_TAK.items() if getattr(args, attr)]
        if given:
            raise UserError(f"{given[0]} needs --tak URL")
        return None
    name = args.tak_name or _name_from(name_default)
    if not _NAME.match(name):
        raise UserError(f"--tak-name {name!r} must be 1-32 letters, digits, '_' or '-'")
    if not args.tak_every_s > 0:
        raise UserError("--tak-every-s must be > 0")
    if not args.tak_stale_s > args.tak_every_s:
        raise UserError("--tak-stale-s must be longer than --tak-every-s (a vehicle would fade between its positions)")
    from gcs.tak.destination import TakProtocol, TakTls, check_tls, parse_tak_url

    tls = None
    if args.tak_cert:
        tls = TakTls(args.tak_cert, args.tak_key, args.tak_ca, os.environ.get("GCS_TAK_CERT_PASSWORD"),
                     args.tak_insecure)
    elif args.tak_key or args.tak_ca or args.tak_insecure:
        raise UserError("--tak-key, --tak-ca and --tak-insecure go with --tak-cert (a tls:// TAK server)")
    if args.tak_interface and not any(url.lower().startswith("udp:") for url in args.tak):
        raise UserError("--tak-interface is for the mesh: it goes with a udp:// --tak")
    destinations = []
    try:
        for url in args.tak:
            destination = parse_tak_url(url, tls=tls, interface=args.tak_interface,
                                        protocol=TakProtocol(args.tak_protocol))
            check_tls(destination)
            destinations.append(destination)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    return destinations, TakSettings(name, every_s=args.tak_every_s, stale_s=args.tak_stale_s)


def tak_feed_from(args: argparse.Namespace, name_default: str) -> TakFeed | None:
    """`gcs fly`'s TAK watcher (`gcs.tak.flight_feed.TakFeed`), None without `--tak`."""
    setup = tak_setup_from(args, name_default)
    if setup is None:
        return None
    from gcs.tak.flight_feed import TakFeed

    return TakFeed(*setup)


def _name_from(text: str) -> str:
    """A usable default name from a folder or fleet name."""
    name = re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-")[:32]
    return name or "gcs"
