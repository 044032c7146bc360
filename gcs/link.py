"""An async MAVLink link over UDP, on pymavlink's message codec.

`MavLink` is an async context manager that owns one datagram endpoint and two background tasks
(the GCS heartbeat and nothing else: receiving is the endpoint's callback). Every decoded
message is offered to the listeners (`subscribe` for all traffic, `listen` for a queue of
chosen message types from one system) and resolves the futures waiting for it, keyed by
(system id, message type, key) — the key is the command of a COMMAND_ACK, the sequence
number of a mission item, or None. The link never blocks: a vehicle that stops answering only
times out the calls addressed to it.

Connection strings follow pymavlink/MAVProxy: `udpout:HOST:PORT` sends to a vehicle (which
answers whoever spoke to it last), `udpin:HOST:PORT` (or `udp:`) listens and answers the last
sender, e.g. an autopilot pushing to a ground-station port."""

from __future__ import annotations

import asyncio
import ipaddress
import os
import socket
import time
from collections import defaultdict
from collections.abc import AsyncIterator, Callable, Iterable
from contextlib import asynccontextmanager
from dataclasses import dataclass

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

__all__ = ["CommandError", "Endpoint", "LinkError", "MavLink", "mavlink", "parse_connection"]

MAVMessage = mavlink.MAVLink_message
GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER
AUTOPILOT_COMPONENT_ID = mavlink.MAV_COMP_ID_AUTOPILOT1
HEARTBEAT_PERIOD_S = 1.0


class LinkError(Exception):
    """A link operation that failed: `operation` says what, `result` the MAV_RESULT (or None on
    a timeout)."""

    def __init__(self, operation: str, result: int | None = None, detail: str = "") -> None:
        self.operation = operation
        self.result = result
        super().__init__(f"{operation}: {detail or _result_name(result)}")


class CommandError(LinkError):
    """A COMMAND_LONG that was refused (result = MAV_RESULT) or never acknowledged (None)."""


def _result_name(result: int | None) -> str:
    if result is None:
        return "no answer (timeout)"
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return entry.name if entry else f"result {result}"


@dataclass(frozen=True, slots=True)
class Endpoint:
    """Where a link's socket points: `mode` is 'out' (we send first) or 'in' (we listen)."""

    mode: str
    host: str
    port: int

    def __str__(self) -> str:
        return f"udp{self.mode}:{self.host}:{self.port}"


def parse_connection(text: str) -> Endpoint:
    """`udpout:HOST:PORT`, `udpin:HOST:PORT` or `udp:HOST:PORT`; ValueError otherwise."""
    parts = text.split(":")
    if len(parts) != 3 or parts[0] not in ("udpout", "udpin", "udp"):
        raise ValueError(f"bad connection string {text!r} (expected udpout:HOST:PORT or udpin:HOST:PORT)")
    kind, host, port_text = parts
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"bad connection string {text!r}: port {port_text!r} is not a number") from None
    if not 0 < port < 65536 and not (kind != "udpout" and port == 0):
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
    return Endpoint("out" if kind == "udpout" else "in", host, port)


class _Writer:
    """The file-like sink pymavlink's encoder writes packed messages to."""

    def __init__(self, link: MavLink) -> None:
        self._link = link

    def write(self, data: bytes) -> None:
        self._link._send_bytes(data)


class _Protocol(asyncio.DatagramProtocol):
    def __init__(self, link: MavLink) -> None:
        self._link = link

    def datagram_received(self, data: bytes, addr: tuple) -> None:
        self._link._on_datagram(data, addr)

    def error_received(self, exc: Exception) -> None:  # ICMP port unreachable: the peer is not up yet
        self._link.errors += 1


