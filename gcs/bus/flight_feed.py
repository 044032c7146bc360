"""The bus attached to `gcs fly`: `FlightFeed` listens to a `FlightController`'s events (stage
changes, take-offs, readings) and publishes each as it happens, samples the vehicles' telemetry
(it never writes their state), and carries commands from the bus to the controller. `attach_bus`
is the few lines `gcs fly --mqtt` needs:

    async with attach_bus(controller, "mqtt://127.0.0.1", fleet="north"):
        await controller.run()

and `BusFeed` the same as a watcher of `gcs.flight.fly.fly_async` (`bus=bus_feed(url, fleet=...)`):
the bus depends on the flight, never the other way round."""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import AsyncIterator
from typing import TYPE_CHECKING

from gcs.bus.connection import TlsOptions, parse_broker_url
from gcs.bus.fleet_bus import FleetBus
from gcs.bus.messages import Command, CommandKind, Telemetry
from gcs.flight.events import FlightEvent, LinkChanged, ReadingReceived, StageChanged, TookOff

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController

__all__ = ["BusFeed", "FlightFeed", "attach_bus", "bus_feed"]

_EVENT_OF_STAGE = {"return": "return", "rtl": "rtl", "landed": "landed", "lost": "link_lost", "failed": "failed"}
_FINAL = ("landed", "failed")


