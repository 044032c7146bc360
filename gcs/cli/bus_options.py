"""The fleet-bus options of `gcs fly` (`--mqtt` and its companions, docs/bus.md)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from gcs.errors import UserError

if TYPE_CHECKING:
    from gcs.bus.flight_feed import BusFeed


def add_bus_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("fleet bus (MQTT, docs/bus.md)")
    g.add_argument("--mqtt", metavar="URL", default=None,
                   help="publish the fleet on this broker and take commands from it: mqtt://[user@]host[:port] or "
                        "mqtts://... (password: $GCS_MQTT_PASSWORD)")
    g.add_argument("--fleet", default="default", help="fleet name on the bus (topics gcs/FLEET/...)")
    g.add_argument("--mqtt-station", default="gcs", help="this station's name on the bus")
    g.add_argument("--mqtt-telemetry-hz", type=float, default=2.0, help="telemetry rate per UAV on the bus")
    g.add_argument("--mqtt-ca-file", default=None, help="mqtts: CA certificate of the broker")
    g.add_argument("--mqtt-tls-insecure", action="store_true", help="mqtts: do not check the broker's host name")


def bus_feed_from(args: argparse.Namespace) -> BusFeed | None:
    """The flight's fleet bus (`gcs.bus.flight_feed.bus_feed`), None without `--mqtt`; a bad
    setting is one error line before anything flies."""
    if not args.mqtt:
        return None
    from gcs.bus.flight_feed import bus_feed

    try:
        return bus_feed(args.mqtt, fleet=args.fleet, station=args.mqtt_station, telemetry_hz=args.mqtt_telemetry_hz,
                        ca_file=args.mqtt_ca_file, tls_insecure=args.mqtt_tls_insecure)
    except ValueError as exc:
        raise UserError(str(exc)) from None
