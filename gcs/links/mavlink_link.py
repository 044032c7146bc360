"""An async MAVLink link over any transport (UDP, TCP, serial), on pymavlink's codec.

`MavLink` is an async context manager that owns one transport and the GCS heartbeat task.
Every decoded message is offered to the listeners (`subscribe` for all traffic, `listen` for a
queue of chosen message types from one system) and resolves the futures waiting for it, keyed
by (system id, message type, key): the key is the command of a COMMAND_ACK, the sequence
number of a mission item, or None. The link never blocks: a vehicle that stops answering only
times out the calls addressed to it.

Several vehicles can share one link (a router, MAVProxy, several SITLs pushing to one UDP
port): each system id is answered on the peer it was last heard from, and messages without a
target (our heartbeat) go to every peer. Each peer has its own parser, so interleaved byte
streams never mix. With a `SigningKey`, everything sent is signed and anything unsigned or
wrongly signed is refused and counted (`status` reports it once per system)."""

from __future__ import annotations

import asyncio
import time
from collections import defaultdict
from collections.abc import AsyncIterator, Callable, Hashable, Iterable, Sequence
from contextlib import AsyncExitStack, asynccontextmanager
from itertools import count

from gcs.errors import UserError
from gcs.links.connection import Connection, parse_connection
from gcs.links.mavlink_codec import MAVMessage, mavlink
from gcs.links.signing import SignatureGuard, SignedCodec, SigningKey, enable_signing
from gcs.links.transport import LinkState, LinkStatus, Transport, TransportError, open_transport

__all__ = ["AUTOPILOT_COMPONENT_ID", "CommandError", "GCS_SYSTEM_ID", "LinkError", "LinkUnavailable", "MavLink",
           "command_name", "open_links"]

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER
AUTOPILOT_COMPONENT_ID = mavlink.MAV_COMP_ID_AUTOPILOT1
HEARTBEAT_PERIOD_S = 1.0
_link_ids = count(1)


class LinkError(Exception):
    """A link operation that failed: `operation` says what, `result` the MAV_RESULT (or None on
    a timeout or when the link could not be opened)."""

    def __init__(self, operation: str, result: int | None = None, detail: str = "") -> None:
        self.operation = operation
        self.result = result
        super().__init__(f"{operation}: {detail or _result_name(result)}")


class CommandError(LinkError):
    """A COMMAND_LONG that was refused (result = MAV_RESULT) or never acknowledged (None)."""


class LinkUnavailable(LinkError, UserError):
    """A link that could not be opened (no such device, nothing listening, port in use)."""

    def __init__(self, connection: str, reason: str) -> None:
        super().__init__(f"link {connection}", None, reason)


def _result_name(result: int | None) -> str:
    if result is None:
        return "no answer (timeout)"
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return entry.name if entry else f"result {result}"


class _Capture:
    """The file-like sink pymavlink's encoder writes one packed message to."""

    def __init__(self) -> None:
        self.data = b""

    def write(self, data: bytes) -> None:
        self.data = bytes(data)


