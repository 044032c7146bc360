"""What a flight shows on TAK, and when: `TakPublisher` turns tracks, readings, stage changes and
the plan into CoT (`gcs.tak.cot`) with their stale times, and hands them to every destination's
sender. The flight's feed (`gcs.tak.flight_feed`) and the bus's (`gcs.tak.bus_feed`) both feed it.

- A vehicle's track is sent about every `every_s` (never sooner than 0.9 of it) and goes stale
  `stale_s` after it was sent: a vehicle that stops reporting fades from the map on its own.
  Its last word (landed, failed) is sent at once and goes stale the same way; a lost link is
  said in the remarks without lengthening the stale time the track already had.
- The area, keep-out zones, paths and markers stay `keep_s` (12 h: an operational period) and
  are sent again every `refresh_s`, so a TAK client that joins mid-flight gets them."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable, Sequence
from dataclasses import replace
from datetime import datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING

from gcs.tak import cot
from gcs.tak.cot import Naming, TrackSample
from gcs.tak.sender import TakSender
from gcs.tak.settings import TakSettings

if TYPE_CHECKING:
    import xml.etree.ElementTree as ET

    from gcs.plans.plan_folder import FleetPlan

__all__ = ["TakPublisher", "plan_events"]

RATE_SLACK = 0.9  # positions come on their own clock (2 Hz on the bus): one 0.49 s after the last passes a 0.5 s rate


def plan_events(naming: Naming, plan: FleetPlan, when: datetime, stale: datetime) -> list[ET.Element]:
    """The plan on the map: the search area and the keep-out zones (the geofence every UAV got:
    the area's outer rings, its holes and the no-fly zones) and each UAV's path, from its
    airport through its mission waypoints and back."""
    events = []
    rings: dict[tuple, bool] = {}
    for task in plan.uavs.values():
        for inclusion, ring in task.fence:
            rings.setdefault(tuple(map(tuple, ring)), not inclusion)
    counts = {False: 0, True: 0}
    for ring, keep_out in rings.items():
        counts[keep_out] += 1
        n = counts[keep_out]
        key, label = ("keep-out", f"keep-out {n}") if keep_out else ("area", "search area" + (f" {n}" if n > 1 else ""))
        events.append(cot.area_shape(naming, f"{key}.{n}", label, list(ring), keep_out, when, stale))
    events += segment_events(naming, plan.folder / "segments.geojson", when, stale)
    for uav, task in sorted(plan.uavs.items()):
        airport = tuple(task.airport_lat_lon)
        events.append(cot.path_route(naming, uav, [airport, *task.waypoints, airport], task.altitude_m, when, stale))
    return events


def segment_events(naming: Naming, path: Path, when: datetime, stale: datetime) -> list[ET.Element]:
    """The plan's search segments with their POA, POD and POS (the folder's segments.geojson,
    `gcs.plans.segments`); none when the folder has none."""
    try:
        features = json.loads(path.read_text())["features"]
    except (OSError, ValueError, KeyError):
        return []
    events = []
    for feature in features:
        geometry, props = feature.get("geometry") or {}, feature.get("properties") or {}
        parts = {"Polygon": [geometry.get("coordinates")], "MultiPolygon": geometry.get("coordinates")}.get(
            geometry.get("type"), [])
        for k, rings in enumerate(parts or []):
            ring = [(lat, lon) for lon, lat, *_ in rings[0]]
            key = f"segment.{props.get('segment')}" + (f".{k + 1}" if len(parts) > 1 else "")
            events.append(cot.segment_shape(naming, key, str(props.get("segment")), ring,
                                            str(props.get("description", "")), when, stale))
    return events


class TakPublisher:
    """The map's content over `senders`; `run()` re-sends the lasting items until cancelled."""

    def __init__(self, senders: Sequence[TakSender], settings: TakSettings,
                 clock: Callable[[], datetime] = cot.utc_now) -> None:
        self.senders = list(senders)
        self.settings = settings
        self.naming = Naming(settings.name)
        self.clock = clock
        self._tracks: dict[int, tuple[TrackSample, datetime, datetime]] = {}  # last sample, sent at, stale at
        self._lasting: dict[str, bytes] = {}

    def _send(self, uid: str, event: ET.Element, keep: bool = False) -> None:
        data = cot.encode(event)
        for sender in self.senders:
            sender.send(uid, data, keep)

    def _lasting_item(self, event: ET.Element) -> None:
        uid = event.get("uid", "")
        self._lasting[uid] = cot.encode(event)
        for sender in self.senders:
            sender.send(uid, self._lasting[uid], keep=True)

    def _keep_until(self, when: datetime) -> datetime:
        return when + timedelta(seconds=self.settings.keep_s)

    # ---- vehicles --------------------------------------------------------------------------

    def track(self, sample: TrackSample, *, now: bool = False, final: bool = False) -> bool:
        """Send the vehicle's track unless one went out less than `every_s` ago (`now` sends it
        anyway); `final` is its last word (kept for a server that comes back). True when sent."""
        when = self.clock()
        last = self._tracks.get(sample.uav)
        if last is not None and not (now or final) and \
                (when - last[1]).total_seconds() < RATE_SLACK * self.settings.every_s:
            return False
        stale = when + timedelta(seconds=self.settings.stale_s)
        self._tracks[sample.uav] = (sample, when, stale)
        self._send(self.naming.uid("uav", sample.uav), cot.uav_track(self.naming, sample, when, stale), keep=final)
        return True

    def link_lost(self, uav: int, note: str = "link lost") -> None:
        """Say in the track's remarks that the vehicle went silent, without lengthening its stale time."""
        last = self._tracks.get(uav)
        if last is None:
            return
        sample, _, stale = last
        when = self.clock()
        if when >= stale:
            return
        lost = replace(sample, note=note)
        self._tracks[uav] = (lost, when, stale)
        self._send(self.naming.uid("uav", uav), cot.uav_track(self.naming, lost, when, stale), keep=True)

    def last_sample(self, uav: int) -> TrackSample | None:
        last = self._tracks.get(uav)
        return None if last is None else last[0]

    # ---- lasting items -----------------------------------------------------------------------

    def plan(self, plan: FleetPlan) -> None:
        when = self.clock()
        for event in plan_events(self.naming, plan, when, self._keep_until(when)):
            self._lasting_item(event)

    def return_leg(self, uav: int, leg: Sequence[tuple[float, float]], alt_m: float) -> None:
        if len(leg) < 1:
            return
        when = self.clock()
        self._lasting_item(cot.path_route(self.naming, uav, list(leg), alt_m, when, self._keep_until(when),
                                          kind="return"))

    def reading(self, uav: int, index: int, lat_deg: float, lon_deg: float, cell: tuple[int, int] | None) -> None:
        """A positive reading (`cell` 1-based, or None outside the grid)."""
        when = self.clock()
        self._lasting_item(cot.reading_marker(self.naming, uav, index, lat_deg, lon_deg, cell, when,
                                              self._keep_until(when)))

    def stage(self, uav: int, kind: str, lat_deg: float, lon_deg: float, text: str) -> None:
        """Where the vehicle turned home (`kind` "return"), landed or failed."""
        when = self.clock()
        self._lasting_item(cot.stage_marker(self.naming, uav, kind, lat_deg, lon_deg, text, when,
                                            self._keep_until(when)))

    async def run(self) -> None:
        while True:
            await asyncio.sleep(self.settings.refresh_s)
            for uid, data in self._lasting.items():
                for sender in self.senders:
                    sender.send(uid, data)
