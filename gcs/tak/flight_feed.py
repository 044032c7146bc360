"""`gcs fly --tak`: `TakFeed` is a watcher of the flight (`gcs.flight.fly.fly_plan(...,
watchers=[feed])`): while the flight runs it puts the plan on every TAK destination, samples the
vehicles' status (it never writes it) and turns the flight's events into markers and last words.
The flight knows nothing of TAK; a TAK server that is away, drops or refuses costs one line
under the flight's own (`gcs.tak.sender`), never the flight.

    feed = TakFeed([parse_tak_url("tcp://127.0.0.1:8087")], TakSettings("north"))
    fly_plan(plan, connections, options, watchers=[feed])"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Sequence
from typing import TYPE_CHECKING

from gcs.flight.events import FlightEvent, MissionUploaded, ReadingReceived, StageChanged
from gcs.tak.cot import TrackSample
from gcs.tak.destination import TakDestination
from gcs.tak.publisher import TakPublisher
from gcs.tak.sender import close_senders, open_senders
from gcs.tak.settings import TakSettings
from gcs.telemetry.status import FINAL_STAGES, Stage, VehicleStatus

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController

__all__ = ["FlightOnTak", "TakFeed", "track_of"]

_RETURNING = (Stage.RETURN, Stage.RTL)
_MARKER_OF_STAGE = {Stage.RETURN: "return", Stage.RTL: "return", Stage.LANDED: "landed", Stage.FAILED: "failed"}


def track_of(status: VehicleStatus, vehicle: str | None = None) -> TrackSample | None:
    """A vehicle's status as the map shows it; None before it has a position."""
    if not status.has_position:
        return None
    assert status.lat_deg is not None and status.lon_deg is not None
    note = ""
    if status.stage in _RETURNING and status.return_reason:
        note = f"going home: {status.return_reason}"
    elif status.stage is Stage.FAILED:
        note = status.note
    return TrackSample(status.uav_id, status.lat_deg, status.lon_deg, status.rel_alt_m, status.stage.value,
                       course_deg=status.heading_deg, speed_m_s=status.ground_speed_m_s,
                       battery_pct=status.battery_pct, vehicle=vehicle, note=note)


class FlightOnTak:
    """The flight's status and events, on a `TakPublisher`."""

    def __init__(self, publisher: TakPublisher, controller: FlightController) -> None:
        self.publisher = publisher
        self.c = controller
        self._heard: dict[int, float] = {}

    def _vehicle(self, uav: int) -> str | None:
        task = self.c.plan.uavs.get(uav)
        return None if task is None else task.vehicle.value

    def sample(self) -> None:
        """Every vehicle heard since its last track, unless it is lost or down for good (its last
        track then goes stale on the map)."""
        for uid, st in sorted(self.c.status.items()):
            if st.stage in FINAL_STAGES or st.stage is Stage.LOST or st.last_heard_s is None:
                continue
            if st.last_heard_s <= self._heard.get(uid, float("-inf")):
                continue
            sample = track_of(st, self._vehicle(uid))
            if sample is not None and self.publisher.track(sample):
                self._heard[uid] = st.last_heard_s

    def on_event(self, event: FlightEvent, now: float) -> None:
        if isinstance(event, StageChanged):
            self._stage_changed(event)
        elif isinstance(event, ReadingReceived) and event.detection.hit:
            d = event.detection
            cell = self.c.plan.cell_of(d.lat_deg, d.lon_deg)
            self.publisher.reading(event.uav_id, d.index, d.lat_deg, d.lon_deg,
                                   None if cell is None else (cell[0] + 1, cell[1] + 1))
        elif isinstance(event, MissionUploaded) and event.kind == "return" and event.leg:
            task = self.c.plan.uavs[event.uav_id]
            self.publisher.return_leg(event.uav_id, [*event.leg, tuple(task.airport_lat_lon)], task.altitude_m)

    def _stage_changed(self, event: StageChanged) -> None:
        uid, st = event.uav_id, self.c.status[event.uav_id]
        if event.after is Stage.LOST:
            self.publisher.link_lost(uid)
            return
        sample = track_of(st, self._vehicle(uid))
        if sample is None:
            return
        final = event.after in FINAL_STAGES
        self.publisher.track(sample, now=True, final=final)
        if st.last_heard_s is not None:
            self._heard[uid] = st.last_heard_s
        kind = _MARKER_OF_STAGE.get(event.after)
        if kind is None or (kind == "return" and event.before in _RETURNING):
            return
        if kind == "return":
            text = f"going home: {st.return_reason or event.note or event.after.value}"
        elif kind == "landed":
            text = "landed" + (f", battery {st.battery_pct:.0f}%" if st.battery_pct is not None else "")
        else:
            text = event.note or st.note or "failed"
        self.publisher.stage(uid, kind, sample.lat_deg, sample.lon_deg, text)


class TakFeed:
    """The TAK destinations of a flight, as `fly_plan` takes a watcher: entered on `attach`."""

    def __init__(self, destinations: Sequence[TakDestination], settings: TakSettings) -> None:
        self.destinations = list(destinations)
        self.settings = settings

    @contextlib.asynccontextmanager
    async def attach(self, controller: FlightController) -> AsyncIterator[FlightOnTak]:
        def say(text: str) -> None:
            controller.say(None, text)

        senders = open_senders(self.destinations, self.settings, say)
        publisher = TakPublisher(senders, self.settings)
        follower = FlightOnTak(publisher, controller)
        publisher.plan(controller.plan)
        unsubscribe = controller.subscribe(follower.on_event)

        async def sampling() -> None:
            while True:
                follower.sample()
                await asyncio.sleep(min(0.5, self.settings.every_s / 2))

        tasks = [asyncio.create_task(sampling(), name="tak-sample"),
                 asyncio.create_task(publisher.run(), name="tak-refresh")]
        try:
            yield follower
        finally:
            unsubscribe()
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            await close_senders(senders, say)
