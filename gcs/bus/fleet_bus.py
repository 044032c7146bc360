"""`FleetBus`: a ground station's side of the MQTT fleet bus.

An async context manager owning its background tasks in a TaskGroup (cancelled on exit):

* one connection task that connects, runs the senders and the command receiver, and on any
  broker loss reconnects with exponential backoff (`reconnect_min_s` doubling to
  `reconnect_max_s`), forever;
* telemetry: `telemetry()` only replaces the UAV's latest sample; a sender publishes each UAV's
  newest sample at most `telemetry_hz` times a second (QoS 0). Nothing is kept while the broker
  is away: no backlog, ever;
* state: the UAV's last known state, retained (QoS 1), on every stage change and at `state_hz`;
* events and replies: `event()` numbers each UAV's events 1, 2, 3 ... and appends them to one
  outgoing queue (`event_queue_size`, default 10 000) that is drained in order, up to 8 QoS 1
  publishes in flight, an item leaving the queue only when the broker acknowledged it. While
  disconnected the queue fills; when full the *oldest* item is dropped and counted
  (`stats.events_dropped`): subscribers see the gap in `seq`. An item whose PUBACK was lost
  in a broker crash is sent again: delivery is at least once, subscribers drop repeats by
  (session, uav, seq);
* commands: `gcs/<fleet>/cmd` is read and each valid command handed to `handler` (an async
  callable returning None on success or the reason for a refusal); malformed JSON, schema
  violations, handler errors and time-outs are refused by the bus itself with a reason. Every
  command gets a reply on `gcs/<fleet>/cmd/reply/<request id>`."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import time
import uuid
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

import aiomqtt

from gcs.bus.connection import Broker
from gcs.bus.messages import (
    INVALID_REQUEST,
    Command,
    InvalidCommand,
    Telemetry,
    Topics,
    check_name,
    encode,
    event_payload,
    parse_command,
    reply_payload,
    state_payload,
    station_payload,
)

__all__ = ["BusStats", "CommandHandler", "FleetBus"]

log = logging.getLogger("gcs.bus")
_BATCH = 8  # publishes awaited at once (aiomqtt warns above 10 pending calls)

CommandHandler = Callable[[Command], Awaitable[str | None]]


@dataclass
class BusStats:
    connects: int = 0
    disconnects: int = 0
    telemetry_sent: int = 0
    telemetry_replaced: int = 0
    states_sent: int = 0
    events_raised: int = 0
    events_sent: int = 0
    events_dropped: int = 0
    commands: int = 0
    commands_refused: int = 0
    last_error: str = ""


@dataclass
class _Outgoing:
    topic: str
    payload: bytes


@dataclass
class _Uav:
    stage: str = "connecting"
    telemetry: dict | None = None
    telemetry_dirty: bool = False
    state_dirty: bool = True
    seq: int = 0
    last_event: dict | None = None
    return_reason: str | None = None


class FleetBus:
    """Publish one fleet's telemetry, state and events; take its commands. Use as
    `async with FleetBus(broker, fleet="demo", station="gcs1", handler=h) as bus:`."""

    def __init__(self, broker: Broker, *, fleet: str, station: str = "gcs", handler: CommandHandler | None = None,
                 telemetry_hz: float = 2.0, state_hz: float = 1.0, event_queue_size: int = 10_000,
                 reconnect_min_s: float = 0.1, reconnect_max_s: float = 5.0, ack_timeout_s: float = 5.0,
                 handler_timeout_s: float = 5.0, on_status: Callable[[str], None] | None = None) -> None:
        if telemetry_hz <= 0 or state_hz <= 0:
            raise ValueError("telemetry_hz and state_hz must be positive")
        if event_queue_size < 1:
            raise ValueError("event_queue_size must be at least 1")
        if not 0 < reconnect_min_s <= reconnect_max_s:
            raise ValueError("need 0 < reconnect_min_s <= reconnect_max_s")
        self.broker = broker
        self.topics = Topics(fleet)
        self.fleet = fleet
        self.station = check_name(station, "station name")
        self.session = uuid.uuid4().hex[:12]
        self.handler = handler
        self.telemetry_period_s = 1.0 / telemetry_hz
        self.state_period_s = 1.0 / state_hz
        self.event_queue_size = event_queue_size
        self.reconnect_min_s, self.reconnect_max_s = reconnect_min_s, reconnect_max_s
        self.ack_timeout_s = ack_timeout_s
        self.handler_timeout_s = handler_timeout_s
        self.on_status = on_status or (lambda text: log.info("%s", text))
        self.stats = BusStats()
        self._uavs: dict[int, _Uav] = {}
        self._outgoing: deque[_Outgoing] = deque()
        self._outgoing_ready = asyncio.Event()
        self._state_ready = asyncio.Event()
        self._connected = asyncio.Event()
        self._closing = False
        self._group: asyncio.TaskGroup | None = None
        self._task: asyncio.Task | None = None

    # ---- public API (synchronous, never blocks, safe to call while disconnected) ----------------

    def telemetry(self, sample: Telemetry) -> None:
        """Replace the UAV's latest sample; a stage change also refreshes its retained state."""
        uav = self._uav(sample.uav)
        payload = sample.payload(self.fleet)
        if uav.telemetry_dirty:
            self.stats.telemetry_replaced += 1
        uav.telemetry, uav.telemetry_dirty = payload, True
        if sample.stage != uav.stage:
            uav.stage = sample.stage
            self._mark_state(uav)

    def event(self, uav_id: int, kind: str, *, reason: str | None = None, text: str = "", data: dict | None = None,
              stage: str | None = None) -> int:
        """Queue one event (QoS 1, in order); returns its sequence number for this UAV."""
        uav = self._uav(uav_id)
        payload = event_payload(self.fleet, self.station, self.session, uav_id, uav.seq + 1, kind, reason, text,
                                data or {})
        uav.seq += 1
        uav.last_event = payload
        self.stats.events_raised += 1
        if kind == "return" and reason is not None:
            uav.return_reason = reason
        if stage is not None and stage != uav.stage:
            uav.stage = stage
        self._push(_Outgoing(self.topics.event(uav_id), encode(payload)))
        self._mark_state(uav)
        return uav.seq

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    @property
    def pending_events(self) -> int:
        return len(self._outgoing)

    async def wait_connected(self, timeout_s: float | None = None) -> None:
        async with asyncio.timeout(timeout_s):
            await self._connected.wait()

    async def drain(self, timeout_s: float | None = None) -> None:
        """Wait until every queued event and reply has been acknowledged by the broker."""
        async with asyncio.timeout(timeout_s):
            while self._outgoing:
                await asyncio.sleep(0.01)

    # ---- lifecycle ------------------------------------------------------------------------------

    async def __aenter__(self) -> FleetBus:
        self._group = asyncio.TaskGroup()
        await self._group.__aenter__()
        self._task = self._group.create_task(self._connection_loop(), name="fleet-bus-connection")
        return self

    async def __aexit__(self, *exc_info) -> None:
        self._closing = True
        self._outgoing_ready.set()
        self._state_ready.set()
        assert self._group is not None
        self._task.cancel()
        await self._group.__aexit__(None, None, None)  # the body's own exception propagates unwrapped

    # ---- internals ----------------------------------------------------------------------------

    def _uav(self, uav_id: int) -> _Uav:
        if uav_id not in self._uavs:
            if isinstance(uav_id, bool) or not isinstance(uav_id, int) or uav_id < 1:
                raise ValueError(f"UAV id must be a positive integer, not {uav_id!r}")
            self._uavs[uav_id] = _Uav()
        return self._uavs[uav_id]

    def _mark_state(self, uav: _Uav) -> None:
        uav.state_dirty = True
        self._state_ready.set()

    def _push(self, item: _Outgoing) -> None:
        if len(self._outgoing) >= self.event_queue_size:
            dropped = self._outgoing.popleft()
            self.stats.events_dropped += 1
            log.warning("fleet bus queue full (%d): dropped the oldest message, on %s", self.event_queue_size,
                        dropped.topic)
        self._outgoing.append(item)
        self._outgoing_ready.set()

    async def _connection_loop(self) -> None:
        delay = self.reconnect_min_s
        will = aiomqtt.Will(self.topics.station(self.station),
                            encode(station_payload(self.fleet, self.station, self.session, False)), qos=1, retain=True)
        while True:
            client = self.broker.client(f"gcs-{self.fleet}-{self.station}-{self.session}", will=will,
                                        timeout_s=self.ack_timeout_s)
            try:
                async with client:
                    delay = self.reconnect_min_s
                    self.stats.connects += 1
                    self.on_status(f"fleet bus: connected to {self.broker}")
                    await self._serve(client)
            except* (aiomqtt.MqttError, OSError) as group:
                self.stats.last_error = "; ".join(str(e) for e in group.exceptions)
            finally:
                if self._connected.is_set():
                    self.stats.disconnects += 1
                self._connected.clear()
            if self._closing:
                return
            self.on_status(f"fleet bus: no broker at {self.broker} ({self.stats.last_error}); "
                           f"retrying in {delay:.1f} s")
            await asyncio.sleep(delay)
            delay = min(delay * 2, self.reconnect_max_s)

    async def _serve(self, client: aiomqtt.Client) -> None:
        await client.publish(self.topics.station(self.station),
                             encode(station_payload(self.fleet, self.station, self.session, True)), qos=1, retain=True)
        if self.handler is not None:
            await client.subscribe(self.topics.command, qos=1)
        for uav in self._uavs.values():
            uav.state_dirty = True  # the broker may have restarted without its retained messages
        self._connected.set()
        try:
            async with asyncio.TaskGroup() as group:
                group.create_task(self._receive(client, group), name="fleet-bus-receive")
                group.create_task(self._send_outgoing(client), name="fleet-bus-events")
                group.create_task(self._send_telemetry(client), name="fleet-bus-telemetry")
                group.create_task(self._send_states(client), name="fleet-bus-states")
        finally:
            if self._closing:
                with contextlib.suppress(aiomqtt.MqttError, asyncio.CancelledError):
                    await asyncio.shield(client.publish(
                        self.topics.station(self.station),
                        encode(station_payload(self.fleet, self.station, self.session, False)), qos=1, retain=True,
                        timeout=1.0))

    # Every loop below also stops on `_closing`: Python 3.11's asyncio.wait_for (inside aiomqtt's
    # publish) can swallow a cancellation that arrives as the publish completes.

    async def _send_outgoing(self, client: aiomqtt.Client) -> None:
        while not self._closing:
            if not self._outgoing:
                self._outgoing_ready.clear()
                await self._outgoing_ready.wait()
                continue
            # up to _BATCH in flight: issued in queue order on one connection, so they arrive in order
            batch = list(itertools.islice(self._outgoing, _BATCH))
            await asyncio.gather(*(client.publish(item.topic, item.payload, qos=1, timeout=self.ack_timeout_s)
                                   for item in batch))
            for item in batch:
                if self._outgoing and self._outgoing[0] is item:
                    self._outgoing.popleft()
                if "/event" in item.topic:
                    self.stats.events_sent += 1

    async def _send_telemetry(self, client: aiomqtt.Client) -> None:
        next_tick = time.monotonic()
        while not self._closing:
            sends = []
            for uid, uav in list(self._uavs.items()):
                if uav.telemetry_dirty:
                    uav.telemetry_dirty = False
                    sends.append((self.topics.telemetry(uid), encode(uav.telemetry)))
            for first in range(0, len(sends), _BATCH):
                await asyncio.gather(*(client.publish(topic, payload, qos=0, timeout=self.ack_timeout_s)
                                       for topic, payload in sends[first:first + _BATCH]))
            self.stats.telemetry_sent += len(sends)
            next_tick += self.telemetry_period_s
            now = time.monotonic()
            if next_tick < now:
                next_tick = now  # late: never catch up in a burst
            await asyncio.sleep(next_tick - now)

    async def _send_states(self, client: aiomqtt.Client) -> None:
        last_full = 0.0
        while not self._closing:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.state_period_s):
                    await self._state_ready.wait()
            self._state_ready.clear()
            now = time.monotonic()
            full = now - last_full >= self.state_period_s
            if full:
                last_full = now
            sends = []
            for uid, uav in list(self._uavs.items()):
                if uav.state_dirty or (full and uav.telemetry is not None):
                    uav.state_dirty = False
                    payload = state_payload(self.fleet, self.station, self.session, uid, uav.stage, uav.telemetry,
                                            uav.last_event, uav.return_reason)
                    sends.append((self.topics.state(uid), encode(payload)))
            for first in range(0, len(sends), _BATCH):
                await asyncio.gather(*(client.publish(topic, payload, qos=1, retain=True, timeout=self.ack_timeout_s)
                                       for topic, payload in sends[first:first + _BATCH]))
            self.stats.states_sent += len(sends)

    async def _receive(self, client: aiomqtt.Client, group: asyncio.TaskGroup) -> None:
        async for message in client.messages:  # raises MqttError when the connection drops
            if message.topic.value == self.topics.command and self.handler is not None:
                group.create_task(self._command(message.payload))

    async def _command(self, raw: bytes | bytearray | str) -> None:
        self.stats.commands += 1
        raw = raw.encode() if isinstance(raw, str) else bytes(raw)
        request_id: str | None = None
        try:
            command = parse_command(raw)
            request_id = command.request_id
            async with asyncio.timeout(self.handler_timeout_s):
                reason = await self.handler(command)
            if reason is not None and not isinstance(reason, str):
                reason = f"handler returned {reason!r} instead of None or a reason"
        except InvalidCommand as exc:
            request_id, reason = exc.request_id, exc.reason
        except TimeoutError:
            reason = f"no answer from the fleet within {self.handler_timeout_s:g} s"
        except Exception as exc:
            log.exception("command handler failed")
            reason = f"command failed: {type(exc).__name__}: {exc}"
        if reason is not None:
            self.stats.commands_refused += 1
        self.on_status(f"fleet bus: command {request_id or '?'}: {'done' if reason is None else 'refused: ' + reason}")
        payload = reply_payload(self.fleet, self.station, request_id, reason)
        self._push(_Outgoing(self.topics.reply(request_id or INVALID_REQUEST), encode(payload)))

