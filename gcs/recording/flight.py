"""Rerun recordings of flights (`gcs fly`) and experiments (`gcs experiment`).

`FlightRecorder` listens to a `FlightController`'s events and samples its vehicle states (it
never writes them), as the bus's `FlightFeed` does: telemetry at a bounded rate per UAV, every
stage change, take-off, mode change and reading as it happens. Everything is
logged on the `flight_time` timeline (seconds since the GCS loop started, its own clock) and on
`wall_time`:

- `geo/uav/<id>` position (GeoPoints), `geo/uav/<id>/trail` the segment flown since the last
  sample (GeoLineStrings; the layout shows all past segments), `geo/plan/<id>` the planned path
  (static), `geo/airports`, `geo/targets` (static), `geo/detections` positive readings (the new
  ones in each row; the layout shows all past rows);
- `uav/<id>/battery` battery %, `uav/<id>/mission` current mission item, `uav/<id>/range/left` and
  `uav/<id>/range/margin` the return trigger's range left and margin (metres of cruise, when known),
  `uav/<id>/wind/speed` and `uav/<id>/wind/sigma` its wind estimate and uncertainty, `uav/<id>/state`
  stage, flight mode, mission item, altitude, ground speed (values);
- `events`: take-off, stage changes (return triggered and why, RTL, landed, lost link, link back,
  failures), the start of the plan's own return, flight-mode changes, positive readings (the
  text of `gcs.flight.watch.event_lines`, which the flight journal keeps too);
- with the flight's sortie record (`sortie`): `geo/segments` the plan's segments on the map
  (static, coloured by their POA), and when the flight ends `segments` one row of the figures the
  flight gives them (POA before, POD, POS, cumulative POD, POA after: `gcs.recording.segments`).

A flight taken over by a restarted station (`gcs fly --resume`) goes on in a further file,
`flight.resume1.rrd`, ... (`segment_path`), with the same recording id: Rerun shows the files as
one recording.

`record_figures` logs matplotlib figures' series (`gcs experiment`) as scalar plots."""

from __future__ import annotations

import asyncio
import contextlib
import math
import sys
import time
import uuid
import warnings
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb

from gcs.display.overview import uav_colour
from gcs.flight.events import FlightEvent, ReadingReceived
from gcs.flight.watch import EventLine, event_lines, watching
from gcs.recording.plan import GEO_STRING, MAP_LUT, EntityRows, check_viewer, flush_rows, lighter, open_stream

if TYPE_CHECKING:

    from gcs.flight.controller import FlightController
    from gcs.flight.journal import JournalState
    from gcs.flight.sortie import SortieLog
    from gcs.plans.plan_folder import FleetPlan

FLIGHT_TIME = "flight_time"
WALL_TIME = "wall_time"
DEFAULT_SAMPLE_HZ = 5.0

_RETURN_STAGES = ("return", "rtl")


def _flight_columns(times: list[tuple[float, float]]) -> list:
    """Rows timed (seconds since the flight began, wall-clock seconds) on both clocks."""
    flight_s, wall_s = zip(*times)
    return [rr.TimeColumn(FLIGHT_TIME, duration=np.asarray(flight_s)),
            rr.TimeColumn(WALL_TIME, timestamp=np.asarray(wall_s))]


def _finite(value: float | None) -> bool:
    return value is not None and math.isfinite(value)


