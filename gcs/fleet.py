"""The fleet as the ground station sees it: what each UAV is to fly (`FleetPlan`, read from a
`gcs plan --area` folder) and what each vehicle reports (`VehicleStatus`, updated from MAVLink
messages by pure methods; the async code only feeds them).

UAV ids are matched to vehicles by MAVLink system id: the plan's UAV N is the vehicle whose
HEARTBEAT comes from system id N, on whichever connection it is heard."""

from __future__ import annotations

import json
import math
from collections import deque
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import numpy as np

from gcs.autopilots import Autopilot
from gcs.errors import UserError
from gcs.links import mavlink
from gcs.mission_transfer import MissionType, WireItem
from gcs.missions.items import (
    AltitudeReference,
    LandingApproach,
    MissionItem,
    UavMission,
    Vehicle,
    landing_items,
    mission_items,
    waypoint_items,
)
from planner.georef import Grid, LocalFrame
from planner.motion import OrientationConstraint, constraint_by_name
from planner.return_exact import UNREACHABLE, return_table

__all__ = ["FleetPlan", "Stage", "UavTask", "VehicleStatus", "load_plan_dir"]

MAVMessage = mavlink.MAVLink_message


@dataclass(frozen=True)
class Pose:
    """A trajectory step: 0-based cell, heading 0..7, planner stage, cell centre lat/lon."""

    step: int
    x: int
    y: int
    heading: int
    stage: str
    lat_deg: float
    lon_deg: float


@dataclass
class UavTask:
    """One UAV's part of the plan."""

    uav_id: int
    name: str
    vehicle: Vehicle
    altitude_m: float
    airport_lat_lon: tuple[float, float]
    airport_cell: tuple[int, int]
    start_heading: int
    range_steps: int
    waypoints: list[tuple[float, float]]
    trajectory: list[Pose]
    fence: list[tuple[bool, list[tuple[float, float]]]] = field(default_factory=list)
    rally: list[tuple[float, float, float]] = field(default_factory=list)
    altitude_reference: AltitudeReference = AltitudeReference.HOME
    elevation_m: float | None = None
    approach: LandingApproach | None = None

    @property
    def mission(self) -> UavMission:
        lat, lon = self.airport_lat_lon
        return UavMission(self.uav_id, self.name, self.vehicle, lat, lon, self.altitude_m, list(self.waypoints),
                          self.elevation_m or 0.0, self.altitude_reference, self.approach)

    def mission_wire(self, autopilot: Autopilot) -> list[WireItem]:
        """The mission as wire items; ArduPilot gets the airport as its home placeholder (item 0)."""
        return self._wire(autopilot, mission_items(self.mission))

    def return_wire(self, autopilot: Autopilot, leg: list[tuple[float, float]]) -> list[WireItem]:
        """A mission that flies `leg` (lat, lon) at the UAV's altitude and lands as the plan does."""
        mission = self.mission
        return self._wire(autopilot, waypoint_items(mission, leg) + landing_items(mission))

    def _wire(self, autopilot: Autopilot, items: list[MissionItem]) -> list[WireItem]:
        wire = [autopilot.adapt_item(WireItem.at(0, it.frame, it.command, it.lat_deg, it.lon_deg, it.alt_m, it.params))
                for it in items]
        if autopilot.home_item(MissionType.MISSION):
            lat, lon = self.airport_lat_lon
            wire.insert(0, WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, lat, lon,
                                       self.elevation_m or 0.0))
        return wire

    def fence_wire(self) -> list[WireItem]:
        """Polygon fence vertices (param1 = vertex count), MAV_MISSION_TYPE_FENCE."""
        out = []
        for inclusion, ring in self.fence:
            cmd = (mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION if inclusion
                   else mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
            out += [WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, cmd, lat, lon, 0.0, (len(ring), 0, 0, 0),
                                MissionType.FENCE)
                    for lat, lon in ring]
        return out

    def rally_wire(self) -> list[WireItem]:
        return [WireItem.at(0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_RALLY_POINT, lat, lon, alt,
                            mission_type=MissionType.RALLY) for lat, lon, alt in self.rally]