class MavLink:
    """One UDP MAVLink link; see the module docstring."""

    def __init__(self, connection: str | Endpoint, *, source_system: int = GCS_SYSTEM_ID,
                 source_component: int = GCS_COMPONENT_ID) -> None:
        self.endpoint = connection if isinstance(connection, Endpoint) else parse_connection(connection)
        self._mav = mavlink.MAVLink(_Writer(self), srcSystem=source_system, srcComponent=source_component)
        self._mav.robust_parsing = True
        self._transport: asyncio.DatagramTransport | None = None
        self._peer: tuple | None = None
        self._tasks: list[asyncio.Task] = []
        self._subscribers: list[Callable[[MAVMessage], None]] = []
        self._queues: dict[int, list[tuple[frozenset[str], asyncio.Queue]]] = defaultdict(list)
        self._waiters: dict[tuple[int, str, object], list[asyncio.Future]] = defaultdict(list)
        self.systems: dict[int, float] = {}  # system id -> monotonic time last heard
        self.received = 0
        self.sent = 0
        self.errors = 0

    def __repr__(self) -> str:
        return f"MavLink({self.endpoint})"

    # ---- lifecycle ---------------------------------------------------------------------

    async def __aenter__(self) -> MavLink:
        loop = asyncio.get_running_loop()
        ep = self.endpoint
        if ep.mode == "out":
            self._peer = (ep.host, ep.port)
            transport, _ = await loop.create_datagram_endpoint(lambda: _Protocol(self), remote_addr=self._peer)
        else:
            transport, _ = await loop.create_datagram_endpoint(lambda: _Protocol(self), local_addr=(ep.host, ep.port))
        self._transport = transport  # type: ignore[assignment]
        self._tasks.append(asyncio.create_task(self._heartbeat_loop(), name=f"heartbeat {ep}"))
        return self

    async def __aexit__(self, *exc: object) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            try:
                await task
            except asyncio.CancelledError:
                pass
        self._tasks.clear()
        for futures in self._waiters.values():
            for fut in futures:
                if not fut.done():
                    fut.cancel()
        self._waiters.clear()
        if self._transport is not None:
            self._transport.close()
            self._transport = None

    @property
    def local_address(self) -> tuple:
        assert self._transport is not None
        return self._transport.get_extra_info("sockname")

    async def _heartbeat_loop(self) -> None:
        while True:
            self.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                                        mavlink.MAV_STATE_ACTIVE, 3))
            await asyncio.sleep(HEARTBEAT_PERIOD_S)

    # ---- sending -----------------------------------------------------------------------

    def send(self, msg: MAVMessage) -> None:
        """Encode and send one message (dropped silently while the link is closed)."""
        if self._transport is None:
            return
        self._mav.send(msg)

    def _send_bytes(self, data: bytes) -> None:
        if self._transport is None:
            return
        if self.endpoint.mode == "out":
            self._transport.sendto(data)
        elif self._peer is not None:
            self._transport.sendto(data, self._peer)
        else:
            return
        self.sent += 1

    # ---- receiving ---------------------------------------------------------------------

    def _on_datagram(self, data: bytes, addr: tuple) -> None:
        if self.endpoint.mode == "in":
            self._peer = addr
        try:
            messages = self._mav.parse_buffer(data) or []
        except Exception:  # a corrupt datagram: count it, keep the link
            self.errors += 1
            return
        now = time.monotonic()
        for msg in messages:
            if msg.get_type() == "BAD_DATA":
                self.errors += 1
                continue
            self.received += 1
            self._dispatch(msg, now)

    def _dispatch(self, msg: MAVMessage, now: float) -> None:
        sysid = msg.get_srcSystem()
        kind = msg.get_type()
        if msg.get_srcComponent() == AUTOPILOT_COMPONENT_ID or kind == "HEARTBEAT":
            self.systems[sysid] = now
        for callback in self._subscribers:
            try:
                callback(msg)
            except Exception:  # a listener's bug must not take the link down
                self.errors += 1
        for types, queue in self._queues.get(sysid, ()):
            if kind in types:
                queue.put_nowait(msg)
        for key in ((sysid, kind, _reply_key(msg)), (sysid, kind, None)):
            futures = self._waiters.get(key)
            if not futures:
                continue
            for fut in futures:
                if not fut.done():
                    fut.set_result(msg)
            del self._waiters[key]

    def subscribe(self, callback: Callable[[MAVMessage], None]) -> None:
        """Call `callback(msg)` for every message received (on the event loop)."""
        self._subscribers.append(callback)

    @asynccontextmanager
    async def listen(self, sysid: int, types: Iterable[str]) -> AsyncIterator[asyncio.Queue]:
        """A queue of every message of `types` from system `sysid` while the context is open."""
        entry = (frozenset(types), asyncio.Queue())
        self._queues[sysid].append(entry)
        try:
            yield entry[1]
        finally:
            self._queues[sysid].remove(entry)

    async def wait_for(self, sysid: int, kind: str, key: object = None, timeout_s: float = 1.0) -> MAVMessage | None:
        """The next `kind` message from `sysid` (with reply key `key`, if given), or None."""
        fut = asyncio.get_running_loop().create_future()
        self._waiters[(sysid, kind, key)].append(fut)
        try:
            return await asyncio.wait_for(fut, timeout_s)
        except TimeoutError:
            return None
        finally:
            waiting = self._waiters.get((sysid, kind, key))
            if waiting and fut in waiting:
                waiting.remove(fut)

    # ---- commands ----------------------------------------------------------------------

    async def command(self, sysid: int, command: int, *params: float, timeout_s: float = 1.0,
                      retries: int = 3, component: int = AUTOPILOT_COMPONENT_ID) -> int:
        """COMMAND_LONG with the command protocol's retransmission (confirmation counts up);
        returns MAV_RESULT_ACCEPTED or raises CommandError carrying the result."""
        p = [float(x) for x in params] + [0.0] * (7 - len(params))
        name = _command_name(command)
        for confirmation in range(retries + 1):
            self.send(mavlink.MAVLink_command_long_message(sysid, component, command, confirmation, *p))
            ack = await self.wait_for(sysid, "COMMAND_ACK", command, timeout_s)
            if ack is None:
                continue
            if ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
                ack = await self.wait_for(sysid, "COMMAND_ACK", command, timeout_s * 10)
                if ack is None:
                    continue
            if ack.result != mavlink.MAV_RESULT_ACCEPTED:
                raise CommandError(f"{name} to vehicle {sysid}", ack.result)
            return ack.result
        raise CommandError(f"{name} to vehicle {sysid}", None,
                           f"no COMMAND_ACK after {retries + 1} tries of {timeout_s:g} s")


def _reply_key(msg: MAVMessage) -> object:
    kind = msg.get_type()
    if kind == "COMMAND_ACK":
        return msg.command
    if kind in ("MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_REQUEST_INT", "MISSION_REQUEST"):
        return msg.seq
    return None


def _command_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name.removeprefix("MAV_CMD_") if entry else f"command {command}"
