"""`FleetWatcher`: a second station's view of a fleet, from the broker alone (retained states,
live telemetry and events), and its way to send commands and wait for their replies."""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field

import aiomqtt

from gcs.bus.connection import Broker
from gcs.bus.messages import Command, MessageType, Topics, schema_errors

__all__ = ["FleetWatcher", "Reply", "UavListener", "UavView", "render_fleet"]

#: called with every valid message about one UAV (telemetry, state, event): its type, the UAV, the payload
UavListener = Callable[[MessageType, int, dict], None]


@dataclass
class UavView:
    """What the watcher knows of one UAV."""

    uav: int
    stage: str = "-"
    telemetry: dict | None = None
    station: str = "-"
    return_reason: str | None = None
    last_event: dict | None = None
    events: int = 0
    session: str = ""
    heard_s: float = 0.0


@dataclass(frozen=True)
class Reply:
    ok: bool
    reason: str | None
    station: str


@dataclass
class WatchStats:
    messages: int = 0
    invalid: list[str] = field(default_factory=list)


class FleetWatcher:
    """Subscribe to one fleet; `uavs` is kept up to date while the context is open."""

    def __init__(self, broker: Broker, *, fleet: str, identifier: str | None = None) -> None:
        self.broker = broker
        self.topics = Topics(fleet)
        self.identifier = identifier or f"gcs-watch-{uuid.uuid4().hex[:10]}"
        self.uavs: dict[int, UavView] = {}
        self.stations: dict[str, dict] = {}
        self.stats = WatchStats()
        self._replies: dict[str, asyncio.Future[Reply]] = {}
        self._client: aiomqtt.Client | None = None
        self.error: str | None = None
        self._task: asyncio.Task | None = None
        self._listeners: list[UavListener] = []

    def subscribe(self, listener: UavListener) -> Callable[[], None]:
        """Call `listener` with every valid UAV message from now on (after the view took it in);
        returns the call that unsubscribes it. A listener that raises is dropped."""
        self._listeners.append(listener)
        return lambda: self._listeners.remove(listener) if listener in self._listeners else None

    async def __aenter__(self) -> FleetWatcher:
        self._client = self.broker.client(self.identifier)
        try:
            await self._client.__aenter__()
        except aiomqtt.MqttError as exc:
            raise ConnectionError(f"cannot connect to {self.broker}: {exc}") from None
        root = self.topics.root
        for topic in (f"{root}/uav/+/state", f"{root}/uav/+/telemetry", f"{root}/uav/+/event", f"{root}/station/+",
                      f"{root}/cmd/reply/+"):
            await self._client.subscribe(topic, qos=1)
        self._task = asyncio.create_task(self._receive(), name="fleet-watch-receive")
        return self

    async def __aexit__(self, *exc_info) -> None:
        assert self._client is not None and self._task is not None
        self._task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self._task
        with contextlib.suppress(aiomqtt.MqttError):
            await self._client.__aexit__(*exc_info)

    async def _receive(self) -> None:
        assert self._client is not None
        try:
            async for message in self._client.messages:
                self.handle(message.topic.value, message.payload)
        except aiomqtt.MqttError as exc:
            self.error = f"lost the broker {self.broker}: {exc}"
            for future in self._replies.values():
                if not future.done():
                    future.set_exception(ConnectionError(self.error))

    def handle(self, topic: str, raw) -> None:
        """Fold one message into the view; messages breaking their schema are counted, not used."""
        kind = self.topics.classify(topic)
        if kind is None:
            return
        message_type, uav_id = kind
        self.stats.messages += 1
        try:
            data = json.loads(raw)
        except (UnicodeDecodeError, json.JSONDecodeError, TypeError):
            self.stats.invalid.append(f"{topic}: not JSON")
            return
        errors = schema_errors(message_type, data)
        if errors:
            self.stats.invalid.append(f"{topic}: {errors[0]}")
            return
        if message_type is MessageType.REPLY:
            future = self._replies.get(topic.rsplit("/", 1)[1])
            if future is not None and not future.done():
                future.set_result(Reply(data["ok"], data["reason"], data["station"]))
            return
        if message_type is MessageType.STATION:
            self.stations[data["station"]] = data
            return
        view = self.uavs.setdefault(uav_id, UavView(uav_id))
        view.heard_s = time.monotonic()
        if message_type is MessageType.STATE:
            view.stage, view.station, view.return_reason = data["stage"], data["station"], data["return_reason"]
            if data["last_event"] is not None and (view.last_event is None
                                                   or data["last_event"]["seq"] > view.last_event["seq"]
                                                   or data["session"] != view.session):
                view.last_event = data["last_event"]
            view.session = data["session"]
            if data["telemetry"] is not None and (view.telemetry is None
                                                  or data["telemetry"]["t_s"] >= view.telemetry["t_s"]):
                view.telemetry = data["telemetry"]
        elif message_type is MessageType.TELEMETRY:
            view.telemetry, view.stage = data, data["stage"]
        elif message_type is MessageType.EVENT:
            view.last_event, view.session = data, data["session"]
            view.events += 1
            if data["kind"] == "return":
                view.return_reason = data["reason"]
        for listener in list(self._listeners):
            try:
                listener(message_type, uav_id, data)
            except Exception:  # a listener's bug must not stop the view
                self._listeners.remove(listener)

    async def command(self, command: Command, timeout_s: float = 5.0) -> Reply:
        """Publish a command and wait for its reply; TimeoutError when none comes, ConnectionError
        when the broker goes away."""
        assert self._client is not None
        if self.error is not None:
            raise ConnectionError(self.error)
        future: asyncio.Future[Reply] = asyncio.get_running_loop().create_future()
        self._replies[command.request_id] = future
        try:
            try:
                await self._client.publish(self.topics.command, json.dumps(command.payload()), qos=1)
            except aiomqtt.MqttError as exc:
                raise ConnectionError(f"cannot send to {self.broker}: {exc}") from None
            async with asyncio.timeout(timeout_s):
                return await future
        finally:
            self._replies.pop(command.request_id, None)

    async def publish_raw(self, payload: bytes | str) -> None:
        """Send anything on the command topic (for tests and diagnostics)."""
        assert self._client is not None
        await self._client.publish(self.topics.command, payload, qos=1)


def _num(value, fmt: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, fmt)


def render_fleet(watcher: FleetWatcher) -> str:
    """The fleet table: one row per UAV known on the broker."""
    head = (f"{'UAV':>3} {'stage':<10} {'lat':>11} {'lon':>12} {'alt m':>6} {'hdg':>5} {'batt %':>6} "
            f"{'range':>6} {'margin':>6} {'station':<10} last event")
    rows = [head]
    for uid, view in sorted(watcher.uavs.items()):
        t = view.telemetry or {}
        event = view.last_event
        last = "-"
        if event is not None:
            last = f"#{event['seq']} {event['kind']}" + (f" ({event['reason']})" if event["reason"] else "")
        rows.append(f"{uid:>3} {view.stage:<10} {_num(t.get('lat_deg'), '.6f'):>11} "
                    f"{_num(t.get('lon_deg'), '.6f'):>12} {_num(t.get('alt_m'), '.1f'):>6} "
                    f"{_num(t.get('heading_deg'), '.0f'):>5} {_num(t.get('battery_pct'), '.0f'):>6} "
                    f"{_num(t.get('range_left_m'), '.0f'):>6} "
                    f"{_num(t.get('margin_m'), '.0f'):>6} {view.station[:10]:<10} {last}")
    if len(rows) == 1:
        rows.append("(no UAV on the broker yet)")
    return "\n".join(rows)
