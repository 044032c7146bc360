"""What each vehicle reports, as the ground station keeps it: `VehicleStatus`, updated from
MAVLink messages by pure methods (the async code only feeds them), its flight `Stage` and the
sensor readings (`Detection`) it sent.

UAV ids are matched to vehicles by MAVLink system id: the plan's UAV N is the vehicle whose
HEARTBEAT comes from system id N, on whichever connection it is heard."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from enum import Enum
from urllib.parse import parse_qs, urlsplit

from gcs.autopilots import Autopilot
from gcs.links import mavlink
from gcs.telemetry.wind import WindEstimate

__all__ = ["FINAL_STAGES", "Detection", "Stage", "VehicleStatus"]

MAVMessage = mavlink.MAVLink_message


class Stage(str, Enum):
    CONNECTING = "connecting"
    PREPARING = "preparing"
    UPLOADING = "uploading"
    ARMING = "arming"
    SEARCH = "search"
    RETURN = "return"
    RTL = "rtl"
    LANDED = "landed"
    LANDED_AWAY = "landed away"  # down, but not at its airport: someone must fetch it
    LOST = "lost"
    FAILED = "failed"


FINAL_STAGES = frozenset({Stage.LANDED, Stage.LANDED_AWAY, Stage.FAILED})


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
    heartbeat_s: float | None = None  # when its last HEARTBEAT came (monotonic)
    airborne_seen: bool = False
    battery_samples: deque = field(default_factory=lambda: deque(maxlen=120))
    detections: list[Detection] = field(default_factory=list)
    detection_indices: set = field(default_factory=set)
    last_text: str = ""
    note: str = ""
    track_index: int = 0
    range_left: float = math.inf
    margin: float = math.inf
    wind: WindEstimate | None = None  # the last wind estimate, still air included
    return_reason: str | None = None
    battery_at_landing: float | None = None
    landed_from_airport_m: float | None = None
    gps_fix_type: int | None = None
    satellites: int | None = None
    ekf_flags: int | None = None
    home: tuple[float, float, float] | None = None  # lat, lon, altitude AMSL (HOME_POSITION)
    origin_seen: bool = False
    prearm_ok: bool | None = None
    consumed_mah: float | None = None
    board_uid: int | None = None  # AUTOPILOT_VERSION.uid (0: the autopilot has none)
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
            self.heartbeat_s = now_s
            self.mode_name = self.autopilot.mode_name(msg.type, msg.custom_mode)
        elif kind == "GLOBAL_POSITION_INT":
            lat, lon = msg.lat / 1e7, msg.lon / 1e7
            if self.airborne and self.has_position:
                self.odometer_m += ground_distance_m(self.lat_deg, self.lon_deg, lat, lon)
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
        elif kind == "AUTOPILOT_VERSION":
            self.board_uid = int(msg.uid)
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


def ground_distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Metres between two nearby points (equirectangular; exact enough between telemetry samples)."""
    k = math.pi / 180.0 * 6_371_008.8
    return math.hypot((lat2 - lat1) * k, (lon2 - lon1) * k * math.cos(math.radians((lat1 + lat2) / 2)))