class MavLink:
    """One MAVLink link; see the module docstring."""

    def __init__(self, connection: str | Connection, *, signing: SigningKey | None = None,
                 source_system: int = GCS_SYSTEM_ID, source_component: int = GCS_COMPONENT_ID,
                 heartbeat: bool = True) -> None:
        self.connection = connection if isinstance(connection, Connection) else parse_connection(connection)
        self.signing = signing
        self.link_id = next(_link_ids) & 0xFF
        self._capture = _Capture()
        self._encoder = self._codec(self._capture, source_system, source_component, outgoing=True)
        self._source = (source_system, source_component)
        self._parsers: dict[Hashable, mavlink.MAVLink] = {}
        self._route: dict[int, Hashable] = {}
        self._transport: Transport | None = None
        self._heartbeat = heartbeat
        self._tasks: list[asyncio.Task] = []
        self._subscribers: list[Callable[[MAVMessage], None]] = []
        self._status_sinks: list[Callable[[LinkStatus], None]] = []
        self._queues: dict[int, list[tuple[frozenset[str], asyncio.Queue]]] = defaultdict(list)
        self._waiters: dict[tuple[int, str, object], list[asyncio.Future]] = defaultdict(list)
        self.systems: dict[int, float] = {}  # system id -> monotonic time last heard
        self.guard = SignatureGuard()
        self.signing_systems: set[int] = set()  # systems heard signing their messages
        self.history: list[LinkStatus] = []
        self.received = 0
        self.sent = 0
        self.errors = 0

    def __repr__(self) -> str:
        return f"MavLink({self.connection})"

    @property
    def name(self) -> str:
        return str(self.connection)

    def _codec(self, sink: object, system: int, component: int, *, outgoing: bool) -> mavlink.MAVLink:
        codec = SignedCodec(sink, srcSystem=system, srcComponent=component)
        codec.robust_parsing = True
        if self.signing is not None:
            enable_signing(codec, self.signing, self.link_id, sign_outgoing=outgoing)
        return codec

    # ---- lifecycle ---------------------------------------------------------------------

    async def __aenter__(self) -> MavLink:
        try:
            self._transport = await open_transport(self.connection, self._on_bytes, self._on_status)
        except TransportError as exc:
            raise LinkUnavailable(self.name, str(exc)) from None
        if self._heartbeat:
            self._tasks.append(asyncio.create_task(self._heartbeat_loop(), name=f"heartbeat {self.name}"))
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
    def transport(self) -> Transport:
        assert self._transport is not None, "the link is not open"
        return self._transport

    @property
    def local_address(self) -> tuple:
        return self.transport.local_address  # type: ignore[attr-defined]

    async def _heartbeat_loop(self) -> None:
        while True:
            self.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                                        mavlink.MAV_STATE_ACTIVE, 3))
            await asyncio.sleep(HEARTBEAT_PERIOD_S)

    # ---- status ------------------------------------------------------------------------

    def on_status(self, sink: Callable[[LinkStatus], None]) -> None:
        """Call `sink(status)` for every change the operator should see (lost, reconnected,
        a new peer, refused signatures)."""
        self._status_sinks.append(sink)

    def _on_status(self, status: LinkStatus) -> None:
        self.history.append(status)
        for sink in list(self._status_sinks):
            try:
                sink(status)
            except Exception:  # a display bug must not take the link down
                self.errors += 1

    # ---- sending -----------------------------------------------------------------------

    def send(self, msg: MAVMessage) -> None:
        """Encode (and sign) one message and send it to the peer its target system was heard
        on, or to every peer (dropped silently while nobody can be reached)."""
        if self._transport is None:
            return
        self._encoder.send(msg)
        target = getattr(msg, "target_system", 0)
        peer = self._route.get(target) if target else None
        if self._transport.send(self._capture.data, peer):
            self.sent += 1

    # ---- receiving ---------------------------------------------------------------------

    def _on_bytes(self, data: bytes, peer: Hashable) -> None:
        parser = self._parsers.get(peer)
        if parser is None:
            parser = self._parsers[peer] = self._codec(None, *self._source, outgoing=False)
            parser.sender = self._encoder
        try:
            messages = parser.parse_buffer(data) or []
        except Exception:  # a corrupt packet: count it, keep the link
            self.errors += 1
            return
        now = time.monotonic()
        for msg in messages:
            if msg.get_type() == "BAD_DATA":
                self.errors += 1
                if "signature" in str(getattr(msg, "reason", "")).lower():
                    self._refused(bytes(msg.data))
                continue
            self.received += 1
            self._route[msg.get_srcSystem()] = peer
            if msg._header.incompat_flags & mavlink.MAVLINK_IFLAG_SIGNED:
                self.signing_systems.add(msg.get_srcSystem())
            self._dispatch(msg, now)

    def _refused(self, raw: bytes) -> None:
        sysid = self.guard.note(raw)
        if sysid is not None and self.guard.refused[sysid] == 1:
            self._on_status(LinkStatus(self.name, LinkState.SIGNATURE_REFUSED,
                                       f"unsigned or wrongly signed messages from system {sysid} are ignored"))

    def _dispatch(self, msg: MAVMessage, now: float) -> None:
        sysid = msg.get_srcSystem()
        kind = msg.get_type()
        if msg.get_srcComponent() == AUTOPILOT_COMPONENT_ID or (
                kind == "HEARTBEAT" and msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID):
            self.systems[sysid] = now  # a vehicle: its autopilot, not a camera or a station beside it
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
            async with asyncio.timeout(timeout_s):
                return await fut
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
        name = command_name(command)
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


def command_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name.removeprefix("MAV_CMD_") if entry else f"command {command}"


@asynccontextmanager
async def open_links(connections: Sequence[str | Connection], *, signing: SigningKey | None = None
                     ) -> AsyncIterator[list[MavLink]]:
    """Open every link (all signed with `signing`, if given) for the duration of the context;
    LinkUnavailable (one line for the user) when one cannot be opened."""
    async with AsyncExitStack() as stack:
        yield [await stack.enter_async_context(MavLink(c, signing=signing)) for c in connections]