@dataclass
class FleetPlan:
    """A plan folder: the UAVs' tasks, the grid on the Earth, the OC and the true targets."""

    folder: Path
    uavs: dict[int, UavTask]
    frame: LocalFrame
    grid: Grid
    no_fly: np.ndarray
    oc: OrientationConstraint
    targets: list[tuple[int, int]]
    raw: dict
    _tables: dict[int, np.ndarray] = field(default_factory=dict)

    @property
    def cell_size_m(self) -> float:
        return self.grid.cell_size_m

    def cell_of(self, lat_deg: float, lon_deg: float) -> tuple[int, int] | None:
        east, north = self.frame.geodetic2local(lat_deg, lon_deg)
        try:
            return self.grid.cell_of(float(east), float(north))
        except ValueError:
            return None

    def local_m(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        east, north = self.frame.geodetic2local(lat_deg, lon_deg)
        return float(east), float(north)

    def cell_lat_lon(self, x: int, y: int) -> tuple[float, float]:
        lat, lon = self.frame.local2geodetic(*self.grid.centre_m(x, y))
        return float(lat), float(lon)

    def return_table(self, uav_id: int) -> np.ndarray:
        """Steps home from every (heading, x, y) to this UAV's airport under the plan's OC
        (`planner.return_exact.return_table`), computed once."""
        if uav_id not in self._tables:
            self._tables[uav_id] = return_table(self.no_fly, self.uavs[uav_id].airport_cell, self.oc)
        return self._tables[uav_id]

    def steps_home(self, uav_id: int, pose: tuple[int, int, int]) -> float:
        x, y, h = pose
        value = int(self.return_table(uav_id)[h, x, y])
        return math.inf if value >= UNREACHABLE else float(value)


def _fail(folder: Path, what: str) -> UserError:
    return UserError(f"{folder}: {what}")


def load_plan_dir(folder: str | Path) -> FleetPlan:
    """Read a `gcs plan --area` output folder; UserError with one line on anything missing."""
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"plan folder {folder} does not exist "
                        f"(make one with: gcs plan --area AREA.geojson --out {folder})")
    path = folder / "plan.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise _fail(folder, "no plan.json in it (make one with gcs plan --area)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _fail(folder, f"plan.json is not readable JSON ({exc})") from None
    _check_schema(folder, data)
    try:
        grid_data = data["grid"]
        georef = grid_data.get("georef")
        if georef is None:
            raise _fail(folder, "plan.json has no geo-reference: plan over an area (gcs plan --area) to fly it")
        frame = LocalFrame(float(georef["origin"]["lat"]), float(georef["origin"]["lon"]))
        grid = Grid(float(georef["east0_m"]), float(georef["north0_m"]), float(georef["cell_size_m"]),
                    int(grid_data["nx"]), int(grid_data["ny"]))
        no_fly = np.zeros((grid.nx, grid.ny), dtype=bool)
        for x, y in grid_data["no_fly"]:
            no_fly[x - 1, y - 1] = True
        oc = constraint_by_name(data["settings"]["oc"])
        uavs = {}
        for u in data["uavs"]:
            uid = int(u["id"])
            if "waypoints" not in u:
                raise _fail(folder, f"UAV {uid} has no mission waypoints in plan.json")
            trajectory = [Pose(int(p["step"]), int(p["x"]) - 1, int(p["y"]) - 1, int(p["heading"]), str(p["stage"]),
                               float(p["lat"]), float(p["lon"])) for p in u["trajectory"]]
            task = UavTask(uid, str(u.get("name", f"UAV{uid}")), Vehicle(u.get("vehicle", "copter")),
                           float(u["altitude_m"]), tuple(u["airport_lat_lon"]),
                           (int(u["airport"][0]) - 1, int(u["airport"][1]) - 1), int(u["start_heading"]),
                           int(u["range"]), [tuple(w) for w in u["waypoints"]], trajectory,
                           altitude_reference=AltitudeReference(u.get("altitude_reference", "home")),
                           elevation_m=u.get("elevation_m"), approach=_approach(u.get("approach")))
            _read_qgc_plan(folder / f"uav{uid}.plan", task)
            uavs[uid] = task
        targets = [(int(t["x"]) - 1, int(t["y"]) - 1) for t in data.get("targets", [])]
    except UserError:
        raise
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise _fail(folder, f"plan.json is not a plan made by gcs plan --area ({type(exc).__name__}: {exc})") from None
    if not uavs:
        raise _fail(folder, "plan.json has no UAVs")
    return FleetPlan(folder, uavs, frame, grid, no_fly, oc, targets, data)


