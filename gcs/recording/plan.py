"""Rerun recording of a closed search, built from the `StepRecord`s the planner yields.

The recorder only reads records (and the scenario and final plan): it never reaches into the
planner. Everything is logged on the `step` sequence timeline:

- `maps/tep`, `maps/eu`: the TEP and EU maps as colour images (viridis, 0 = dark, 1 = yellow);
- `world/...`: the 2-D grid view (x east, y north; one view unit per cell): no-fly cells,
  known / key region outlines, airports, true targets, targets found, sensor detections and
  false alarms (cumulative), and per UAV its pose and heading arrow, its trail (the segment
  flown each step, lighter on the way home; the layout shows all past segments) and the chosen /
  runner-up Np-step paths of its decision with their J1;
- `uav/<id>/state`: cell x, y (1-based, as in the plan file), heading and stage, one row per
  step flown (the plan's trajectory, step 0 included);
- `uav/<id>/range`: the return trigger's inputs (range left, return cost, margin) and
  `uav/<id>/j1` the chosen and runner-up J1, as plots;
- `uav/<id>/success`: the UAV's expected targets found so far, `success/expected` the team's and
  `success/share` the probability of success in percent (expected over what the prior puts in
  the area; `planner.success`), as plots from step 1;
- `events`: return events with their reason, targets found, landings, the end or interruption;
- `geo/...` (when a cells -> (lat, lon) function is given): the same trajectories on a map;
- `segments`, `world/segments`, `geo/segments` (from `log_segments`, an area plan's): the search
  team's segments with the figures the plan gives them (`gcs.recording.segments`).

Rows are buffered and sent column-wise (`send_columns`) at most every `flush_interval_s`
seconds, and always when the recorder closes, also after an exception or Ctrl-C: a recording
cut short is readable up to the last flushed step."""

from __future__ import annotations

import socket
import sys
import time
import warnings
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlparse

import numpy as np
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb

from gcs.display.overview import mask_outline, region_masks, title_outcome, uav_colour
from gcs.errors import UserError
from gcs.recording.plan_rules import interruption, map_interval
from planner.dtscs import StepRecord
from planner.motion import HEADING_DX, HEADING_DY
from planner.plan import Plan, ReturnReason, Stage
from planner.scenario import Scenario
from planner.search_theory import SearchTheory, Segment

TIMELINE = "step"
DEFAULT_CONNECT = "rerun+http://127.0.0.1:9876/proxy"
APPLICATION_ID = "gcs"
FLUSH_TIMEOUT_S = 10.0

CellsToLatLon = Callable[[np.ndarray], np.ndarray]
"""Maps (n, 2) cells, 0-based (x, y), to (n, 2) rows of (latitude, longitude) in degrees of their
centres (e.g. `AreaGrid.cells_lonlat`). Fractional cells must work too: (x + 0.5, y) is the
middle of the cell's east edge (used for region outlines)."""

PLAN_COLOURS = [(255, 255, 255), (150, 150, 150)]  # chosen, runner-up

RETURN_REASON_TEXT = {
    ReturnReason.RANGE: "one more search step would leave it unable to get home (eq. 24)",
    ReturnReason.ORDER: "return order",
    ReturnReason.RANGE_CUT: "range cut below what the way home needs",
    ReturnReason.BOXED_IN: "no feasible search step (boxed in)",
}


def lighter(colour: tuple[int, int, int], amount: float = 0.55) -> tuple[int, int, int]:
    """`colour` moved `amount` of the way to white: a UAV's way home, drawn beside its search."""
    return tuple(int(c + (255 - c) * amount) for c in colour)  # type: ignore[return-value]


# matplotlib's viridis sampled every 15 of its 256 entries (and the last), linearly interpolated:
# within 5/255 of the original, without importing matplotlib for a recording.
_VIRIDIS_AT = (0, 15, 30, 45, 60, 75, 90, 105, 120, 135, 150, 165, 180, 195, 210, 225, 240, 255)
_VIRIDIS = ((68, 1, 84), (72, 23, 105), (71, 42, 122), (67, 61, 132), (61, 78, 138), (53, 94, 141), (46, 109, 142),
            (41, 123, 142), (35, 137, 142), (31, 151, 139), (33, 165, 133), (46, 179, 124), (70, 192, 111),
            (101, 203, 94), (137, 213, 72), (176, 221, 47), (216, 226, 25), (253, 231, 37))
MAP_LUT = np.stack([np.interp(np.arange(256), _VIRIDIS_AT, [c[i] for c in _VIRIDIS]) for i in range(3)],
                   axis=-1).round().astype(np.uint8)


