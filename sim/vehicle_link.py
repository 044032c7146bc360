"""The transport of one vehicle: MAVLink 2 framing, optional signing, injected faults.

Over UDP the vehicle answers whoever spoke to it last (a px4-profile vehicle: whoever spoke
first, as PX4 SITL does) and also pushes to any fixed ground-station addresses (like ArduPilot
SITL's `--out`). It can also serve byte
streams, as a SITL serial port does: a TCP port that ground stations connect to, or a serial
device (`gcs.links.transport`'s TCP server and serial port, reopened when they drop); every
connected stream gets the vehicle's traffic. Faults are drawn from a seeded generator per
link, so a test run repeats exactly.
"""

from __future__ import annotations

import asyncio
import logging
import random
import time
from collections.abc import Hashable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.links.signing import SigningKey

if TYPE_CHECKING:
    from gcs.links.transport import Transport
    from sim.autopilot.vehicle import SimVehicle

log = logging.getLogger(__name__)
Address = tuple[str, int]
_SIGNING_EPOCH_S = 1420070400  # MAVLink signing timestamps count 10 us units from 2015-01-01
_UNSIGNED_OK = frozenset({mavlink.MAVLINK_MSG_ID_RADIO_STATUS})


@dataclass(frozen=True, slots=True, kw_only=True)
class LinkFaults:
    """Per-datagram probabilities (each direction) and extra one-way latency."""

    loss: float = 0.0
    duplicate: float = 0.0
    delay_s: float = 0.0
    jitter_s: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not (0.0 <= self.loss < 1.0 and 0.0 <= self.duplicate <= 1.0):
            raise ValueError("loss must be in [0, 1) and duplicate in [0, 1]")
        if self.delay_s < 0 or self.jitter_s < 0:
            raise ValueError("delay and jitter must not be negative")


def signing_key_from(text: str) -> bytes:
    """64 hex digits are the key itself; anything else is a passphrase hashed with SHA-256
    (MAVProxy's `signing setup` convention)."""
    return SigningKey.from_text(text).secret


class VehicleLink(asyncio.DatagramProtocol):
    """One UDP socket serving one vehicle."""

    def __init__(
        self,
        vehicle: SimVehicle,
        *,
        faults: LinkFaults = LinkFaults(),
        out: tuple[Address, ...] = (),
        signing_key: bytes | None = None,
    ) -> None:
        self.vehicle = vehicle
        self.faults = faults
        self.out = out
        self.peer: Address | None = None
        self.silent = False
        self.transport: asyncio.DatagramTransport | None = None
        self.rejected = 0
        self.sent = 0
        self.received = 0
        self.errors = 0
        self._rng = random.Random(faults.seed * 7919 + vehicle.sysid)
        self.signing_key = signing_key
        self.mav = self._codec()
        self.streams: list[Transport] = []
        self._parsers: dict[Hashable, mavlink.MAVLink] = {}

    def _codec(self) -> mavlink.MAVLink:
        mav = mavlink.MAVLink(None, srcSystem=self.vehicle.sysid, srcComponent=mavlink.MAV_COMP_ID_AUTOPILOT1)
        mav.robust_parsing = True
        if self.signing_key is not None:
            s = mav.signing
            s.secret_key = self.signing_key
            s.sign_outgoing = True
            s.link_id = 0
            s.timestamp = int((time.time() - _SIGNING_EPOCH_S) * 100_000)
            s.allow_unsigned_callback = lambda _mav, msg_id: msg_id in _UNSIGNED_OK
        return mav

    def set_signing_key(self, key: bytes | None) -> None:
        """SETUP_SIGNING: sign with `key` from now on (None or all zeros: stop signing)."""
        self.signing_key = key if key and any(key) else None
        self.mav = self._codec()
        self._parsers.clear()

    def stream_received(self, data: bytes, peer: Hashable) -> None:
        """Bytes from a TCP client or the serial port (the receiver of `gcs.links.transport`)."""
        self.datagram_received(data, ("stream", peer))

    @property
    def keeps_first_peer(self) -> bool:
        """PX4 answers the first address that spoke to it, for good (research `px4` §11)."""
        return self.vehicle.config.profile == "px4"

    @property
    def local_address(self) -> Address:
        assert self.transport is not None
        return self.transport.get_extra_info("sockname")[:2]

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]

    def datagram_received(self, data: bytes, addr: Address) -> None:
        if self.silent or self._lost():
            return
        copies = 2 if self._duplicated() else 1
        delay = self._delay()
        for _ in range(copies):
            if delay > 0:
                asyncio.get_running_loop().call_later(delay, self._receive, data, addr)
            else:
                self._receive(data, addr)

    def _receive(self, data: bytes, addr: Address) -> None:
        parser = self._parsers.get(addr)
        if parser is None:
            parser = self._parsers[addr] = self._codec()
        try:
            msgs = parser.parse_buffer(data) or []
        except mavlink.MAVError:
            self.rejected += 1
            return
        now = time.monotonic()
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                self.rejected += 1
                continue
            self.received += 1
            if msg.get_type() == "SETUP_SIGNING" and msg.target_system in (0, self.vehicle.sysid):
                self.set_signing_key(bytes(msg.secret_key))
                continue
            if addr[0] != "stream" and (self.peer is None or not self.keeps_first_peer):
                self.peer = addr  # only a valid (and, with signing, authenticated) sender is answered
            try:
                replies = self.vehicle.handle(msg, now)
            except Exception:  # a malformed request must not kill the socket
                log.exception("vehicle %d: failed to handle %s", self.vehicle.sysid, msg.get_type())
                self.errors += 1
                continue
            self.send(replies)

    def send(self, msgs: list[mavlink.MAVLink_message]) -> None:
        if self.silent or self.transport is None or not msgs:
            return
        dests: list = list(self.out)
        if self.peer is not None and self.peer not in dests:
            dests.append(self.peer)
        dests += self.streams
        if not dests:
            return
        for msg in msgs:
            buf = msg.pack(self.mav)
            for dest in dests:
                self._transmit(buf, dest)

    def _transmit(self, buf: bytes, dest: Address | Transport) -> None:
        if self._lost():
            return
        copies = 2 if self._duplicated() else 1
        delay = self._delay()
        for _ in range(copies):
            self.sent += 1
            if delay > 0:
                asyncio.get_running_loop().call_later(delay, self._sendto, buf, dest)
            else:
                self._sendto(buf, dest)

    def _sendto(self, buf: bytes, dest: Address | Transport) -> None:
        if not isinstance(dest, tuple):
            dest.send(buf)
        elif self.transport is not None and not self.transport.is_closing():
            self.transport.sendto(buf, dest)

    def _lost(self) -> bool:
        return self.faults.loss > 0 and self._rng.random() < self.faults.loss

    def _duplicated(self) -> bool:
        return self.faults.duplicate > 0 and self._rng.random() < self.faults.duplicate

    def _delay(self) -> float:
        f = self.faults
        if f.delay_s == 0 and f.jitter_s == 0:
            return 0.0
        return f.delay_s + (self._rng.uniform(0.0, f.jitter_s) if f.jitter_s else 0.0)

    def error_received(self, exc: Exception) -> None:
        """ICMP port unreachable (no GCS listening yet): keep serving."""