def _check_schema(folder: Path, data: object) -> None:
    """plan.json against gcs/schemas/plan.schema.json: UserError naming the first field that
    is missing or wrong (where it is, and what was expected)."""
    import jsonschema

    from gcs.plan_file import plan_schema

    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(plan_schema()).iter_errors(data))
    if error is not None:
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path).lstrip(".")
        raise _fail(folder, f"plan.json does not follow the plan schema: {where or 'the top level'}: {error.message}")


def _approach(data: dict | None) -> LandingApproach | None:
    if data is None:
        return None
    (lat, lon), alt = data["lat_lon"], data["alt_m"]
    return LandingApproach(float(lat), float(lon), float(alt))


def _read_qgc_plan(path: Path, task: UavTask) -> None:
    """Geofence polygons and rally points from the UAV's QGroundControl .plan, when present."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    for poly in doc.get("geoFence", {}).get("polygons", []):
        task.fence.append((bool(poly["inclusion"]), [(float(a), float(b)) for a, b in poly["polygon"]]))
    for lat, lon, alt in doc.get("rallyPoints", {}).get("points", []):
        task.rally.append((float(lat), float(lon), float(alt)))


# ---- live state ------------------------------------------------------------------------


class Stage(str, Enum):
    CONNECTING = "connecting"
    PREPARING = "preparing"
    UPLOADING = "uploading"
    ARMING = "arming"
    SEARCH = "search"
    RETURN = "return"
    RTL = "rtl"
    LANDED = "landed"
    LOST = "lost"
    FAILED = "failed"


FINAL_STAGES = frozenset({Stage.LANDED, Stage.FAILED})


@dataclass(frozen=True, slots=True)
class Detection:
    """One CAMERA_IMAGE_CAPTURED reading: the observed cell's centre and whether it reported."""

    index: int
    lat_deg: float
    lon_deg: float
    hit: bool
    time_s: float