def maps_to_rgb(maps: np.ndarray) -> np.ndarray:
    """A stack of [x, y] maps of values in [0, 1] as RGB images (rows from north to south)."""
    index = (np.clip(maps, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    return MAP_LUT[index.transpose(0, 2, 1)[:, ::-1]]


def map_to_rgb(values: np.ndarray) -> np.ndarray:
    """One [x, y] map of values in [0, 1] as an RGB image (rows from north to south)."""
    return maps_to_rgb(values[None])[0]


def cell_to_view(x, y, ny: int) -> np.ndarray:
    """Cell centre(s) in the 2-D view: image pixels, x to the east, rows from the north edge."""
    return np.stack([np.asarray(x, dtype=np.float64) + 0.5, ny - 0.5 - np.asarray(y, dtype=np.float64)], axis=-1)


def view_to_cell(points: np.ndarray, ny: int) -> np.ndarray:
    """Inverse of `cell_to_view`: 0-based integer cells."""
    points = np.asarray(points, dtype=np.float64)
    return np.stack([np.rint(points[..., 0] - 0.5), np.rint(ny - 0.5 - points[..., 1])], axis=-1).astype(np.int64)


STRIP_2D = pa.list_(pa.field("item", pa.list_(pa.field("item", pa.float32(), nullable=False), 2), nullable=False))
GEO_STRING = pa.list_(pa.field("item", pa.list_(pa.field("item", pa.float64(), nullable=False), 2), nullable=False))
BLOB = pa.list_(pa.field("item", pa.uint8(), nullable=False))


def _strips_array(strips: list[np.ndarray], datatype: pa.DataType) -> pa.Array:
    """Many (n_i, 2) strips as one Arrow list array (what Rerun's converters build one by one)."""
    value_type = datatype.value_type.value_type
    dtype = np.float32 if value_type == pa.float32() else np.float64
    lengths = np.fromiter((len(s) for s in strips), dtype=np.int32, count=len(strips))
    offsets = np.zeros(len(strips) + 1, dtype=np.int32)
    np.cumsum(lengths, out=offsets[1:])
    flat = np.concatenate(strips).astype(dtype, copy=False).ravel() if strips else np.zeros(0, dtype)
    points = pa.FixedSizeListArray.from_arrays(pa.array(flat, type=value_type), 2)
    return pa.ListArray.from_arrays(pa.array(offsets), points).cast(datatype)


def step_columns(times: list) -> list:
    """The `step` sequence timeline of rows added with a step number as their time."""
    return [rr.TimeColumn(TIMELINE, sequence=times)]


class EntityRows:
    """Rows of one entity waiting to be sent column-wise (the plan's and the flight's
    recorders batch their rows in these). Each row holds n instances of every
    field it sets (n may be 0: the entity shows nothing at that step). Fields named in
    `strips` hold lists of (m, 2) arrays, one per instance, sent as one Arrow array.
    `time_columns` turns the rows' times (as given to `add`) into Rerun time columns."""

    def __init__(self, columns: Callable, strips: dict[str, pa.DataType] | None = None,
                 time_columns: Callable[[list], list] = step_columns) -> None:
        self.columns = columns
        self.strips = strips or {}
        self.time_columns = time_columns
        self.times: list = []
        self.lengths: list[int] = []
        self.values: dict[str, list] = defaultdict(list)

    def add(self, time, n: int, **fields) -> None:
        self.times.append(time)
        self.lengths.append(n)
        for name, value in fields.items():
            self.values[name].append(value)

    def send(self, rec: rr.RecordingStream, path: str) -> None:
        if not self.times:
            return
        merged = {}
        for name, parts in self.values.items():
            if name in self.strips:
                merged[name] = _strips_array([strip for part in parts for strip in part], self.strips[name])
            elif isinstance(parts[0], np.ndarray):
                merged[name] = np.concatenate(parts)
            else:
                merged[name] = [item for part in parts for item in part]
        rec.send_columns(path, self.time_columns(self.times), self.columns(**merged).partition(self.lengths))
        self.times, self.lengths, self.values = [], [], defaultdict(list)


class _MapRows:
    """Copies of a [x, y] map at some steps, turned into RGB image rows when sent."""

    def __init__(self) -> None:
        self.steps: list[int] = []
        self.maps: list[np.ndarray] = []

    def add(self, step: int, values: np.ndarray) -> None:
        self.steps.append(step)
        self.maps.append(values.copy())

    def send(self, rec: rr.RecordingStream, path: str) -> None:
        if not self.steps:
            return
        images = maps_to_rgb(np.stack(self.maps))
        size = images[0].size
        buffers = pa.ListArray.from_arrays(pa.array(np.arange(len(images) + 1, dtype=np.int32) * size),
                                           pa.array(images.ravel(), type=pa.uint8())).cast(BLOB)
        rec.send_columns(path, [rr.TimeColumn(TIMELINE, sequence=self.steps)], rr.Image.columns(buffer=buffers))
        self.steps, self.maps = [], []


def _pose_columns(positions, vectors) -> rr.ComponentColumnList:
    """A UAV's position (Points2D) and heading arrow (Arrows2D) on one entity."""
    return rr.ComponentColumnList([*rr.Points2D.columns(positions=positions),
                                   *rr.Arrows2D.columns(origins=positions, vectors=vectors)])


@dataclass
class _Track:
    """What the recorder keeps of one UAV between records: where it is (view and lat/lon)."""

    uav_id: int
    colour: tuple[int, int, int]
    position: tuple[float, float] | None = None
    geo: tuple[float, float] | None = None
    landed: bool = False
    rows: dict[str, EntityRows] = field(default_factory=dict)

    @property
    def return_colour(self) -> tuple[int, int, int]:
        return lighter(self.colour)


class PlanRecorder:
    """Logs a closed search to a Rerun recording: a .rrd file (`rrd_path`), a running viewer
    (`connect`, a gRPC URL such as `DEFAULT_CONNECT`), both, or nothing (both None: every call
    is a cheap no-op).

        with PlanRecorder(path, None, scenario) as rec:
            for record in search.run():
                rec.log_step(record)
            rec.log_plan(search.plan())

    `cells_to_lat_lon` adds the geographic entities and the map view. `map_every` logs the TEP
    and EU images every that many steps (always at step 0 and the last step); by default every
    step on grids up to `gcs.recording.plan_rules.MAP_CELLS_EVERY_STEP` cells, less often on bigger ones."""

    def __init__(self, rrd_path: str | Path | None, connect: str | None, scenario: Scenario, *,
                 cells_to_lat_lon: CellsToLatLon | None = None, name: str | None = None,
                 map_every: int | None = None, flush_interval_s: float = 0.5) -> None:
        map_every = map_every if map_every is not None else map_interval(scenario.search_map.tep.size)
        if map_every < 1:
            raise ValueError("map_every must be at least 1")
        self.rrd_path = Path(rrd_path) if rrd_path is not None else None
        self.connect = connect
        self.scenario = scenario
        self.cells_to_lat_lon = cells_to_lat_lon
        self.name = name or scenario.name
        self.map_every = map_every
        self.flush_interval_s = flush_interval_s
        self.nx, self.ny = scenario.search_map.shape
        self._available = float(scenario.success_prior[~scenario.search_map.no_fly].sum())
        self.rec: rr.RecordingStream | None = None
        self._rows: dict[str, EntityRows | _MapRows] = {}
        self._tracks: dict[int, _Track] = {}
        self._found: list[tuple[int, int, str]] = []
        self._detections: list[tuple[int, int]] = []
        self._false_alarms: list[tuple[int, int]] = []
        self._last_record: StepRecord | None = None
        self._last_map_step = -1
        self._last_flush = 0.0
        self._sink_failed = False
        self._lat_lon_cache: dict[tuple[float, float], tuple[float, float]] = {}

    @property
    def enabled(self) -> bool:
        return self.rrd_path is not None or self.connect is not None

    # -- life cycle ---------------------------------------------------------------------------

    def __enter__(self) -> PlanRecorder:
        self.open()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            self.log_interruption(interruption(exc_type, exc))
        self.close()

    def log_interruption(self, what: str) -> None:
        """The run stopped early, by `what` (Ctrl-C or an error): an ERROR event at its last step."""
        if self.rec is None:
            return
        step = self._last_record.step if self._last_record else 0
        self._event(step, f"run interrupted after step {step} ({what})", "ERROR")

    def open(self) -> None:
        if not self.enabled or self.rec is not None:
            return
        self.rec = open_stream(self.rrd_path, self.connect, self.name,
                               default_blueprint(self.scenario, self.cells_to_lat_lon is not None))
        self._log_static()
        self._start()
        self._last_flush = time.monotonic()

    def close(self) -> None:
        """Send what is buffered (and the last maps) and close the file or connection."""
        if self.rec is None:
            return
        last = self._last_record
        if last is not None and self._last_map_step < last.step and last.tep is not None:
            self._add_maps(last.step, last.tep, last.eu)
        self._flush()
        try:
            self.rec.disconnect()
        except RuntimeError:
            pass  # already reported by _flush
        self.rec = None

    # -- what is logged -----------------------------------------------------------------------

    def _row(self, path: str, columns: Callable, **strips: pa.DataType) -> EntityRows:
        rows = self._rows.get(path)
        if rows is None:
            rows = self._rows[path] = EntityRows(columns, strips)
        return rows

    def _static(self, path: str, archetype) -> None:
        assert self.rec is not None
        self.rec.log(path, archetype, static=True)

    def _lat_lon(self, x: int, y: int) -> tuple[float, float]:
        key = (x, y)
        if key not in self._lat_lon_cache:
            lat, lon = self._geo([key])[0]
            self._lat_lon_cache[key] = (float(lat), float(lon))
        return self._lat_lon_cache[key]

    def _geo(self, cells) -> np.ndarray:
        cells = np.asarray(list(cells) if not isinstance(cells, np.ndarray) else cells, dtype=np.float64).reshape(-1, 2)
        return np.asarray(self.cells_to_lat_lon(cells), dtype=np.float64).reshape(-1, 2)  # type: ignore[misc]

    def _geo_outline(self, mask: np.ndarray) -> list[np.ndarray]:
        """A cell mask's outline as lat/lon segments."""
        segments = mask_outline(mask)
        cells = np.stack([segments[..., 0] - 0.5, self.ny - 0.5 - segments[..., 1]], axis=-1)
        return list(self._geo(cells.reshape(-1, 2)).reshape(-1, 2, 2))

    def _log_static(self) -> None:
        s, ny = self.scenario, self.ny
        no_fly = s.search_map.no_fly
        image_format = rr.components.ImageFormat(width=self.nx, height=ny, color_model="RGB", channel_datatype="U8")
        for path in ("maps/tep", "maps/eu"):
            self._static(path, rr.Image.from_fields(format=image_format, draw_order=-10.0))
        self._static("world/no_fly",
                     rr.AnnotationContext([(0, "free", (0, 0, 0, 0)), (1, "no-fly", (200, 30, 30, 190))]))
        self._static("world/no_fly", rr.SegmentationImage(no_fly.T[::-1].astype(np.uint8), draw_order=-5.0))
        region_colours = {"known": (255, 255, 255), "key": (255, 140, 0)}
        for region, mask in region_masks(s).items():
            if mask.any():
                outline = mask_outline(mask)
                self._static(f"world/regions/{region}",
                             rr.LineStrips2D(outline, colors=region_colours[region], radii=0.08, draw_order=-4.0))
        airports = np.array([u.airport for u in s.uavs], dtype=np.float64).reshape(-1, 2)
        self._static("world/airports", rr.Points2D(cell_to_view(airports[:, 0], airports[:, 1], ny), radii=0.6,
                                                   colors=[uav_colour(i) for i in range(len(s.uavs))],
                                                   labels=[f"A{u.uav_id}" for u in s.uavs], draw_order=1.0))
        if len(s.targets):
            self._static("world/targets", rr.Points2D(cell_to_view(s.targets[:, 0], s.targets[:, 1], ny), radii=0.25,
                                                      colors=(120, 0, 0), draw_order=2.0))
        self._static("world/found", rr.Points2D.from_fields(radii=[0.55], colors=[(0, 230, 0)], draw_order=2.5))
        self._static("world/detections", rr.Points2D.from_fields(radii=[0.3], colors=[(120, 255, 120)], draw_order=2.2))
        self._static("world/false_alarms",
                     rr.Points2D.from_fields(radii=[0.3], colors=[(255, 60, 200)], draw_order=2.2))
        for i, u in enumerate(s.uavs):
            colour = uav_colour(i)
            base = f"world/uav/{u.uav_id}"
            self._static(base, rr.Points2D.from_fields(radii=[0.5], colors=[colour], labels=[f"UAV {u.uav_id}"],
                                                       show_labels=True, draw_order=5.0))
            self._static(base, rr.Arrows2D.from_fields(colors=[colour], radii=[0.12], draw_order=5.0))
            self._static(f"{base}/trail", rr.LineStrips2D.from_fields(radii=[0.15], draw_order=3.0))
            self._static(f"{base}/plan", rr.LineStrips2D.from_fields(radii=[0.1], show_labels=False, draw_order=4.0))
            self._static(f"uav/{u.uav_id}/range", rr.SeriesLines(names=["range left", "return cost", "margin"],
                                                                 colors=[colour, (128, 128, 128), (220, 50, 50)]))
            self._static(f"uav/{u.uav_id}/j1", rr.SeriesLines(names=["J1 chosen", "J1 runner-up"],
                                                              colors=[colour, (128, 128, 128)]))
            self._static(f"uav/{u.uav_id}/success", rr.SeriesLines(names=["expected targets found"], colors=[colour]))
            track = self._tracks[u.uav_id] = _Track(u.uav_id, colour)
            track.rows = self._track_rows(track)
        if self.cells_to_lat_lon is not None:
            outlines = {"no_fly": (no_fly, (220, 30, 30))}
            outlines.update({f"regions/{name}": (mask, region_colours[name]) for name, mask in region_masks(s).items()})
            for name, (mask, colour) in outlines.items():
                if mask.any():
                    self._static(f"geo/{name}", rr.GeoLineStrings(lat_lon=self._geo_outline(mask), colors=colour,
                                                                  radii=rr.Radius.ui_points(1.5)))
            self._static("geo/airports", rr.GeoPoints(lat_lon=self._geo([u.airport for u in s.uavs]),
                                                      radii=rr.Radius.ui_points(6.0),
                                                      colors=[uav_colour(i) for i in range(len(s.uavs))]))
            if len(s.targets):
                self._static("geo/targets", rr.GeoPoints(lat_lon=self._geo(s.targets), radii=rr.Radius.ui_points(3.0),
                                                         colors=(120, 0, 0)))
            self._static("geo/found", rr.GeoPoints.from_fields(radii=[rr.Radius.ui_points(6.0)], colors=[(0, 230, 0)]))
            for i, u in enumerate(s.uavs):
                self._static(f"geo/uav/{u.uav_id}",
                             rr.GeoPoints.from_fields(radii=[rr.Radius.ui_points(7.0)], colors=[uav_colour(i)]))
                self._static(f"geo/uav/{u.uav_id}/trail",
                             rr.GeoLineStrings.from_fields(radii=[rr.Radius.ui_points(2.0)]))

    def _start(self) -> None:
        """Step 0: every UAV on its airport, the prior maps."""
        for u in self.scenario.uavs:
            self._add_pose(0, self._tracks[u.uav_id], u.airport[0], u.airport[1], u.heading, Stage.SEARCH, None)
        m = self.scenario.search_map
        self._add_maps(0, m.tep, m.eu)

    def log_maps(self, step: int, tep: np.ndarray, eu: np.ndarray) -> None:
        """The TEP and EU maps at `step` (`log_step` logs them every `map_every` steps, `close`
        the last step's from its record)."""
        if self.rec is not None:
            self._add_maps(step, tep, eu)

    def _add_maps(self, step: int, tep: np.ndarray, eu: np.ndarray) -> None:
        for path, values in (("maps/tep", tep), ("maps/eu", eu)):
            rows = self._rows.get(path)
            if rows is None:
                rows = self._rows[path] = _MapRows()
            rows.add(step, values)
        self._last_map_step = step

    def _view_path(self, cells: np.ndarray, start: tuple[float, float]) -> np.ndarray:
        out = np.empty((len(cells) + 1, 2), dtype=np.float32)
        out[0] = start
        out[1:, 0] = cells[:, 0] + 0.5
        out[1:, 1] = self.ny - 0.5 - cells[:, 1]
        return out

    def _track_rows(self, track: _Track) -> dict[str, EntityRows]:
        """The rows of one UAV's entities, registered for flushing."""
        uid, base = track.uav_id, f"world/uav/{track.uav_id}"
        rows: dict[str, EntityRows] = {
            "pose": self._row(base, _pose_columns),
            "trail": self._row(f"{base}/trail", rr.LineStrips2D.columns, strips=STRIP_2D),
            "plan": self._row(f"{base}/plan", rr.LineStrips2D.columns, strips=STRIP_2D),
            "state": self._row(f"uav/{uid}/state", rr.AnyValues.columns),
            "j1": self._row(f"uav/{uid}/j1", rr.Scalars.columns),
            "range": self._row(f"uav/{uid}/range", rr.Scalars.columns),
            "success": self._row(f"uav/{uid}/success", rr.Scalars.columns),
        }
        if self.cells_to_lat_lon is not None:
            rows["geo"] = self._row(f"geo/uav/{uid}", rr.GeoPoints.columns)
            rows["geo_trail"] = self._row(f"geo/uav/{uid}/trail", rr.GeoLineStrings.columns, line_strings=GEO_STRING)
        return rows

    def _add_pose(self, step: int, track: _Track, x: int, y: int, heading: int, stage: Stage, decision) -> None:
        rows = track.rows
        here = (x + 0.5, self.ny - 0.5 - y)
        before = track.position
        first = before is None
        track.position = here
        rows["pose"].add(step, 1, positions=[here], vectors=[(0.9 * HEADING_DX[heading], -0.9 * HEADING_DY[heading])])
        colour = track.colour if stage is Stage.SEARCH else track.return_colour
        if first:
            rows["trail"].add(step, 0, strips=[], colors=[])
        else:
            rows["trail"].add(step, 1, strips=[np.array((before, here))], colors=[colour])
        before = here if first else before
        if decision is None:
            rows["plan"].add(step, 0, strips=[], labels=[], colors=[])
        else:
            plans = [self._view_path(decision.path, before)]
            labels = [f"J1 {decision.j1:.3f}"]
            runner_j1 = np.nan
            if decision.runner_up is not None and len(decision.runner_up):
                plans.append(self._view_path(decision.runner_up, before))
                labels.append(f"runner-up {decision.runner_up_j1:.3f}")
                runner_j1 = decision.runner_up_j1
            rows["plan"].add(step, len(plans), strips=plans, labels=labels, colors=PLAN_COLOURS[: len(plans)])
            rows["j1"].add(step, 2, scalars=[decision.j1, runner_j1])
        rows["state"].add(step, 1, x=[x + 1], y=[y + 1], heading=[heading], stage=[stage.value])
        if self.cells_to_lat_lon is not None:
            here_geo = self._lat_lon(x, y)
            rows["geo"].add(step, 1, positions=[here_geo])
            if first:
                rows["geo_trail"].add(step, 0, line_strings=[], colors=[])
            else:
                rows["geo_trail"].add(step, 1, line_strings=[np.array((track.geo, here_geo))], colors=[colour])
            track.geo = here_geo

    def _event(self, step: int, text: str, level: str = "INFO") -> None:
        self._row("events", rr.TextLog.columns).add(step, 1, text=[text], level=[level])

    def log_step(self, record: StepRecord) -> None:
        """Log one step of the search (call it with every record `ClosedSearch.run()` yields)."""
        if self.rec is None:
            return
        k = record.step
        for event in record.returns:
            conflict = (", no conflict-free way home: following the return table"
                        if getattr(event, "conflict", False) else "")
            self._event(event.step, f"UAV {event.uav_id} returns at step {event.step}: "
                                    f"{RETURN_REASON_TEXT.get(event.reason, event.reason.value)} "
                                    f"[{event.reason.value}], {event.return_steps} steps home{conflict}", "WARN")
        started_home = {e.uav_id for e in record.returns if e.return_steps == 0}
        for uid, (x, y, heading, stage) in record.poses.items():
            track = self._tracks[uid]
            if track.landed:
                continue
            if stage is Stage.LANDED:
                track.landed = True
                self._event(k, f"UAV {uid} landed at step {k}")
                if uid in started_home:
                    continue  # it was home already: no step flown
                stage = Stage.RETURN
            self._add_pose(k, track, x, y, heading, stage, record.decisions.get(uid))
            r = record.ranges[uid]
            track.rows["range"].add(k, 3, scalars=[r.range_left, r.return_cost, r.margin])
        self._add_sensing(k, record)
        self._add_success(k, record.expected_found)
        if k % self.map_every == 0:
            self._add_maps(k, record.tep, record.eu)
        self._last_record = record
        if time.monotonic() - self._last_flush >= self.flush_interval_s:
            self._flush()

    def _add_sensing(self, k: int, record: StepRecord) -> None:
        targets = self.scenario.targets
        for index, by in record.found:
            tx, ty = (int(v) for v in targets[index])
            who = f"UAV {by}" if by is not None else "a UAV"
            self._found.append((tx, ty, f"T{index + 1}"))
            self._event(k, f"target {index + 1} at ({tx + 1}, {ty + 1}) found by {who} at step {k}")
        if record.found:
            cells = np.array([(x, y) for x, y, _ in self._found], dtype=np.float64)
            self._row("world/found", rr.Points2D.columns).add(
                k, len(cells), positions=cell_to_view(cells[:, 0], cells[:, 1], self.ny),
                labels=[label for _, _, label in self._found])
            if self.cells_to_lat_lon is not None:
                self._row("geo/found", rr.GeoPoints.columns).add(
                    k, len(cells), positions=self._geo((x, y) for x, y, _ in self._found))
        reports = record.reports
        for path, kept, present in (("world/detections", self._detections, 1),
                                    ("world/false_alarms", self._false_alarms, 0)):
            new = reports[(reports[:, 2] == 1) & (reports[:, 3] == present)] if len(reports) else reports
            if len(new):
                kept.extend((int(x), int(y)) for x, y in new[:, :2])
                cells = np.array(kept, dtype=np.float64)
                self._row(path, rr.Points2D.columns).add(k, len(cells),
                                                         positions=cell_to_view(cells[:, 0], cells[:, 1], self.ny))

    def _add_success(self, k: int, expected: dict[int, float]) -> None:
        """Expected targets found so far, per UAV and for the team, and the team's PoS in %."""
        if not expected:
            return
        for uid, value in expected.items():
            if uid in self._tracks:
                self._tracks[uid].rows["success"].add(k, 1, scalars=[value])
        total = sum(expected.values())
        self._row("success/expected", rr.Scalars.columns).add(k, 1, scalars=[total])
        share = 100.0 * total / self._available if self._available > 0 else 0.0
        self._row("success/share", rr.Scalars.columns).add(k, 1, scalars=[share])

    def log_plan(self, plan: Plan) -> None:
        """The outcome: a summary event and the closed trajectories (static, under `plan/`)."""
        if self.rec is None:
            return
        step = self._last_record.step if self._last_record else 0
        self._event(step, f"search complete after {plan.steps} steps: {title_outcome(plan)}")
        for i, u in enumerate(plan.uavs):
            cells = np.array([(p.x, p.y) for p in u.trajectory], dtype=np.float64)
            pos = f", PoS {plan.success.share_of(u.uav_id):.1%}" if plan.success else ""
            self._static(f"plan/uav/{u.uav_id}", rr.LineStrips2D([cell_to_view(cells[:, 0], cells[:, 1], self.ny)],
                                                                 colors=uav_colour(i), radii=0.15,
                                                                 labels=f"UAV {u.uav_id}: eta {u.eta:.0%}{pos}"))
        self._flush()

    def log_segments(self, segments: list[Segment], theory: SearchTheory) -> None:
        """The search team's segments and the figures this plan gives them (static; entities in
        `gcs.recording.segments`): outlines in the grid view and on the map coloured by POA,
        labels with name, POA and POD, and every figure as values under `segments`."""
        if self.rec is None:
            return
        from gcs.recording.segments import ROOT, figure_values, outlines

        drawn = outlines(segments, theory, MAP_LUT)
        self._static(ROOT, rr.AnyValues(**figure_values(theory)))
        self._static(f"world/{ROOT}", rr.LineStrips2D(drawn.view, colors=drawn.colours, radii=0.1, draw_order=-3.0))
        if drawn.labels:
            self._static(f"world/{ROOT}/labels", rr.Points2D(
                cell_to_view(drawn.label_cells[:, 0], drawn.label_cells[:, 1], self.ny), radii=0.05,
                colors=(255, 255, 255), labels=drawn.labels, show_labels=True, draw_order=-2.0))
        if self.cells_to_lat_lon is not None and len(drawn.cells):
            geo = self._geo(drawn.cells.reshape(-1, 2)).reshape(-1, 2, 2)
            self._static(f"geo/{ROOT}", rr.GeoLineStrings(lat_lon=list(geo), colors=drawn.colours,
                                                          radii=rr.Radius.ui_points(2.0)))
        self._flush()

    def _flush(self) -> None:
        if self.rec is None:
            return
        self._sink_failed = flush_rows(self.rec, self._rows, "run", self._sink_failed)
        self._last_flush = time.monotonic()


def flush_rows(rec: rr.RecordingStream, rows: dict[str, EntityRows | _MapRows], what: str, warned: bool) -> bool:
    """Send the buffered rows and flush the stream; a viewer that went away must not stop the
    `what` (run, flight): a warning on stderr, once. Returns whether it has been given."""
    for path, buffered in rows.items():
        buffered.send(rec, path)
    try:
        rec.flush(timeout_sec=FLUSH_TIMEOUT_S)
    except RuntimeError as exc:
        if not warned:
            print(f"warning: Rerun: {exc}; the {what} goes on", file=sys.stderr, flush=True)
        return True
    return warned


def open_stream(rrd_path: Path | None, connect: str | None, name: str, blueprint,
                recording_id: str | None = None) -> rr.RecordingStream:
    """A recording stream to a .rrd file, a running viewer (checked first), or both; with
    `recording_id`, a further segment of that recording (a resumed flight's)."""
    if connect is not None:
        check_viewer(connect)
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
    sinks = []
    if rrd_path is not None:
        rrd_path.parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(str(rrd_path)))
    if connect is not None:
        sinks.append(rr.GrpcSink(connect))
    rec.set_sinks(*sinks, default_blueprint=blueprint)
    rec.send_recording_name(name)
    return rec


def check_viewer(url: str, timeout_s: float = 2.0) -> None:
    """A viewer (or Rerun gRPC server) must listen at `url`: else one clear UserError, not a hang."""
    parsed = urlparse(url)
    if not parsed.scheme.startswith("rerun") or parsed.hostname is None:
        raise UserError(f"not a Rerun viewer address: {url} (e.g. {DEFAULT_CONNECT})")
    try:
        socket.create_connection((parsed.hostname, parsed.port or 9876), timeout=timeout_s).close()
    except OSError:
        raise UserError(f"no Rerun viewer listening at {url}: start one with `rerun` first") from None


def default_blueprint(scenario: Scenario, geo: bool) -> rrb.Blueprint:
    """Map view (geo runs), the 2-D grid with TEP and trails, EU, and the per-UAV plots. A trail
    entity holds one segment per step: the views show all its past steps."""
    whole_past = rrb.VisibleTimeRanges(rrb.VisibleTimeRange(TIMELINE, start=rrb.TimeRangeBoundary.infinite(),
                                                            end=rrb.TimeRangeBoundary.cursor_relative()))
    trails = {f"/world/uav/{u.uav_id}/trail": whole_past for u in scenario.uavs}
    grid = rrb.Spatial2DView(name="TEP, trails and decisions", origin="/",
                             contents=["/maps/tep", "/world/**"], overrides=trails)
    eu = rrb.Spatial2DView(name="EU", origin="/", contents=["/maps/eu", "/world/no_fly", "/world/uav/**",
                                                            "- /world/uav/*/plan"], overrides=trails)
    outcome = rrb.Spatial2DView(name="closed plan", origin="/",
                                contents=["/maps/tep", "/world/no_fly", "/world/airports", "/world/found", "/plan/**",
                                          "/world/segments/**"])
    left = [rrb.Tabs(grid, eu, outcome)]
    if geo:
        left.insert(0, rrb.MapView(name="map", origin="/geo", overrides={
            f"/geo/uav/{u.uav_id}/trail": whole_past for u in scenario.uavs}))
    plots = []
    for u in scenario.uavs:
        plots.append(rrb.Vertical(
            rrb.TimeSeriesView(name=f"UAV {u.uav_id}: return trigger", origin=f"/uav/{u.uav_id}/range"),
            rrb.TimeSeriesView(name=f"UAV {u.uav_id}: J1", origin=f"/uav/{u.uav_id}/j1"),
            rrb.TimeSeriesView(name=f"UAV {u.uav_id}: expected targets found", origin=f"/uav/{u.uav_id}/success"),
            row_shares=[2, 1, 1], name=f"UAV {u.uav_id}"))
    success = rrb.Tabs(rrb.TimeSeriesView(name="probability of success (%)", origin="/success/share"),
                       rrb.TimeSeriesView(name="expected targets found", origin="/success/expected"))
    right = rrb.Vertical(rrb.Tabs(*plots, name="UAVs") if plots else rrb.Vertical(), success,
                         rrb.TextLogView(name="events", origin="/events"), row_shares=[3, 1, 1])
    return rrb.Blueprint(rrb.Horizontal(rrb.Vertical(*left), right, column_shares=[3, 2]),
                         rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed"),
                         rrb.TimePanel(state="collapsed"))


# -- reading a recording back ---------------------------------------------------------------------

@dataclass
class RecordingTables:
    """A recording read back: per entity path (without the leading '/'), its temporal rows sorted
    by step and its static components."""

    temporal: dict[str, pa.Table]
    static: dict[str, pa.Table]
    blueprints: int
    timeline: str = TIMELINE

    def column(self, entity: str, component: str) -> tuple[list, list]:
        table = self.temporal[entity]
        times = table.column(self.timeline)
        if pa.types.is_duration(times.type):  # flight_time: seconds as floats
            import pyarrow.compute as pc  # ~0.05 s to import: only when a recording is read back

            times = pc.divide(times.cast(pa.int64()).cast(pa.float64()), 1e9)
        return times.to_pylist(), table.column(component).to_pylist()


def read_recording(path: str | Path, timeline: str = TIMELINE) -> RecordingTables:
    """Every chunk of the first recording in a .rrd file, through Rerun's chunk reader; the
    temporal rows are those on `timeline` (`step` for plans, `flight_time` for flights)."""
    from rerun.chunk import RrdReader

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # files cut short have no footer: read them by scanning
        reader = RrdReader(str(path))
        blueprints = len(reader.blueprints())
        batches: dict[tuple[str, bool], list[pa.Table]] = defaultdict(list)
        for chunk in reader.stream():
            batch = chunk.to_record_batch()
            keep = [n for n in batch.schema.names if not n.startswith("rerun.controls")]
            table = pa.Table.from_batches([batch]).select(keep)
            batches[(chunk.entity_path.lstrip("/"), chunk.is_static)].append(table)
    temporal, static = {}, {}
    for (entity, is_static), tables in batches.items():
        table = pa.concat_tables(tables, promote_options="permissive")
        if is_static:
            static[entity] = table
        elif timeline in table.column_names:
            temporal[entity] = table.sort_by(timeline)
    return RecordingTables(temporal, static, blueprints, timeline)
