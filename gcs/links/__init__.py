"""Vehicle links: connection strings, transports (UDP, TCP, serial), MAVLink 2 signing and the
async `MavLink` that the upload, the flight and the watcher talk through."""

from gcs.links.connection import Connection, LinkKind, parse_connection
from gcs.links.mavlink_codec import MAVMessage, mavlink
from gcs.links.mavlink_link import (
                                    AUTOPILOT_COMPONENT_ID,
                                    GCS_SYSTEM_ID,
                                    CommandError,
                                    LinkError,
                                    LinkUnavailable,
                                    MavLink,
                                    command_name,
                                    open_links,
)
from gcs.links.signing import SigningKey, setup_signing_message
from gcs.links.transport import LinkState, LinkStatus

__all__ = ["AUTOPILOT_COMPONENT_ID", "GCS_SYSTEM_ID", "CommandError", "Connection", "LinkError", "LinkKind",
           "LinkState", "LinkStatus", "LinkUnavailable", "MAVMessage", "MavLink", "SigningKey", "command_name",
           "mavlink", "open_links", "parse_connection", "setup_signing_message"]
