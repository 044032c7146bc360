"""The flight journal: what `gcs fly` keeps in the plan folder while vehicles fly, so that a
station that died (killed, crashed, its laptop closed) can take the flight over again with
`gcs fly --resume FOLDER` (`gcs.flight.resume`, docs/fly.md).

`flight-journal.jsonl` holds one JSON object a line, appended and flushed to the operating
system as each thing happens (a killed process loses nothing it wrote; the file is synced to
disk every second), so it is never rewritten and a line is either whole or, after a power
cut, a torn last line that the reader skips. Each line has a kind `k` and its flight second
`t` (seconds since the flight began, on the wall clock, across restarts):

- `start`: the flight's set-up (connections, options, recording file and id, plan hash), once;
- `resume`: a restarted station took over (its connections and recording segment);
- `event`: a line of the event log (`gcs.flight.watch.event_lines`, the recording's own text);
- `stage`, `takeoff`, `mission` (the search or a return leg verified on board), `range` (an
  operator's range order): what a restarted station must know of each vehicle;
- `reading`: every sensor reading (the belief map is the plan's belief with these folded in);
- `track`: a vehicle's position every fifth of a cell, with its place on the plan's track;
- `battery`: each battery sample the return trigger learns its consumption from;
- `end`: the flight ended with the station alive (nothing to resume).

`read_journal` folds the lines into a `JournalState`."""

from __future__ import annotations

import contextlib
import json
import math
import os
import time
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gcs.atomic import write_text_atomic
from gcs.errors import UserError
from gcs.flight.events import FlightEvent, MissionUploaded, ReadingReceived, Reattached, StageChanged, TookOff
from gcs.flight.watch import EventLine, event_lines, watching
from gcs.links.connection import LinkKind
from gcs.plans.plan_folder import FleetPlan
from gcs.telemetry.status import FINAL_STAGES, Detection, Stage

if TYPE_CHECKING:
    from gcs.flight.controller import FlightController, FlyOptions

__all__ = ["JOURNAL_FILE", "FlightJournal", "JournalError", "JournalStart", "JournalState", "VehicleRecord",
           "read_journal"]

JOURNAL_FILE = "flight-journal.jsonl"
VERSION = 1
SYNC_EVERY_S = 1.0


class JournalError(ValueError):
    """A journal that cannot be resumed from, and why."""


@dataclass(frozen=True)
class JournalStart:
    """How the flight was started."""

    wall_s: float
    utc: str
    plan_sha256: str
    connections: tuple[str, ...]
    sim: bool
    signed: bool
    online: bool
    options: dict
    rrd: str | None
    recording_id: str | None

    def to_dict(self) -> dict:
        return {"k": "start", "t": 0.0, "version": VERSION, "wall_s": self.wall_s, "utc": self.utc,
                "plan_sha256": self.plan_sha256, "connections": list(self.connections), "sim": self.sim,
                "signed": self.signed, "online": self.online, "options": self.options, "rrd": self.rrd,
                "recording_id": self.recording_id}

    @classmethod
    def from_dict(cls, d: dict) -> JournalStart:
        return cls(float(d["wall_s"]), str(d["utc"]), str(d["plan_sha256"]), tuple(map(str, d["connections"])),
                   bool(d["sim"]), bool(d["signed"]), bool(d["online"]), dict(d["options"]), d.get("rrd"),
                   d.get("recording_id"))


@dataclass
class VehicleRecord:
    """What the journal says of one vehicle, as of its last line."""

    uav_id: int
    stage: Stage = Stage.CONNECTING
    stage_before_loss: Stage | None = None
    return_reason: str | None = None
    airborne_seen: bool = False
    mission: str | None = None  # "search" or "return": the list verified on board
    leg: list[tuple[float, float]] = field(default_factory=list)
    track_index: int = 0
    odometer_m: float = 0.0
    track: list[tuple[float, float]] = field(default_factory=list)
    track_t: list[float] = field(default_factory=list)  # flight seconds of each track point
    battery_samples: list[tuple[float, float, float]] = field(default_factory=list)
    battery_t: list[float] = field(default_factory=list)
    readings: list[Detection] = field(default_factory=list)
    reading_component: int | None = None
    operator_range: float | None = None

    @property
    def flying_stage(self) -> Stage:
        """The stage it was in, seeing through a lost link."""
        return (self.stage_before_loss or Stage.SEARCH) if self.stage is Stage.LOST else self.stage


