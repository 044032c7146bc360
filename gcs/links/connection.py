"""Connection strings as users type them into MAVProxy, QGroundControl or pymavlink.

- `udpin:HOST:PORT`, `udp:HOST:PORT`: listen on a UDP port; vehicles (SITL `--serial1 udpclient:`,
  MAVProxy `--out`, a radio bridge) push to it and are answered at the address each one sends from
- `udpout:HOST:PORT`: send to a vehicle's UDP port first (PX4 SITL, `gcs sim`); it answers us
- `tcp:HOST:PORT`: connect to a TCP server (SITL SERIAL0 `tcp:127.0.0.1:5760`, MAVProxy,
  mavlink-router, a companion computer)
- `tcpin:HOST:PORT`: listen for TCP clients (one or several)
- `/dev/ttyUSB0[,BAUD]`, `COM3[,BAUD]`, `serial:DEVICE[:BAUD]`: a serial port (SiK / RFD900
  telemetry radio, USB to an autopilot), 57600 baud by default as SiK radios ship

`parse_connection` returns a small typed `Connection` or raises ValueError saying what is wrong."""

from __future__ import annotations

import ipaddress
import re
import socket
from dataclasses import dataclass
from enum import Enum

__all__ = ["DEFAULT_BAUD", "BAUD_RATES", "Connection", "LinkKind", "parse_connection"]

DEFAULT_BAUD = 57600
BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 111100, 115200, 230400, 250000, 460800, 500000, 921600,
              1000000, 1500000, 2000000, 3000000)
_WINDOWS_PORT = re.compile(r"^COM[1-9][0-9]{0,2}$", re.IGNORECASE)


class LinkKind(str, Enum):
    UDP_IN = "udpin"
    UDP_OUT = "udpout"
    TCP_CLIENT = "tcp"
    TCP_SERVER = "tcpin"
    SERIAL = "serial"

    @property
    def is_stream(self) -> bool:
        """A byte stream (TCP, serial) rather than datagrams."""
        return self in (LinkKind.TCP_CLIENT, LinkKind.TCP_SERVER, LinkKind.SERIAL)

    @property
    def listens(self) -> bool:
        """We wait for the peers to speak first (and may have several)."""
        return self in (LinkKind.UDP_IN, LinkKind.TCP_SERVER)


@dataclass(frozen=True, slots=True)
class Connection:
    """Where a link goes: a network endpoint (`host`, `port`) or a serial `device` at `baud`.
    `source_port`: the local UDP port a `udpout` link sends from (0: any), so that a restarted
    station speaks from the same address as before (PX4 answers only the first it heard)."""

    kind: LinkKind
    host: str = ""
    port: int = 0
    device: str = ""
    baud: int = DEFAULT_BAUD
    source_port: int = 0

    def __str__(self) -> str:
        if self.kind is LinkKind.SERIAL:
            return f"{self.device},{self.baud}"
        return f"{self.kind.value}:{self.host}:{self.port}"


def parse_connection(text: str) -> Connection:
    """The `Connection` a string names; ValueError with the reason when it names none."""
    text = text.strip()
    if not text:
        raise ValueError("empty connection string")
    head, sep, rest = text.partition(":")
    if sep and head.lower() in ("udpin", "udp", "udpout", "tcp", "tcpin"):
        kind = {"udp": LinkKind.UDP_IN}.get(head.lower()) or LinkKind(head.lower())
        return _network(text, kind, rest)
    if head.lower() == "serial" and sep:
        device, _, baud = rest.rpartition(":") if re.search(r":\d+$", rest) else (rest, "", "")
        return _serial(text, device, baud)
    if text.startswith("/") or _WINDOWS_PORT.match(text.partition(",")[0]):
        device, _, baud = text.partition(",")
        return _serial(text, device, baud)
    raise ValueError(f"bad connection string {text!r}: expected udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, "
                     "tcpin:HOST:PORT or a serial device such as /dev/ttyUSB0,57600 or COM3,57600")


def _network(text: str, kind: LinkKind, rest: str) -> Connection:
    host, sep, port_text = rest.rpartition(":")
    if not sep:
        raise ValueError(f"bad connection string {text!r}: expected {kind.value}:HOST:PORT")
    host = host.strip("[]")
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"bad connection string {text!r}: port {port_text!r} is not a number") from None
    lowest = 0 if kind.listens else 1
    if not lowest <= port < 65536:
        raise ValueError(f"bad connection string {text!r}: port {port} out of range")
    if not host:
        raise ValueError(f"bad connection string {text!r}: no host")
    try:
        ipaddress.ip_address(host)
    except ValueError:
        try:
            socket.getaddrinfo(host, None)
        except OSError:
            raise ValueError(f"bad connection string {text!r}: unknown host {host!r}") from None
    return Connection(kind, host=host, port=port)


def _serial(text: str, device: str, baud_text: str) -> Connection:
    if not device:
        raise ValueError(f"bad connection string {text!r}: no serial device")
    if not baud_text:
        return Connection(LinkKind.SERIAL, device=device)
    try:
        baud = int(baud_text)
    except ValueError:
        raise ValueError(f"bad connection string {text!r}: baud rate {baud_text!r} is not a number") from None
    if baud not in BAUD_RATES:
        raise ValueError(f"bad connection string {text!r}: baud rate {baud} is not one of "
                         f"{', '.join(map(str, BAUD_RATES))}")
    return Connection(LinkKind.SERIAL, device=device, baud=baud)
