"""A flight as one sortie of a campaign (docs/campaigns.md): what `gcs fly` leaves in the plan
folder for `gcs plan --continue`.

`SortieLog` watches a `FlightController` (`fly_async(watchers=[log])`). Every reading
(`ReadingReceived`) is folded, as it arrives, into the belief the plan was made from
(`belief.json`) with the planner's own Bayes update (`SearchMap.observe`, eq. 2-4, the one
online mode uses), with the plan's Pc and Pf; each vehicle's position is sampled into its flown
track. When the flight ends, however it ends, these files are published together
(`gcs.atomic.staged_outputs`):

- `sortie.json`: the sortie number, whether the flight finished (and why not), the hashes of
  plan.json and of the area file, the posterior TEP and EU grids, the readings per cell of this
  sortie and of the whole campaign, every reading, the vehicles' ends and the campaign's expected
  finds before and after (schema `gcs/schemas/sortie.schema.json`);
- `tracks.geojson`: one LineString per vehicle, the positions it reported from take-off on;
- `detections.geojson`: one Point per positive reading;
- `tracks.kml`, `tracks.gpx`, `detections.kml`, `detections.gpx`: the same for Google Earth,
  CalTopo, QGIS and handheld GPS units (`gcs.missions.kml`, `gcs.missions.gpx`).

A flight taken over by a restarted station (`gcs fly --resume`) is one sortie: `restore` folds
in the readings and tracks its journal kept before the station died.

A vehicle without a detector sends no readings: its track is still written and the posterior is
the prior (`observed` false: nothing was observed).

Grids in these files are lists of columns: `grid[x - 1][y - 1]` is cell (x, y) (1-based, x east,
y north), as plan.json numbers cells."""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
from collections.abc import AsyncIterator
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gcs.atomic import staged_outputs
from gcs.plans.belief_file import (
    BELIEF_FILE,
    SCHEMA_VERSION,
    SORTIE_FILE,
    belief_from_dict,
    belief_to_dict,
    file_sha256,
)
from gcs.plans.segments import FROM_AREA_FILE, FROM_GRID, plan_folder_segments
from planner.campaign import Belief
from planner.search_theory import SearchTheory, Segment, block_segments, search_theory

if TYPE_CHECKING:  # the flight modules load pymavlink: `gcs plan --continue` needs none of them
    from gcs.flight.controller import FlightController
    from gcs.flight.events import FlightEvent
    from gcs.flight.journal import JournalState
    from gcs.plans.plan_folder import FleetPlan
    from gcs.telemetry.status import Detection

__all__ = ["DETECTIONS_FILE", "TRACKS_FILE", "SortieLog"]

TRACKS_FILE = "tracks.geojson"
DETECTIONS_FILE = "detections.geojson"


@dataclass(frozen=True, slots=True)
class _Reading:
    uav_id: int
    index: int
    cell: tuple[int, int] | None
    hit: bool
    time_s: float
    lat_deg: float
    lon_deg: float


def plan_sortie(plan: FleetPlan) -> int:
    """Which sortie of its campaign `plan` is (1 for a plan made without one)."""
    return int((plan.raw.get("campaign") or {}).get("sortie", 1))