@dataclass
class JournalState:
    """A journal read back: the start, each vehicle, the event log, and whether it ended."""

    path: Path
    start: JournalStart
    vehicles: dict[int, VehicleRecord]
    events: list[tuple[float, EventLine]]
    segments: list[str]
    last_t: float
    ended: dict | None = None
    torn_lines: int = 0
    resumed_t: list[float] = field(default_factory=list)  # when each restarted station took over
    udp_source_ports: dict[str, int] = field(default_factory=dict)  # udpout link -> the local port it sent from

    @property
    def readings(self) -> list[tuple[int, Detection]]:
        """Every reading, per vehicle in the order it arrived."""
        return [(uid, d) for uid, v in sorted(self.vehicles.items()) for d in v.readings]


def read_journal(folder: str | Path) -> JournalState:
    """Fold `folder`'s journal; JournalError when there is none or it is not one."""
    path = Path(folder) / JOURNAL_FILE
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise JournalError(f"no flight journal ({JOURNAL_FILE}) in {folder}: it was never flown by this version of "
                           "gcs fly, or never started") from None
    except OSError as exc:
        raise JournalError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    lines = raw.split(b"\n")
    records, torn = [], 0
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            records.append(json.loads(line))
        except ValueError:
            if i < len(lines) - 1:  # a whole line (it ends in a newline)
                raise JournalError(f"{path}: line {i + 1} is not JSON (the journal is damaged)") from None
            torn += 1  # the last line, cut by a power loss
    if not records or records[0].get("k") != "start":
        raise JournalError(f"{path}: it does not begin with the flight's start")
    try:
        return _fold(path, records, torn)
    except (KeyError, TypeError, ValueError) as exc:
        raise JournalError(f"{path}: not a flight journal ({type(exc).__name__}: {exc})") from None


def check_no_flight_in_progress(folder: Path) -> None:
    """Refuse to fly, upload or plan the next sortie over a flight whose station died while its
    vehicles flew (UserError naming `gcs fly --resume`)."""
    if not (folder / JOURNAL_FILE).exists():
        return
    try:
        state = read_journal(folder)
    except JournalError as exc:
        raise UserError(f"{folder}: cannot tell whether a flight is in progress there ({exc}); if nothing is flying, "
                        f"delete {folder / JOURNAL_FILE}") from None
    if state.ended is None and not state.start.sim:
        raise UserError(f"{folder}: the flight started {state.start.utc} never ended (its station stopped while the "
                        f"vehicles flew?): take it over with gcs fly --resume {folder}, or, if nothing is flying, "
                        f"delete {folder / JOURNAL_FILE}")


def _fold(path: Path, records: list[dict], torn: int) -> JournalState:
    head = records[0]
    if head.get("version") != VERSION:
        raise JournalError(f"{path}: journal version {head.get('version')}, this gcs reads {VERSION}")
    start = JournalStart.from_dict(head)
    vehicles: dict[int, VehicleRecord] = {}
    state = JournalState(path, start, vehicles, [], [start.rrd] if start.rrd else [], 0.0, torn_lines=torn)
    for r in records[1:]:
        kind, t = r["k"], float(r["t"])
        state.last_t = max(state.last_t, t)
        v = vehicles.setdefault(int(r["uav"]), VehicleRecord(int(r["uav"]))) if r.get("uav") is not None else None
        if kind == "event":
            state.events.append((t, EventLine(r.get("uav"), str(r["text"]), str(r["level"]))))
        elif kind == "stage":
            after = Stage(r["stage"])
            if after is Stage.LOST:
                v.stage_before_loss = Stage(r["before"])
            elif v.stage is not Stage.LOST:
                v.stage_before_loss = None
            v.stage = after
            v.return_reason = r.get("return_reason")
        elif kind == "takeoff":
            v.airborne_seen = True
        elif kind == "mission":
            v.mission = str(r["mission"])
            v.leg = [(float(a), float(b)) for a, b in r.get("leg", [])]
        elif kind == "reading":
            v.readings.append(Detection(int(r["index"]), float(r["lat"]), float(r["lon"]), bool(r["hit"]),
                                        float(r["time_s"])))
            if r.get("comp") is not None:
                v.reading_component = int(r["comp"])
        elif kind == "track":
            v.track.append((float(r["lat"]), float(r["lon"])))
            v.track_t.append(t)
            v.track_index = int(r["track_index"])
            v.odometer_m = float(r["odometer_m"])
        elif kind == "battery":
            v.battery_samples.append((float(r["time_boot_s"]), float(r["pct"]), float(r["steps"])))
            v.battery_t.append(t)
        elif kind == "range":
            if "range_m" in r:  # journals before ranges were metres kept steps: not resumed
                v.operator_range = float(r["range_m"])
        elif kind == "resume":
            state.resumed_t.append(t)
            if r.get("rrd"):
                state.segments.append(str(r["rrd"]))
            state.ended = None
        elif kind == "links":
            state.udp_source_ports.update({str(k): int(p) for k, p in r["udp_source_ports"].items()})
        elif kind == "end":
            state.ended = r
        else:
            raise ValueError(f"unknown line kind {kind!r}")
    return state