def _or_none(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


class FlightFeed:
    """Feeds a FleetBus from a FlightController: events as the controller raises them,
    telemetry sampled every `sample_every_s` (the bus limits it further to its own rate)."""

    def __init__(self, bus: FleetBus, controller: FlightController, sample_every_s: float = 0.05) -> None:
        self.bus = bus
        self.sample_every_s = sample_every_s
        self.c = controller
        self._ordered: set[int] = set()
        self.close = controller.subscribe(self.on_event)

    def sample(self) -> None:
        for uid, st in sorted(self.c.status.items()):
            has_position = st.has_position
            self.bus.telemetry(Telemetry(
                uid, st.stage.value, lat_deg=st.lat_deg if has_position else None,
                lon_deg=st.lon_deg if has_position else None, alt_m=st.rel_alt_m, heading_deg=st.heading_deg,
                battery_pct=st.battery_pct, range_left_m=_or_none(st.range_left), margin_m=_or_none(st.margin)))

    def on_event(self, event: FlightEvent, now: float) -> None:
        if isinstance(event, LinkChanged):
            for uid in event.uav_ids:
                self.bus.event(uid, "note", text=str(event.status), stage=self.c.status[uid].stage.value,
                               data={"link": event.status.link, "link_state": event.status.state.value})
            return
        uid = event.uav_id
        st = self.c.status[uid]
        stage = st.stage.value
        if isinstance(event, TookOff):
            self.bus.event(uid, "takeoff", text=f"airborne, {event.alt_m:.0f} m", stage=stage)
        elif isinstance(event, StageChanged):
            before, after = event.before.value, event.after.value
            if before == "lost":
                self.bus.event(uid, "link_back", text=st.note, stage=after)
            kind = _EVENT_OF_STAGE.get(after, "stage")
            if not (before == "lost" and kind == "stage"):
                reason = st.return_reason if kind in ("return", "rtl") else None
                self.bus.event(uid, kind, reason=reason, text=event.note or after, stage=after,
                               data={"from": before, "to": after})
        elif isinstance(event, ReadingReceived) and event.detection.hit:
            d = event.detection
            cell = self.c.plan.cell_of(d.lat_deg, d.lon_deg)
            self.bus.event(uid, "detection", text="positive reading", stage=stage,
                           data={"lat_deg": d.lat_deg, "lon_deg": d.lon_deg, "image_index": d.index,
                                 "cell": None if cell is None else [cell[0] + 1, cell[1] + 1]})

    async def run(self) -> None:
        while True:
            self.sample()
            await asyncio.sleep(self.sample_every_s)

    async def handle(self, command: Command) -> str | None:
        """Commands from the bus: None when done, else the reason for the refusal."""
        status = self.c.status
        if command.uav is not None and command.uav not in status:
            return f"unknown UAV {command.uav} (the fleet has {', '.join(map(str, sorted(status)))})"
        targets = sorted(status) if command.uav is None else [command.uav]
        if command.kind is CommandKind.RANGE:
            self.c.set_range(command.uav, command.range_m)
            return None
        active = [u for u in targets if status[u].stage.value not in _FINAL]
        if command.uav is not None and not active:
            return f"UAV {command.uav} has {status[command.uav].stage.value}"
        if command.kind is CommandKind.RETURN:
            going = [u for u in active if status[u].stage.value in ("return", "rtl") or u in self._ordered]
            if command.uav is not None and going:
                return f"UAV {command.uav} is already returning"
            for uid in active:
                if uid not in going:
                    self.c.order_return(uid, "mqtt")
                    self._ordered.add(uid)  # the controller acts on its next tick
            return None
        results = await asyncio.gather(*(self.c.vehicles[uid].rtl() for uid in active), return_exceptions=True)
        for uid in active:
            status[uid].return_reason = status[uid].return_reason or "mqtt abort"
        failed = [str(uid) for uid, ok in zip(active, results) if ok is not True]
        return f"RTL not acknowledged by UAV {', '.join(failed)}" if failed else None


def bus_feed(url: str, *, fleet: str = "default", station: str = "gcs", telemetry_hz: float = 2.0,
             ca_file: str | None = None, tls_insecure: bool = False) -> BusFeed:
    """A flight's fleet bus on the broker at `url` (mqtt:// or mqtts://), checked before the flight:
    ValueError with one line for a bad URL, TLS settings or name."""
    tls = TlsOptions(ca_file, insecure=tls_insecure) if (ca_file or tls_insecure) else None
    broker = parse_broker_url(url, tls=tls)
    from gcs.bus.messages import check_name

    check_name(fleet, "--fleet")
    check_name(station, "--mqtt-station")
    return BusFeed(broker, fleet=fleet, station=station, telemetry_hz=telemetry_hz)


@contextlib.asynccontextmanager
async def attach_bus(controller: FlightController, broker, *, fleet: str, station: str = "gcs",
                     telemetry_hz: float = 2.0, **bus_kwargs) -> AsyncIterator[FlightFeed]:
    """A FleetBus fed by `controller` for as long as the block runs; `broker` is a URL or a
    `Broker`. The last states and events are flushed (up to 2 s) on the way out."""
    if isinstance(broker, str):
        broker = parse_broker_url(broker)
    bus_kwargs.setdefault("handler_timeout_s", 10.0)
    bus_kwargs.setdefault("on_status", lambda text: controller.say(None, text))
    holder: dict[str, FlightFeed] = {}

    async def handler(command: Command) -> str | None:
        return await holder["feed"].handle(command)

    async with FleetBus(broker, fleet=fleet, station=station, handler=handler, telemetry_hz=telemetry_hz,
                        **bus_kwargs) as bus:
        feed = holder["feed"] = FlightFeed(bus, controller)
        task = asyncio.create_task(feed.run(), name="fleet-bus-feed")
        try:
            yield feed
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            feed.close()
            feed.sample()
            if bus.connected:
                with contextlib.suppress(TimeoutError):
                    await bus.drain(2.0)
                await asyncio.sleep(min(0.5, bus.state_period_s))  # the final retained states


class BusFeed:
    """A flight's fleet bus, as `fly_async` takes it (`bus=`, or among its `watchers`): the
    settings of `attach_bus` (`bus_feed` checks them), entered on `attach`."""

    def __init__(self, broker, *, fleet: str, station: str = "gcs", telemetry_hz: float = 2.0, **bus_kwargs) -> None:
        self.broker = broker
        self.fleet = fleet
        self.station = station
        self.telemetry_hz = telemetry_hz
        self.bus_kwargs = bus_kwargs

    def attach(self, controller: FlightController) -> contextlib.AbstractAsyncContextManager[FlightFeed]:
        """`attach_bus(controller, ...)` with these settings."""
        return attach_bus(controller, self.broker, fleet=self.fleet, station=self.station,
                          telemetry_hz=self.telemetry_hz, **self.bus_kwargs)
