"""The MQTT fleet bus: a ground station publishes its fleet's telemetry, retained state and
events and takes commands (`FleetBus`); any other station watches and commands the fleet from
the broker alone (`FleetWatcher`, `gcs watch`). Topic tree and payloads: `gcs.bus.messages`,
docs/bus.md; one JSON Schema per message type in gcs/schemas/bus/."""

from gcs.bus.connection import Broker, TlsOptions, parse_broker_url
from gcs.bus.fleet_bus import BusStats, CommandHandler, FleetBus
from gcs.bus.messages import (
                              EVENT_KINDS,
                              STAGES,
                              Command,
                              CommandKind,
                              InvalidCommand,
                              MessageType,
                              Telemetry,
                              Topics,
                              parse_command,
                              schema_errors,
                              validate,
)
from gcs.bus.watcher import FleetWatcher, Reply, UavView, render_fleet

__all__ = ["EVENT_KINDS", "STAGES", "Broker", "BusStats", "Command", "CommandHandler", "CommandKind", "FleetBus",
           "FleetWatcher", "InvalidCommand", "MessageType", "Reply", "Telemetry", "TlsOptions", "Topics", "UavView",
           "parse_broker_url", "parse_command", "render_fleet", "schema_errors", "validate"]