class FlightRecorder:
    """Logs a flight to a .rrd file (`rrd_path`), a running viewer (`connect`), or both.

        async with recorder.attach(controller):
            await controller.run()

    `sample_hz` bounds the telemetry rows per UAV, sampled every `poll_s`; events (stages,
    take-off, modes, readings) are logged the moment the controller raises them. Rows are sent
    every `flush_interval_s` (default 1 s with a viewer, else 5 s) and when the block ends.

    `resumed` continues the recording of a flight whose station died (`gcs fly --resume`): this
    recorder writes its own file, a segment of the same recording (Rerun joins files that share
    a recording id), and first logs the event-log lines the earlier segments missed.

    `sortie` (a `gcs.flight.sortie.SortieLog` watching the same flight, set before it flies) adds
    the plan's segments and, at the end, the figures its record gives them."""

    def __init__(self, rrd_path: str | Path | None, connect: str | None, plan: FleetPlan, *, name: str = "flight",
                 sample_hz: float = DEFAULT_SAMPLE_HZ, poll_s: float = 0.05,
                 flush_interval_s: float | None = None, resumed: ResumedRecording | None = None) -> None:
        if sample_hz <= 0:
            raise ValueError("sample_hz must be positive")
        self.rrd_path = Path(rrd_path) if rrd_path is not None else None
        self.connect = connect
        self.plan = plan
        self.name = name
        self.sample_every_s = 1.0 / sample_hz
        self.poll_s = poll_s
        # every send is a chunk of ~1 KB overhead per entity: often for a viewer, seldom for a file
        self.flush_interval_s = flush_interval_s if flush_interval_s is not None else (1.0 if connect else 5.0)
        self.rec: rr.RecordingStream | None = None
        self.t0 = time.monotonic()
        self._rows: dict[str, EntityRows] = {}
        self._last_sample: dict[int, float] = {}
        self._last_geo: dict[int, tuple[float, float]] = {}
        self._planned_return: set[int] = set()
        self._controller: FlightController | None = None
        self._last_flush = 0.0
        self._sink_failed = False
        self.resumed = resumed
        if resumed is not None:
            self._planned_return |= set(resumed.planned_return)
        self.sortie: SortieLog | None = None

    @property
    def enabled(self) -> bool:
        return self.rrd_path is not None or self.connect is not None

    @property
    def recording_id(self) -> str | None:
        """The Rerun recording id (once open): every segment of one flight shares it."""
        return None if self.rec is None else str(self.rec.get_recording_id())

    # -- life cycle ---------------------------------------------------------------------------

    def open(self) -> None:
        if not self.enabled or self.rec is not None:
            return
        if self.rrd_path is not None and self.resumed is None:  # an earlier flight's continuations
            for stale in self.rrd_path.parent.glob(f"{self.rrd_path.stem}.resume*{self.rrd_path.suffix}"):
                stale.unlink(missing_ok=True)
        blueprint = flight_blueprint(sorted(self.plan.uavs))
        self.rec = open_stream(self.rrd_path, self.connect, self.name, blueprint,
                               self.resumed.recording_id if self.resumed is not None else None)
        self._log_static()
        if self.resumed is not None:
            self._log_backlog(self.resumed)
        self._last_flush = time.monotonic()

    def _log_backlog(self, resumed: ResumedRecording) -> None:
        """What the journal kept and the earlier segments lack, at the flight seconds it happened."""
        def when(t: float) -> tuple[float, float]:
            return t, resumed.wall_s0 + t

        for t, line in resumed.events:
            self._row("events", rr.TextLog.columns).add(when(t), 1, text=[line.line], level=[line.level])
        for uid, points in resumed.positions.items():
            colour = uav_colour(sorted(self.plan.uavs).index(uid))
            for i, (t, lat, lon) in enumerate(points):
                self._row(f"geo/uav/{uid}", rr.GeoPoints.columns).add(when(t), 1, positions=[(lat, lon)])
                if i:
                    segment = np.array((points[i - 1][1:], (lat, lon)))
                    self._row(f"geo/uav/{uid}/trail", rr.GeoLineStrings.columns, line_strings=GEO_STRING).add(
                        when(t), 1, line_strings=[segment], colors=[colour])
        for uid, samples in resumed.battery.items():
            for t, pct in samples:
                self._row(f"uav/{uid}/battery", rr.Scalars.columns).add(when(t), 1, scalars=[pct])

    def close(self) -> None:
        if self.rec is None:
            return
        self._flush()
        with contextlib.suppress(RuntimeError):
            self.rec.disconnect()
        self.rec = None

    @contextlib.asynccontextmanager
    async def attach(self, controller: FlightController) -> AsyncIterator[FlightRecorder]:
        """Log `controller`'s events as they happen and sample its telemetry in a background task
        while the block runs; the last state, an
        interruption event when the block raised, and every buffered row on the way out (even when
        the segments' figures fail: then an event and a warning on stderr say so, and the block's
        own exception, if any, is the one raised)."""
        self.t0 = controller.t0
        self._controller = controller
        self.open()
        if self.resumed is not None:
            self._event(time.monotonic(), None, f"station restarted: flight resumed after {self.resumed.away_s:.0f} s "
                                                "without it", "WARN")
        try:
            async with watching(controller, self.on_event,
                                lambda last: self.sample(controller, time.monotonic(), force=last), self.poll_s,
                                "rerun-flight-recorder"):
                try:
                    yield self
                except BaseException as exc:
                    what = "Ctrl-C" if isinstance(exc, (KeyboardInterrupt, asyncio.CancelledError)) \
                        else f"{type(exc).__name__}: {exc}"
                    self._event(time.monotonic(), None, f"flight interrupted ({what})", "ERROR")
                    raise
        finally:
            try:
                if controller.interrupted:
                    self._event(time.monotonic(), None, "interrupted by the operator: RTL commanded", "WARN")
                self._log_segment_figures(time.monotonic())
            except Exception as exc:  # the figures must not hide the flight's end nor lose its rows
                self._event(time.monotonic(), None, f"the segments' figures are not recorded "
                                                    f"({type(exc).__name__}: {exc})", "WARN")
                print(f"warning: Rerun: the segments' figures are not recorded ({type(exc).__name__}: {exc}); "
                      f"the rest of the flight is", file=sys.stderr, flush=True)
            finally:
                self.close()

    # -- what is logged -----------------------------------------------------------------------

    def _row(self, path: str, columns: Callable, **strips) -> EntityRows:
        rows = self._rows.get(path)
        if rows is None:
            rows = self._rows[path] = EntityRows(columns, strips, _flight_columns)
        return rows

    def _add(self, path: str, columns: Callable, now: float, n: int, strips: dict | None = None, **fields) -> None:
        self._row(path, columns, **(strips or {})).add((now - self.t0, time.time()), n, **fields)

    def _event(self, now: float, uid: int | None, text: str, level: str = "INFO") -> None:
        line = f"UAV {uid}: {text}" if uid is not None else text
        self._add("events", rr.TextLog.columns, now, 1, text=[line], level=[level])

    def _log_static(self) -> None:
        assert self.rec is not None
        plan = self.plan
        ids = sorted(plan.uavs)
        self.rec.log("geo/airports", rr.GeoPoints(lat_lon=[plan.uavs[u].airport_lat_lon for u in ids],
                                                  radii=rr.Radius.ui_points(6.0),
                                                  colors=[uav_colour(i) for i in range(len(ids))]), static=True)
        if plan.targets:
            self.rec.log("geo/targets", rr.GeoPoints(lat_lon=[plan.cell_lat_lon(x, y) for x, y in plan.targets],
                                                     radii=rr.Radius.ui_points(3.0), colors=(120, 0, 0)), static=True)
        self.rec.log("geo/detections", rr.GeoPoints.from_fields(radii=[rr.Radius.ui_points(4.0)], colors=[(0, 230, 0)]),
                     static=True)
        for i, uid in enumerate(ids):
            task, colour = plan.uavs[uid], uav_colour(i)
            search = [(p.lat_deg, p.lon_deg) for p in task.trajectory if p.stage == "search"]
            back = [(p.lat_deg, p.lon_deg) for p in task.trajectory[max(0, len(search) - 1):] if p.stage != "search"]
            strings, colours = [search], [colour]
            if back:
                strings.append([search[-1], *back] if search else back)
                colours.append(lighter(colour))
            self.rec.log(f"geo/plan/{uid}", rr.GeoLineStrings(lat_lon=strings, colors=colours,
                                                              radii=rr.Radius.ui_points(1.0)), static=True)
            self.rec.log(f"geo/uav/{uid}", rr.GeoPoints.from_fields(radii=[rr.Radius.ui_points(7.0)], colors=[colour]),
                         static=True)
            self.rec.log(f"geo/uav/{uid}/trail", rr.GeoLineStrings.from_fields(radii=[rr.Radius.ui_points(2.5)],
                                                                               colors=[colour]), static=True)
            self.rec.log(f"uav/{uid}/battery", rr.SeriesLines(names="battery %", colors=colour), static=True)
            self.rec.log(f"uav/{uid}/mission", rr.SeriesLines(names="mission item", colors=colour), static=True)
            self.rec.log(f"uav/{uid}/range/left", rr.SeriesLines(names="range left (m)", colors=colour),
                         static=True)
            self.rec.log(f"uav/{uid}/range/margin", rr.SeriesLines(names="return margin (m)",
                                                                   colors=(220, 50, 50)), static=True)
            self.rec.log(f"uav/{uid}/wind/speed", rr.SeriesLines(names="wind (m/s)", colors=colour), static=True)
            self.rec.log(f"uav/{uid}/wind/sigma", rr.SeriesLines(names="wind uncertainty, 1 sigma (m/s)",
                                                                 colors=lighter(colour)), static=True)
        self._log_segment_outlines()

    def _cells_lat_lon(self, cells: np.ndarray) -> np.ndarray:
        """(n, 2) fractional 0-based cells -> (n, 2) rows of (lat, lon)."""
        lat, lon = self.plan.frame.local2geodetic(*self.plan.grid.centre_m(cells[:, 0], cells[:, 1]))
        return np.column_stack([lat, lon])

    def _log_segment_outlines(self) -> None:
        """The plan's segments on the map, coloured by their POA before the flight."""
        theory = self.sortie.search_theory() if self.sortie is not None and self.rec is not None else None
        if theory is None:  # before any reading: the POAs the flight starts from
            return
        from gcs.recording.segments import ROOT, outlines

        drawn = outlines(self.sortie.segments, theory, MAP_LUT)
        if len(drawn.cells):
            geo = self._cells_lat_lon(drawn.cells.reshape(-1, 2)).reshape(-1, 2, 2)
            self.rec.log(f"geo/{ROOT}", rr.GeoLineStrings(lat_lon=list(geo), colors=drawn.colours,
                                                          radii=rr.Radius.ui_points(2.0)), static=True)

    def _log_segment_figures(self, now: float) -> None:
        """The figures the flight's sortie record gives the segments, one row at the flight's end."""
        theory = self.sortie.search_theory() if self.sortie is not None and self.rec is not None else None
        if theory is None:
            return
        from gcs.recording.segments import ROOT, figure_values

        self._add(ROOT, rr.AnyValues.columns, now, len(theory.segments), **figure_values(theory))

    def sample(self, controller: FlightController, now: float, *, force: bool = False) -> None:
        """One pass: telemetry rows where `sample_hz` allows, and the planned return's start."""
        if self.rec is None:
            return
        for uid, st in sorted(controller.status.items()):
            self._planned_return_begins(uid, st, now)
            last = self._last_sample.get(uid)
            if force or last is None or now - last >= self.sample_every_s:
                self._last_sample[uid] = now
                self._telemetry(uid, st, now)
        if now - self._last_flush >= self.flush_interval_s:
            self._flush()

    def _telemetry(self, uid: int, st, now: float) -> None:
        base = f"uav/{uid}"
        if st.has_position:
            here = (st.lat_deg, st.lon_deg)
            self._add(f"geo/uav/{uid}", rr.GeoPoints.columns, now, 1, positions=[here])
            before = self._last_geo.get(uid)
            if before is not None and before != here:
                colour = uav_colour(sorted(self.plan.uavs).index(uid))
                if st.stage.value in _RETURN_STAGES:
                    colour = lighter(colour)
                self._add(f"geo/uav/{uid}/trail", rr.GeoLineStrings.columns, now, 1,
                          strips={"line_strings": GEO_STRING},
                          line_strings=[np.array((before, here))], colors=[colour])
            self._last_geo[uid] = here
        if st.battery_pct is not None:
            self._add(f"{base}/battery", rr.Scalars.columns, now, 1, scalars=[st.battery_pct])
        if st.mission_total or st.mission_seq:
            self._add(f"{base}/mission", rr.Scalars.columns, now, 1, scalars=[st.mission_seq])
        if _finite(st.range_left):
            self._add(f"{base}/range/left", rr.Scalars.columns, now, 1, scalars=[st.range_left])
        if _finite(st.margin):
            self._add(f"{base}/range/margin", rr.Scalars.columns, now, 1, scalars=[st.margin])
        if st.wind is not None:
            self._add(f"{base}/wind/speed", rr.Scalars.columns, now, 1, scalars=[st.wind.speed_m_s])
            self._add(f"{base}/wind/sigma", rr.Scalars.columns, now, 1, scalars=[st.wind.sigma_m_s])
        self._add(f"{base}/state", rr.AnyValues.columns, now, 1, stage=[st.stage.value], mode=[st.mode_name],
                  mission_item=[st.mission_seq], mission_total=[st.mission_total], alt_m=[st.rel_alt_m],
                  ground_speed_m_s=[st.ground_speed_m_s])

    def on_event(self, event: FlightEvent, now: float) -> None:
        """Log one controller event as it happens."""
        if self.rec is None:
            return
        for line in event_lines(event, self._controller.status, self.plan):
            self._event(now, line.uav_id, line.text, line.level)
        if isinstance(event, ReadingReceived) and event.detection.hit:
            d = event.detection
            self._add("geo/detections", rr.GeoPoints.columns, now, 1, positions=[(d.lat_deg, d.lon_deg)])

    def _planned_return_begins(self, uid: int, st, now: float) -> None:
        """Said once a vehicle that follows its plan home is seen on the plan's return (or down
        after flying it: a short return at a high speed-up may pass between two samples)."""
        if uid in self._planned_return or uid not in self.plan.uavs or st.return_reason is not None:
            return
        trajectory = self.plan.uavs[uid].trajectory
        first = next((i for i, p in enumerate(trajectory) if i > 0 and p.stage != "search"), None)
        if first is not None and st.stage.value in ("search", "landed") and st.track_index >= first:
            self._planned_return.add(uid)
            self._event(now, uid, f"planned return begins (step {trajectory[first].step} of the plan)")

    def _flush(self) -> None:
        if self.rec is None:
            return
        self._sink_failed = flush_rows(self.rec, self._rows, "flight", self._sink_failed)
        self._last_flush = time.monotonic()