@dataclass
class VehicleStatus:
    """The last known state of one vehicle, from its telemetry (times in vehicle seconds
    where the message carries them, else the GCS clock)."""

    uav_id: int
    stage: Stage = Stage.CONNECTING
    autopilot: Autopilot | None = None
    mav_type: int | None = None
    custom_mode: int | None = None
    mode_name: str = "-"
    armed: bool = False
    lat_deg: float | None = None
    lon_deg: float | None = None
    rel_alt_m: float = 0.0
    heading_deg: float = 0.0
    ground_speed_m_s: float = 0.0
    time_boot_s: float = 0.0
    battery_pct: float | None = None
    voltage_v: float | None = None
    time_remaining_s: float | None = None
    landed_state: int = mavlink.MAV_LANDED_STATE_UNDEFINED
    mission_seq: int = 0
    mission_total: int = 0
    last_heard_s: float | None = None
    airborne_seen: bool = False
    battery_samples: deque = field(default_factory=lambda: deque(maxlen=120))
    detections: list[Detection] = field(default_factory=list)
    detection_indices: set = field(default_factory=set)
    last_text: str = ""
    note: str = ""
    track_index: int = 0
    range_left: float = math.inf
    margin: float = math.inf
    return_reason: str | None = None
    battery_at_landing: float | None = None
    gps_fix_type: int | None = None
    satellites: int | None = None
    ekf_flags: int | None = None
    home: tuple[float, float, float] | None = None  # lat, lon, altitude AMSL (HOME_POSITION)
    origin_seen: bool = False
    prearm_ok: bool | None = None
    consumed_mah: float | None = None
    odometer_m: float = 0.0
    steps_flown: float = 0.0  # planner steps along the plan, kept up by the flight controller
    unsupported_streams: set = field(default_factory=set)
    text_chunks: dict = field(default_factory=dict)  # STATUSTEXT id -> {chunk_seq: text}

    @property
    def ekf_position_ok(self) -> bool | None:
        """ArduPilot's estimator uses an absolute horizontal position (EKF_STATUS_REPORT has
        POS_HORIZ_ABS and not CONST_POS_MODE); None until reported."""
        if self.ekf_flags is None:
            return None
        return bool(self.ekf_flags & mavlink.EKF_POS_HORIZ_ABS) and not self.ekf_flags & mavlink.EKF_CONST_POS_MODE

    def waiting_for(self) -> list[str]:
        """What the vehicle still lacks before it can be armed and flown (empty when ready). The
        signals are the ones measured on the autopilots (docs/autopilots.md): a 3-D GPS fix, the
        estimator's position (ArduPilot's EKF flags; PX4's pre-arm bit in SYS_STATUS health, which
        covers it) and a home position; a signal the vehicle does not send (it refused that
        stream) is not waited for."""
        missing = []
        if self.gps_fix_type is None:
            if mavlink.MAVLINK_MSG_ID_GPS_RAW_INT not in self.unsupported_streams:
                missing.append("GPS")
        elif self.gps_fix_type < mavlink.GPS_FIX_TYPE_3D_FIX:
            missing.append("a 3-D GPS fix")
        signals = self.autopilot.readiness_signals() if self.autopilot else ()
        if "ekf" in signals and self.ekf_position_ok is not True \
                and mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT not in self.unsupported_streams:
            missing.append("the EKF's position estimate")
        if "prearm" in signals and not self.prearm_ok:
            missing.append(f"{self.autopilot.value.upper()}'s pre-arm checks")
        if self.home is None and mavlink.MAVLINK_MSG_ID_HOME_POSITION not in self.unsupported_streams:
            missing.append("a home position")
        if not self.has_position:
            missing.append("a position")
        return missing

    @property
    def has_position(self) -> bool:
        """Real autopilots report 0, 0 until their estimator has a GPS origin."""
        return self.lat_deg is not None and not (self.lat_deg == 0.0 and self.lon_deg == 0.0)

    @property
    def fixed_wing(self) -> bool:
        return self.mav_type == mavlink.MAV_TYPE_FIXED_WING

    @property
    def airborne(self) -> bool:
        if self.landed_state in (mavlink.MAV_LANDED_STATE_IN_AIR, mavlink.MAV_LANDED_STATE_TAKEOFF,
                                 mavlink.MAV_LANDED_STATE_LANDING):
            return True
        return self.armed and self.rel_alt_m > 1.0

    def update(self, msg: MAVMessage, now_s: float) -> None:
        """Fold one message from this vehicle into the state."""
        kind = msg.get_type()
        self.last_heard_s = now_s
        if kind == "HEARTBEAT":
            if msg.type == mavlink.MAV_TYPE_GCS:
                return
            self.autopilot = Autopilot.from_heartbeat(msg.autopilot)
            self.mav_type = msg.type
            self.custom_mode = msg.custom_mode
            self.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            self.mode_name = self.autopilot.mode_name(msg.type, msg.custom_mode)
        elif kind == "GLOBAL_POSITION_INT":
            lat, lon = msg.lat / 1e7, msg.lon / 1e7
            if self.airborne and self.has_position:
                self.odometer_m += _ground_distance_m(self.lat_deg, self.lon_deg, lat, lon)
            self.lat_deg, self.lon_deg = lat, lon
            self.rel_alt_m = msg.relative_alt / 1000.0
            self.time_boot_s = msg.time_boot_ms / 1000.0
            if msg.hdg != 65535:
                self.heading_deg = msg.hdg / 100.0
            self.ground_speed_m_s = math.hypot(msg.vx, msg.vy) / 100.0
        elif kind == "BATTERY_STATUS":
            if msg.battery_remaining >= 0:
                self.battery_pct = float(msg.battery_remaining)
            if msg.current_consumed >= 0:
                self.consumed_mah = float(msg.current_consumed)
            if msg.time_remaining > 0:
                self.time_remaining_s = float(msg.time_remaining)
            cells = [v for v in msg.voltages if v != 65535]
            if cells:
                self.voltage_v = sum(cells) / 1000.0
            self._sample_battery()
        elif kind == "SYS_STATUS":
            if msg.battery_remaining >= 0 and self.battery_pct is None:
                self.battery_pct = float(msg.battery_remaining)
            prearm = mavlink.MAV_SYS_STATUS_PREARM_CHECK
            if (self.autopilot and self.autopilot.prearm_bit_always_reported()) \
                    or msg.onboard_control_sensors_present & prearm:
                self.prearm_ok = bool(msg.onboard_control_sensors_health & prearm)
            if msg.voltage_battery not in (0, 65535):
                self.voltage_v = msg.voltage_battery / 1000.0
        elif kind == "GPS_RAW_INT":
            self.gps_fix_type = msg.fix_type
            self.satellites = msg.satellites_visible if msg.satellites_visible != 255 else None
        elif kind == "EKF_STATUS_REPORT":
            self.ekf_flags = msg.flags
        elif kind == "HOME_POSITION":
            self.home = (msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0)
        elif kind == "GPS_GLOBAL_ORIGIN":
            self.origin_seen = True
        elif kind == "EXTENDED_SYS_STATE":
            self.landed_state = msg.landed_state
        elif kind == "MISSION_CURRENT":
            self.mission_seq = msg.seq
            self.mission_total = getattr(msg, "total", 0) or 0
        elif kind == "STATUSTEXT":
            self._status_text(msg)
        elif kind == "CAMERA_IMAGE_CAPTURED":
            self._detection(msg)
        if self.airborne:
            self.airborne_seen = True

    def _status_text(self, msg) -> None:
        """The autopilot's latest words. A text longer than one message comes in chunks sharing a
        non-zero `id` (PX4 splits texts over 50 characters); a chunk shorter than 50 is the last.
        The joined text shows as it grows, so a lost last chunk still leaves the start of it; PX4's
        trailing tab is dropped."""
        text = (msg.text if isinstance(msg.text, str) else msg.text.decode(errors="replace")).rstrip("\x00")
        if not getattr(msg, "id", 0):
            self.last_text = text.rstrip()
            return
        chunks = self.text_chunks.setdefault(msg.id, {})
        chunks[msg.chunk_seq] = text
        self.last_text = "".join(chunks[i] for i in sorted(chunks)).rstrip()
        ends = [seq for seq, part in chunks.items() if len(part) < 50]
        if ends and len(chunks) == min(ends) + 1:
            del self.text_chunks[msg.id]
        while len(self.text_chunks) > 4:  # ids whose last chunk never came
            del self.text_chunks[next(iter(self.text_chunks))]

    def _sample_battery(self) -> None:
        if self.battery_pct is None or not self.airborne:
            return
        if self.battery_samples and self.battery_samples[-1][0] >= self.time_boot_s:
            return
        self.battery_samples.append((self.time_boot_s, self.battery_pct, self.steps_flown))

    def _detection(self, msg: MAVMessage) -> None:
        if msg.image_index in self.detection_indices:
            return
        url = msg.file_url.rstrip("\x00") if isinstance(msg.file_url, str) else msg.file_url.decode(errors="replace")
        query = parse_qs(urlsplit(url).query)
        hit = query.get("hit", ["0"])[0] == "1"
        self.detection_indices.add(msg.image_index)
        self.detections.append(Detection(msg.image_index, msg.lat / 1e7, msg.lon / 1e7, hit, msg.time_boot_ms / 1000))

    @property
    def lost_detections(self) -> list[int]:
        """Image indices missing below the highest seen (lost datagrams to re-request)."""
        if not self.detection_indices:
            return []
        return [i for i in range(max(self.detection_indices)) if i not in self.detection_indices]


def _ground_distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Metres between two nearby points (equirectangular; exact enough between telemetry samples)."""
    k = math.pi / 180.0 * 6_371_008.8
    return math.hypot((lat2 - lat1) * k, (lon2 - lon1) * k * math.cos(math.radians((lat1 + lat2) / 2)))