class FlightJournal:
    """Writes a flight's journal while it flies (`attach`, a watcher of `fly_async`); `begin`
    starts the journal of a new flight, `reopen` continues one after a restart."""

    def __init__(self, path: Path, plan: FleetPlan, first: dict, *, recorder=None, poll_s: float = 0.1) -> None:
        self.path = path
        self.plan = plan
        self.first = first
        self.recorder = recorder
        self.poll_s = poll_s
        self.min_move_m = plan.cell_size_m / 5.0
        self._fd: int | None = None
        self._last_sync = 0.0
        self._dirty = False
        self._t0 = time.monotonic()
        self._track: dict[int, tuple[float, float]] = {}
        self._battery: dict[int, float] = {}
        self._range: dict[int, float] = {}
        self._controller: FlightController | None = None

    @classmethod
    def begin(cls, plan: FleetPlan, start: JournalStart, recorder=None) -> FlightJournal:
        """The journal of a new flight in `plan`'s folder (the start line is written once
        attached, with the flight's clock and `recorder`'s recording id; an earlier flight's
        journal is replaced then)."""
        return cls(Path(plan.folder) / JOURNAL_FILE, plan, start.to_dict(), recorder=recorder)

    @classmethod
    def reopen(cls, plan: FleetPlan, state: JournalState, connections: list[str], rrd: str | None) -> FlightJournal:
        """Continue `state`'s journal after a restart; the vehicles' last known places carry on."""
        journal = cls(state.path, plan, {"k": "resume", "t": round(time.time() - state.start.wall_s, 6),
                                          "wall_s": time.time(), "utc": _utc_now(), "connections": connections,
                                          "rrd": rrd})
        for uid, v in state.vehicles.items():
            if v.track:
                journal._track[uid] = v.track[-1]
            if v.battery_samples:
                journal._battery[uid] = v.battery_samples[-1][0]
            if v.operator_range is not None:
                journal._range[uid] = v.operator_range
        return journal

    # ---- writing -------------------------------------------------------------------------

    def _open(self) -> None:
        """The start line (a new journal, replacing an earlier flight's) or the resume line;
        UserError when the folder takes no journal: nothing has been sent to a vehicle yet."""
        try:
            if self.first["k"] == "start":
                self.first["wall_s"] = time.time() - (time.monotonic() - self._t0)
                if self.recorder is not None:
                    self.first["recording_id"] = self.recorder.recording_id
                write_text_atomic(self.path, json.dumps(self.first) + "\n")
            self._fd = os.open(self.path, os.O_RDWR | os.O_APPEND)
            if self.first["k"] != "start":
                self._drop_torn_line()
                self._write_line(self.first)
            self._sync()
        except OSError as exc:
            raise UserError(f"cannot write the flight journal {self.path} ({exc.strerror or exc}): without it a "
                            "restarted station could not take the flight over") from None

    def _drop_torn_line(self) -> None:
        """Cut a last line torn by a power loss (unreadable, and the next line must not join it)."""
        size = os.fstat(self._fd).st_size
        tail = os.pread(self._fd, min(size, 65536), max(0, size - 65536))
        if tail and not tail.endswith(b"\n"):
            os.ftruncate(self._fd, size - len(tail) + tail.rfind(b"\n") + 1)

    def write(self, kind: str, uav: int | None = None, *, at: float | None = None, **fields) -> None:
        """Append one line, at once (the operating system keeps it if this process dies);
        `at`: the monotonic time it happened (default now)."""
        if self._fd is None:
            return
        record = {"k": kind, "t": round((time.monotonic() if at is None else at) - self._t0, 6)}
        if uav is not None:
            record["uav"] = uav
        record.update(fields)
        self._write_line(record)

    def _write_line(self, record: dict) -> None:
        data = (json.dumps(record, separators=(",", ":")) + "\n").encode()
        try:
            os.write(self._fd, data)
        except OSError as exc:
            self._failed(exc)
            return
        self._dirty = True

    def _sync(self) -> None:
        if self._fd is not None and self._dirty:
            try:
                os.fsync(self._fd)
            except OSError as exc:
                self._failed(exc)
                return
            self._dirty = False
        self._last_sync = time.monotonic()

    def _failed(self, exc: OSError) -> None:
        """A full or failing disk: the flight goes on without its journal, and the operator knows."""
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
            self._fd = None
        if self._controller is not None:
            self._controller.say(None, f"error: the flight journal {self.path} can no longer be written "
                                       f"({exc.strerror or exc}): a restarted station could not take this flight over")

    def close(self) -> None:
        if self._fd is None:
            return
        self._sync()
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    # ---- watching ------------------------------------------------------------------------

    def on_event(self, event: FlightEvent, now: float) -> None:
        c = self._controller
        for line in event_lines(event, c.status, self.plan):
            self.write("event", line.uav_id, at=now, text=line.text, level=line.level)
        if isinstance(event, StageChanged):
            st = c.status[event.uav_id]
            self.write("stage", event.uav_id, stage=event.after.value, before=event.before.value, note=event.note,
                       return_reason=st.return_reason)
        elif isinstance(event, Reattached):
            st = c.status[event.uav_id]
            self.write("stage", event.uav_id, stage=event.stage.value, before=event.stage.value, note="reattached",
                       return_reason=st.return_reason)
        elif isinstance(event, TookOff):
            self.write("takeoff", event.uav_id, alt_m=round(event.alt_m, 1))
        elif isinstance(event, MissionUploaded):
            self.write("mission", event.uav_id, mission=event.kind, leg=[list(p) for p in event.leg])
        elif isinstance(event, ReadingReceived):
            d = event.detection
            self.write("reading", event.uav_id, index=d.index, lat=d.lat_deg, lon=d.lon_deg, hit=int(d.hit),
                       time_s=d.time_s, comp=c.vehicles[event.uav_id].reading_component)

    def sample(self, controller: FlightController) -> None:
        """Track points, new battery samples and operator ranges since the last pass; a sync
        to disk every `SYNC_EVERY_S`."""
        for uid, st in controller.status.items():
            if st.airborne_seen and st.has_position:
                here, last = (st.lat_deg, st.lon_deg), self._track.get(uid)
                if last is None or math.hypot(*np.subtract(self.plan.local_m(*here), self.plan.local_m(*last))) \
                        >= self.min_move_m:
                    self._track[uid] = here
                    self.write("track", uid, lat=here[0], lon=here[1], track_index=st.track_index,
                               odometer_m=round(st.odometer_m, 1))
            newest = self._battery.get(uid, -math.inf)
            for boot_s, pct, steps in list(st.battery_samples):
                if boot_s > newest:
                    self.write("battery", uid, time_boot_s=boot_s, pct=pct, steps=steps)
                    self._battery[uid] = newest = boot_s
            range_m = controller.vehicles[uid].operator_range
            if range_m is not None and self._range.get(uid) != range_m:
                self._range[uid] = range_m
                self.write("range", uid, range_m=round(range_m, 3))
        if time.monotonic() - self._last_sync >= SYNC_EVERY_S:
            self._sync()

    @contextlib.asynccontextmanager
    async def attach(self, controller: FlightController) -> AsyncIterator[FlightJournal]:
        """Journal the flight while the block runs; when it ends, however (the station alive to
        see it), the `end` line: there is nothing to resume."""
        self._controller = controller
        self._t0 = controller.t0
        self._open()
        self.write("links", udp_source_ports={link.name: link.local_address[1] for link in controller.links
                                              if link.connection.kind is LinkKind.UDP_OUT})
        async with watching(controller, self.on_event, lambda last: self.sample(controller), self.poll_s,
                            "flight-journal", on_end=lambda failure: self._end(controller, failure)):
            yield self

    def _end(self, controller: FlightController, failure: BaseException | None) -> None:
        """The `end` line (the station alive to see the flight end: nothing to resume)."""
        try:
            open_ends = sorted(uid for uid, st in controller.status.items() if st.stage not in FINAL_STAGES)
            self.write("end", landed=[uid for uid, st in sorted(controller.status.items()) if st.stage is Stage.LANDED],
                       open=open_ends, interrupted=controller.interrupted,
                       error=None if failure is None else f"{type(failure).__name__}: {failure}")
        finally:
            self.close()


def _utc_now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


#: the `FlyOptions` fields a flight's journal keeps: a resumed flight flies with them unless given again
JOURNALED_OPTIONS = ("reserve_pct", "link_timeout_s", "lost_giveup_s", "arm_timeout_s", "ready_timeout_s", "fence",
                     "check_home")


def journal_options(options: FlyOptions) -> dict:
    """The knobs of `options` a flight's journal keeps (`JOURNALED_OPTIONS`)."""
    return {name: getattr(options, name) for name in JOURNALED_OPTIONS}


def new_start(plan_sha256: str, connections: list[str], *, sim: bool, signed: bool, online: bool, options: dict,
              rrd: str | None, recording_id: str | None) -> JournalStart:
    """The start line of a flight beginning now."""
    return JournalStart(time.time(), _utc_now(), plan_sha256, tuple(connections), sim, signed, online, options, rrd,
                        recording_id)