def flight_blueprint(uav_ids: list[int]) -> rrb.Blueprint:
    """The map (trails over the whole past), per-UAV tabs of battery, return trigger and mission
    progress, and the event log."""
    whole_past = rrb.VisibleTimeRanges(rrb.VisibleTimeRange(FLIGHT_TIME, start=rrb.TimeRangeBoundary.infinite(),
                                                            end=rrb.TimeRangeBoundary.cursor_relative()))
    detections = rrb.VisibleTimeRanges(rrb.VisibleTimeRange(FLIGHT_TIME, start=rrb.TimeRangeBoundary.infinite(),
                                                            end=rrb.TimeRangeBoundary.cursor_relative()))
    overrides = {f"/geo/uav/{u}/trail": whole_past for u in uav_ids}
    overrides["/geo/detections"] = detections
    map_view = rrb.MapView(name="map", origin="/geo", overrides=overrides)
    tabs = [rrb.Vertical(rrb.TimeSeriesView(name=f"UAV {u}: battery %", origin=f"/uav/{u}/battery"),
                         rrb.TimeSeriesView(name=f"UAV {u}: return trigger (m)", origin=f"/uav/{u}/range"),
                         rrb.TimeSeriesView(name=f"UAV {u}: mission item", origin=f"/uav/{u}/mission"),
                         name=f"UAV {u}") for u in uav_ids]
    right = rrb.Vertical(rrb.Tabs(*tabs, name="UAVs") if tabs else rrb.Vertical(),
                         rrb.TextLogView(name="events", origin="/events"), row_shares=[2, 1])
    return rrb.Blueprint(rrb.Horizontal(map_view, right, column_shares=[3, 2]),
                         rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed"),
                         rrb.TimePanel(state="collapsed"))