class SortieLog:
    """Folds a flight's readings into the plan's belief and keeps each vehicle's track; writes
    the sortie record when the flight ends (`attach`)."""

    def __init__(self, plan: FleetPlan, *, poll_s: float = 0.05, min_move_m: float | None = None) -> None:
        self.plan = plan
        self.folder = Path(plan.folder)
        self.sortie = plan_sortie(plan)
        self.area = (plan.raw.get("campaign") or {}).get("area")
        self.pc, self.pf = plan.pc, plan.pf  # the camera's Pc when the plan was made with one
        self.poll_s = poll_s
        self.min_move_m = min_move_m if min_move_m is not None else plan.cell_size_m / 5.0
        self.plan_sha256 = file_sha256(self.folder / "plan.json")
        self.start, self.no_belief = self._read_start()
        self.belief = None if self.start is None else Belief(self.start.search_map.copy(), self.start.p0,
                                                             self.start.looks_before, self.start.sortie,
                                                             self.start.found)
        self.segments, self.segments_from, self.segments_note = self._plan_segments()
        self.readings: list[_Reading] = []
        self.tracks: dict[int, list[tuple[float, float]]] = {uid: [] for uid in plan.uavs}
        self.started_utc = datetime.now(UTC)
        self.finished: bool | None = None
        self.reason: str | None = None
        self.written: list[Path] = []
        self.write_error: str | None = None

    def _read_start(self) -> tuple[Belief | None, str | None]:
        """The belief the plan was made from, or None and why there is none."""
        path = self.folder / BELIEF_FILE
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return None, f"the plan folder has no {BELIEF_FILE} (planned before campaigns): plan it again to continue"
        except (OSError, ValueError) as exc:
            return None, f"{BELIEF_FILE} is not readable ({exc})"
        try:
            return belief_from_dict(data, self.plan.no_fly), None
        except ValueError as exc:
            return None, f"{BELIEF_FILE}: {exc}"

    def _plan_segments(self) -> tuple[list[Segment], str, str | None]:
        """The segments the plan reported (`gcs.plans.segments.plan_folder_segments`), where they
        came from, and why the grid's blocks stand in for the area file's when they must."""
        searchable = ~self.plan.no_fly
        try:
            segments = plan_folder_segments(self.plan, searchable)
        except ValueError as exc:
            return block_segments(searchable), FROM_GRID, f"the area file's segments are not reported: {exc}"
        theory = self.plan.raw.get("search_theory") or {}
        return segments, FROM_AREA_FILE if theory.get("segments_from") == FROM_AREA_FILE else FROM_GRID, None

    # ---- during the flight -------------------------------------------------------------

    def on_event(self, event: FlightEvent, now: float) -> None:
        """A `FlightListener`: every reading is folded into the belief as it arrives."""
        from gcs.flight.events import ReadingReceived

        if isinstance(event, ReadingReceived):
            self._fold(event.uav_id, event.detection)

    def _fold(self, uav_id: int, d: Detection) -> None:
        cell = self.plan.cell_of(d.lat_deg, d.lon_deg)
        self.readings.append(_Reading(uav_id, d.index, cell, d.hit, d.time_s, d.lat_deg, d.lon_deg))
        if cell is not None and self.belief is not None:
            self.belief.search_map.observe(*cell, d.hit, self.pc, self.pf)

    def restore(self, state: JournalState) -> None:
        """Continue the record of a flight a restarted station took over (`gcs fly --resume`):
        its start, the readings the journal kept (folded into the belief again) and the tracks."""
        self.started_utc = datetime.fromisoformat(state.start.utc)
        for uav_id, d in state.readings:
            self._fold(uav_id, d)
        for uid, v in state.vehicles.items():
            if uid in self.tracks:
                self.tracks[uid] = list(v.track)

    def sample(self, controller: FlightController) -> None:
        """Add each vehicle's position to its track once it has taken off and moved `min_move_m`."""
        for uid, st in controller.status.items():
            if not (st.airborne_seen and st.has_position) or uid not in self.tracks:
                continue
            track = self.tracks[uid]
            here = (st.lat_deg, st.lon_deg)
            if not track or math.hypot(*np.subtract(self.plan.local_m(*here), self.plan.local_m(*track[-1]))) \
                    >= self.min_move_m:
                track.append(here)

    @contextlib.asynccontextmanager
    async def attach(self, controller: FlightController) -> AsyncIterator[SortieLog]:
        """Listen and sample while the block runs; write the record when it ends, however."""
        from gcs.flight.watch import watching

        async with watching(controller, self.on_event, lambda last: self.sample(controller), self.poll_s,
                            "sortie-log", on_end=lambda failure: self.finish(controller, failure)):
            yield self

    # ---- when it ends ------------------------------------------------------------------

    def finish(self, controller: FlightController, failure: BaseException | None = None) -> None:
        """Decide whether the flight finished, and publish the record (an error is kept in
        `write_error` and said on the controller's output: it never hides the flight's own end)."""
        self.finished, self.reason = self._outcome(controller, failure)
        tracks, detections = self.tracks_geojson(controller), self.detections_geojson()
        files = {name: json.dumps(data, indent=1) + "\n" for name, data in
                 ((SORTIE_FILE, self.record(controller)), (TRACKS_FILE, tracks), (DETECTIONS_FILE, detections))}
        try:
            files.update(self.map_files(tracks, detections))
        except Exception as exc:  # the sortie record matters more than its maps: it is written all the same
            controller.say(None, f"error: the KML and GPX files of the flight were not written ({exc})")
        paths = [self.folder / name for name in files]
        try:
            with staged_outputs(paths) as staged:
                for name, text in files.items():
                    staged[self.folder / name].write_text(text, encoding="utf-8")
            self.written = paths
        except OSError as exc:
            self.write_error = str(exc)
            controller.say(None, f"error: the sortie record was not written ({exc})")

    @staticmethod
    def _outcome(controller: FlightController, failure: BaseException | None) -> tuple[bool, str | None]:
        if failure is not None:
            if isinstance(failure, (KeyboardInterrupt, asyncio.CancelledError)):
                return False, "the flight was interrupted"
            return False, f"the flight ended with an error ({type(failure).__name__}: {failure})"
        if controller.interrupted:
            return False, "the flight was stopped by the operator (Ctrl-C): every vehicle was sent home"
        from gcs.telemetry.status import FINAL_STAGES

        open_ends = [f"UAV {uid} ended {st.stage.value}" for uid, st in sorted(controller.status.items())
                     if st.stage not in FINAL_STAGES]
        if open_ends:
            return False, ", ".join(open_ends) + " (not landed)"
        return True, None

    @property
    def observed(self) -> bool:
        return any(r.cell is not None for r in self.readings)

    def record(self, controller: FlightController) -> dict:
        """The `sortie.json` document."""
        ended = datetime.now(UTC)
        vehicles = []
        for uid, st in sorted(controller.status.items()):
            mine = [r for r in self.readings if r.uav_id == uid]
            vehicles.append({"id": uid, "end": st.stage.value, "return_reason": st.return_reason,
                             "note": st.note or None, "battery_pct": st.battery_pct,
                             "readings": len(mine), "positive": sum(r.hit for r in mine),
                             "track_points": len(self.tracks.get(uid, [])), "track_length_m": round(st.odometer_m, 1)})
        data = {
            "schema_version": SCHEMA_VERSION,
            "sortie": self.sortie,
            "finished": bool(self.finished),
            "reason": self.reason,
            "plan_sha256": self.plan_sha256,
            "area": self.area,
            "started_utc": self.started_utc.isoformat(timespec="seconds"),
            "ended_utc": ended.isoformat(timespec="seconds"),
            "duration_s": round((ended - self.started_utc).total_seconds(), 1),
            "sensor": {"pc": self.pc, "pf": self.pf},
            "observed": self.observed,
            "readings": {"count": len(self.readings), "positive": sum(r.hit for r in self.readings),
                         "outside_grid": sum(r.cell is None for r in self.readings)},
            "vehicles": vehicles,
            "belief": None,
            "no_belief": self.no_belief,
            "reading_log": [[r.uav_id, r.index, None if r.cell is None else r.cell[0] + 1,
                             None if r.cell is None else r.cell[1] + 1, int(r.hit), r.time_s] for r in self.readings],
        }
        if self.belief is not None:
            before, after = self.start.expected(self.pc), self.belief.expected(self.pc)
            available = self.belief.available()
            data["belief"] = belief_to_dict(self.belief.with_found(self.targets_found()), "flight") | {
                "sortie_looks": self.belief.search_map.visits.tolist()}
            data["campaign"] = {"expected_targets_in_area": available, "expected_before": before,
                                "expected_after": after, "expected_targets_found": after - before,
                                "pos_before": before / available if available > 0 else 0.0,
                                "pos_after": after / available if available > 0 else 0.0}
            theory = self.search_theory()
            if theory is not None:
                data["search_theory"] = theory.as_dict() | {"segments_from": self.segments_from}
        return data

    def targets_found(self) -> list[tuple[int, int]]:
        """The plan's true targets (an exercise's) whose cell got a positive reading."""
        targets = set(self.plan.targets)
        return sorted({r.cell for r in self.readings if r.hit and r.cell is not None and r.cell in targets})

    def search_theory(self) -> SearchTheory | None:
        """POA / POD / POS per segment of what this flight read (`planner.search_theory`, over the
        plan's segments: the area file's, else named blocks of the grid, and the share of the
        subject plan.json says lies inside the area); None without a belief or prior mass."""
        if self.belief is None or self.start is None or not self.start.available() > 0:
            return None
        planned = self.plan.raw.get("search_theory") or {}
        return search_theory(self.start.p0, self.belief.searchable, self.pc, self.belief.search_map.visits,
                             self.segments, looks_before=self.start.looks_before,
                             inside=float(planned.get("inside_area", 1.0)))

    def tracks_geojson(self, controller: FlightController) -> dict:
        features = []
        for uid, track in sorted(self.tracks.items()):
            st = controller.status.get(uid)
            geometry = {"type": "LineString", "coordinates": [[lon, lat] for lat, lon in track]} if len(track) > 1 \
                else None
            features.append({"type": "Feature", "geometry": geometry,
                             "properties": {"uav": uid, "name": self.plan.uavs[uid].name, "sortie": self.sortie,
                                            "end": st.stage.value if st else None, "points": len(track),
                                            "length_m": round(st.odometer_m, 1) if st else 0.0}})
        return {"type": "FeatureCollection", "name": f"{self.folder.name} sortie {self.sortie} tracks",
                "features": features}

    def detections_geojson(self) -> dict:
        targets = set(self.plan.targets)
        features = [{"type": "Feature", "geometry": {"type": "Point", "coordinates": [r.lon_deg, r.lat_deg]},
                     "properties": {"uav": r.uav_id, "index": r.index, "time_s": r.time_s, "sortie": self.sortie,
                                    "cell": None if r.cell is None else [r.cell[0] + 1, r.cell[1] + 1],
                                    "known_target_cell": r.cell in targets}}
                    for r in self.readings if r.hit]
        return {"type": "FeatureCollection", "name": f"{self.folder.name} sortie {self.sortie} detections",
                "features": features}

    def map_files(self, tracks: dict, detections: dict) -> dict[str, str]:
        """tracks.kml, tracks.gpx, detections.kml and detections.gpx of the two GeoJSON collections
        (Google Earth, CalTopo, QGIS, handheld GPS)."""
        from gcs.missions.gpx import gpx_text
        from gcs.missions.kml import kml_text
        from gcs.missions.paths import uav_label

        title = f"{self.folder.name} sortie {self.sortie}"
        tracked = [uav_label(f["properties"]["uav"], f["properties"]["name"]) for f in tracks["features"]]
        seen = [f"UAV {f['properties']['uav']} reading {f['properties']['index']}" for f in detections["features"]]
        return {"tracks.kml": kml_text(tracks, "tracks", tracked, f"{title}: flown tracks", "LineString"),
                "tracks.gpx": gpx_text(tracks, tracked, "LineString"),
                "detections.kml": kml_text(detections, "detections", seen, f"{title}: detections", "Point"),
                "detections.gpx": gpx_text(detections, seen, "Point")}

    def report(self) -> str:
        """What the record says, for the end of `gcs fly`."""
        if self.finished is None:
            return "sortie record: not written (the flight did not start)"
        if self.write_error is not None:
            return f"sortie record: NOT written ({self.write_error})"
        names = ", ".join(p.name for p in self.written)
        positive = sum(r.hit for r in self.readings)
        lines = [f"sortie {self.sortie} recorded in {self.folder}/ ({names}): {len(self.readings)} readings, "
                 f"{positive} positive"]
        if self.belief is None:
            lines.append(f"no belief map: {self.no_belief}")
        elif not self.observed:
            lines.append("no readings arrived (a vehicle needs `gcs detector` to send them): nothing was observed, the "
                         "posterior is the prior")
        if not self.finished:
            lines.append(f"the flight did not finish ({self.reason}): gcs plan --continue will refuse this folder")
        elif self.belief is not None:
            before, after = self.start.expected(self.pc), self.belief.expected(self.pc)
            available = self.belief.available()
            theory = self.search_theory()
            if theory is not None:
                lines.append(theory.table())
            if self.segments_note is not None:
                lines.append(self.segments_note)
            if available > 0:
                lines.append(f"campaign probability of success {before / available:.1%} -> {after / available:.1%} "
                             f"after sortie {self.sortie}; plan the next with: gcs plan --continue {self.folder}")
        return "\n".join(lines)
