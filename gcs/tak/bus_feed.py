"""`gcs watch --mqtt ... --tak URL`: a second station puts the fleet it reads from the bus on TAK,
from the broker alone. `BusOnTak` turns the bus's telemetry into tracks (a speed worked out from
successive positions, since the bus carries none) and its events into markers; with the plan
folder (`gcs watch --plan DIR`) the area, keep-out zones and paths go on the map too.

    async with FleetWatcher(broker, fleet="north") as watcher, \\
            tak_on_bus(watcher, destinations, TakSettings("north"), plan=None, say=print):
        ..."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Callable, Sequence
from typing import TYPE_CHECKING

from gcs.bus.messages import MessageType
from gcs.tak.cot import TrackSample
from gcs.tak.destination import TakDestination
from gcs.tak.publisher import TakPublisher
from gcs.tak.sender import close_senders, open_senders
from gcs.tak.settings import TakSettings
from gcs.telemetry.status import ground_distance_m

if TYPE_CHECKING:
    from gcs.bus.watcher import FleetWatcher
    from gcs.plans.plan_folder import FleetPlan

__all__ = ["BusOnTak", "tak_on_bus"]

_NOT_FLYING = ("landed", "failed", "lost")
_MARKER_OF_EVENT = {"return": "return", "rtl": "return", "landed": "landed", "failed": "failed"}


class BusOnTak:
    """The fleet on the bus, on a `TakPublisher`: `on_message` is a `FleetWatcher` listener."""

    def __init__(self, publisher: TakPublisher, plan: FleetPlan | None = None) -> None:
        self.publisher = publisher
        self.plan = plan
        self._last: dict[int, dict] = {}  # each UAV's last telemetry with a position
        self._speed: dict[int, float | None] = {}
        self._returning: set[int] = set()

    def _sample(self, uav: int, data: dict, stage: str | None = None) -> TrackSample:
        vehicle = None
        if self.plan is not None and uav in self.plan.uavs:
            vehicle = self.plan.uavs[uav].vehicle.value
        return TrackSample(uav, data["lat_deg"], data["lon_deg"], data["alt_m"] or 0.0, stage or data["stage"],
                           course_deg=data["heading_deg"], speed_m_s=self._speed.get(uav),
                           battery_pct=data["battery_pct"], vehicle=vehicle)

    def on_message(self, kind: MessageType, uav: int, data: dict) -> None:
        if kind is MessageType.TELEMETRY:
            self._telemetry(uav, data)
        elif kind is MessageType.EVENT:
            self._event(uav, data)

    def _telemetry(self, uav: int, data: dict) -> None:
        if data["lat_deg"] is None or data["lon_deg"] is None:
            return
        before = self._last.get(uav)
        if before is not None and data["t_s"] - before["t_s"] >= 0.2:
            moved = ground_distance_m(before["lat_deg"], before["lon_deg"], data["lat_deg"], data["lon_deg"])
            self._speed[uav] = moved / (data["t_s"] - before["t_s"])
        if before is None or data["t_s"] - before["t_s"] >= 0.2:
            self._last[uav] = data
        if data["stage"] not in _NOT_FLYING:
            self.publisher.track(self._sample(uav, data))

    def _event(self, uav: int, data: dict) -> None:
        kind, last = data["kind"], self._last.get(uav)
        if kind == "detection":
            d = data["data"]
            if d.get("lat_deg") is not None and d.get("lon_deg") is not None:
                cell = d.get("cell")
                self.publisher.reading(uav, int(d.get("image_index", 0)), d["lat_deg"], d["lon_deg"],
                                       None if cell is None else (int(cell[0]), int(cell[1])))
            return
        if kind == "link_lost":
            self.publisher.link_lost(uav)
            return
        marker = _MARKER_OF_EVENT.get(kind)
        if marker is None or last is None:
            return
        if marker == "return":
            if uav in self._returning:
                return
            self._returning.add(uav)
            self.publisher.track(self._sample(uav, last, kind), now=True)
            text = f"going home: {data['reason'] or data['text']}"
        else:
            self.publisher.track(self._sample(uav, last, kind), final=True)
            text = data["text"] or kind
        self.publisher.stage(uav, marker, last["lat_deg"], last["lon_deg"], text)


@contextlib.asynccontextmanager
async def tak_on_bus(watcher: FleetWatcher, destinations: Sequence[TakDestination], settings: TakSettings, *,
                     plan: FleetPlan | None, say: Callable[[str], None]) -> AsyncIterator[BusOnTak]:
    """The fleet `watcher` reads, on TAK for as long as the block runs."""
    senders = open_senders(destinations, settings, say)
    publisher = TakPublisher(senders, settings)
    follower = BusOnTak(publisher, plan)
    if plan is not None:
        publisher.plan(plan)
    def follow(kind: MessageType, uav: int, data: dict) -> None:
        try:
            follower.on_message(kind, uav, data)
        except Exception as exc:  # the watcher drops a listener that raises: say so, once
            say(f"TAK: stopped following the bus ({type(exc).__name__}: {exc})")
            raise

    unsubscribe = watcher.subscribe(follow)
    refresh = asyncio.create_task(publisher.run(), name="tak-refresh")
    try:
        yield follower
    finally:
        unsubscribe()
        refresh.cancel()
        await asyncio.gather(refresh, return_exceptions=True)
        await close_senders(senders, say)