@dataclass(frozen=True)
class ResumedRecording:
    """What a resumed flight's recorder continues: the recording id; what the journal kept that
    the earlier segments lack (the killed station had not flushed it yet), in flight seconds:
    event-log lines, positions and battery per UAV; the wall-clock time of flight second 0;
    the UAVs whose planned return had begun; how long the station was away."""

    recording_id: str
    events: tuple[tuple[float, EventLine], ...] = ()
    positions: dict[int, list[tuple[float, float, float]]] = field(default_factory=dict)
    battery: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    wall_s0: float = 0.0
    planned_return: frozenset[int] = frozenset()
    away_s: float = 0.0


def resumed_recording(state: JournalState, plan: FleetPlan, earlier: list[Path], away_s: float) -> ResumedRecording:
    """The `ResumedRecording` of a journal, given the recording files written so far."""
    until = recorded_until(earlier)

    def after(entity: str, t: float) -> bool:
        return entity not in until or t > until[entity] + 2e-6  # the journal keeps microseconds

    events = tuple((t, line) for t, line in state.events if after("events", t))
    positions, battery = {}, {}
    for uid, v in state.vehicles.items():
        if uid not in plan.uavs:
            continue
        positions[uid] = [(t, *p) for t, p in zip(v.track_t, v.track) if after(f"geo/uav/{uid}", t)]
        battery[uid] = [(t, b[1]) for t, b in zip(v.battery_t, v.battery_samples) if after(f"uav/{uid}/battery", t)]
    planned_return = frozenset(uid for uid, v in state.vehicles.items() if uid in plan.uavs
                               and 0 < v.track_index < len(plan.uavs[uid].trajectory)
                               and plan.uavs[uid].trajectory[v.track_index].stage != "search")
    return ResumedRecording(state.start.recording_id or str(uuid.uuid4()), events, positions, battery,
                            state.start.wall_s, planned_return, away_s)


def segment_path(first: Path, k: int) -> Path:
    """The file of a flight recording's segment `k` (0: the first, `flight.rrd`; then
    `flight.resume1.rrd`, ...)."""
    return first if k == 0 else first.with_name(f"{first.stem}.resume{k}{first.suffix}")


def new_flight_recorder(plan: FleetPlan, rrd: Path | None, connect: str | None) -> FlightRecorder | None:
    """The recorder of a new flight of `plan` to the file `rrd` and/or the viewer at `connect`
    (UserError if none listens there), or None when nothing is recorded."""
    if rrd is None and connect is None:
        return None
    if connect is not None:
        check_viewer(connect)
    return FlightRecorder(rrd, connect, plan, name=f"flight {Path(plan.folder).name}")


def resumed_flight_recorder(plan: FleetPlan, state: JournalState, *, record: bool,
                            connect: str | None) -> FlightRecorder | None:
    """The recorder of a flight taken over after its station died: the recording's next segment
    beside the first (when the flight was recorded to a file and `record`), and/or the viewer at
    `connect`, first logging what the earlier segments lack; None when nothing is recorded."""
    folder = Path(plan.folder)
    rrd = segment_path(folder / state.start.rrd, len(state.segments)) if record and state.start.rrd else None
    if rrd is None and connect is None:
        return None
    if connect is not None:
        check_viewer(connect)
    resumed = resumed_recording(state, plan, [folder / name for name in state.segments],
                                time.time() - state.start.wall_s - state.last_t)
    return FlightRecorder(rrd, connect, plan, name=f"flight {folder.name}", resumed=resumed)


def recorded_until(paths: list[Path]) -> dict[str, float]:
    """The latest flight second of each entity's rows in these recording files (a file cut short
    by a killed process is read as far as it goes)."""
    from rerun.chunk import RrdReader

    latest: dict[str, float] = {}
    for path in paths:
        if not path.exists():
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a killed writer leaves no footer
            try:
                chunks = list(RrdReader(str(path)).stream())
            except Exception:
                continue
        for chunk in chunks:
            if chunk.is_static:
                continue
            batch = chunk.to_record_batch()
            if FLIGHT_TIME not in batch.schema.names:
                continue
            times = batch.column(FLIGHT_TIME).cast(pa.int64()).to_pylist()
            if times:
                entity = chunk.entity_path.lstrip("/")
                latest[entity] = max(latest.get(entity, -math.inf), max(times) / 1e9)
    return latest


# -- experiments ------------------------------------------------------------------------------------
