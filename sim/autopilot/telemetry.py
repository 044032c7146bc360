"""Telemetry streams: which message is due when, and how each is built from vehicle state.

Intervals are in simulated seconds, so `--speedup K` sends K times as often in real time, as
ArduPilot SITL does. A stream sends at most once per fleet tick: an overloaded process sends
less often rather than in bursts.

Defaults per profile: an ArduCopter streams nothing but HEARTBEAT until a station asks
(SET_MESSAGE_INTERVAL or REQUEST_DATA_STREAM), an ArduPlane streams every group at 1 Hz
(research `ardupilot_flight` §1); the px4 profile streams at PX4's own rates (research `px4`
§3: position and attitude 50 Hz, GPS 5 Hz, HUD 4 Hz, status 1 Hz, battery, home and estimator
0.5 Hz), position, attitude and HUD at `telemetry_hz` when given. Before its GPS fix (ArduPilot)
or its position estimate (PX4) a vehicle reports position 0, 0.

`reading_message` and `reading_text` are a reading of the downward sensor on the wire (docs/sim.md,
"The detection message"), for every sender of readings: the simulated vehicles and
`sim/detector.py`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim.autopilot import px4
from sim.autopilot.failsafe import FailsafeLevel
from sim.autopilot.modes import Mode
from sim.physics.battery import Battery
from sim.physics.sensor import Observation, SensorConfig

if TYPE_CHECKING:
    from sim.autopilot.vehicle import SimVehicle

HEARTBEAT = mavlink.MAVLINK_MSG_ID_HEARTBEAT
SYS_STATUS = mavlink.MAVLINK_MSG_ID_SYS_STATUS
BATTERY_STATUS = mavlink.MAVLINK_MSG_ID_BATTERY_STATUS
EXTENDED_SYS_STATE = mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE
MISSION_CURRENT = mavlink.MAVLINK_MSG_ID_MISSION_CURRENT
GLOBAL_POSITION_INT = mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
ATTITUDE = mavlink.MAVLINK_MSG_ID_ATTITUDE
VFR_HUD = mavlink.MAVLINK_MSG_ID_VFR_HUD
HOME_POSITION = mavlink.MAVLINK_MSG_ID_HOME_POSITION
AUTOPILOT_VERSION = mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION
GPS_RAW_INT = mavlink.MAVLINK_MSG_ID_GPS_RAW_INT
EKF_STATUS_REPORT = mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT
GPS_GLOBAL_ORIGIN = mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN
ESTIMATOR_STATUS = mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS

SLOW_STREAMS = (HEARTBEAT, SYS_STATUS, BATTERY_STATUS, EXTENDED_SYS_STATE, MISSION_CURRENT)
FAST_STREAMS = (GLOBAL_POSITION_INT, ATTITUDE, VFR_HUD)
ARDUPILOT_STREAMS = SLOW_STREAMS + FAST_STREAMS + (GPS_RAW_INT, EKF_STATUS_REPORT)

# REQUEST_DATA_STREAM groups, as ArduPilot assigns messages to them.
DATA_STREAM_GROUPS: dict[int, tuple[int, ...]] = {
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: (SYS_STATUS, MISSION_CURRENT, EXTENDED_SYS_STATE, GPS_RAW_INT),
    mavlink.MAV_DATA_STREAM_POSITION: (GLOBAL_POSITION_INT,),
    mavlink.MAV_DATA_STREAM_EXTRA1: (ATTITUDE,),
    mavlink.MAV_DATA_STREAM_EXTRA2: (VFR_HUD,),
    mavlink.MAV_DATA_STREAM_EXTRA3: (BATTERY_STATUS, EKF_STATUS_REPORT),
}
DATA_STREAM_GROUPS[mavlink.MAV_DATA_STREAM_ALL] = tuple(m for g in DATA_STREAM_GROUPS.values() for m in g)

CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
)
_SENSORS = (
    mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | mavlink.MAV_SYS_STATUS_SENSOR_GPS
    | mavlink.MAV_SYS_STATUS_SENSOR_BATTERY
)
_GRAVITY_M_S2 = 9.80665


def default_intervals_s(fast_hz: float | None, *, profile: str = "px4", vehicle_type: str = "copter"
                        ) -> dict[int, float | None]:
    """What a vehicle streams before anyone asks: ArduCopter only HEARTBEAT, ArduPlane every
    stream at 1 Hz; px4: PX4's rates, position/attitude/HUD at `fast_hz` when given."""
    if profile == "ardupilot":
        hz = 1.0 if vehicle_type == "plane" else None
        intervals: dict[int, float | None] = dict.fromkeys(ARDUPILOT_STREAMS, hz)
        intervals[HEARTBEAT] = 1.0
        return intervals
    intervals = {msg_id: 1.0 / hz for msg_id, hz in px4.DEFAULT_RATES_HZ.items()}
    if fast_hz is not None:
        intervals.update(dict.fromkeys(FAST_STREAMS, 1.0 / fast_hz))
    return intervals


class StreamScheduler:
    """Next due time per message id; interval None means off."""

    def __init__(self, intervals_s: dict[int, float | None]) -> None:
        self._defaults = dict(intervals_s)
        self._interval: dict[int, float | None] = dict(intervals_s)
        self._due: dict[int, float] = dict.fromkeys(intervals_s, 0.0)

    def set_interval(self, msg_id: int, interval_s: float | None, now_s: float) -> None:
        """None disables; the SET_MESSAGE_INTERVAL value 0 means 'default': pass `default`."""
        self._interval[msg_id] = interval_s
        self._due[msg_id] = now_s

    def reset_default(self, msg_id: int, now_s: float) -> None:
        self.set_interval(msg_id, self._defaults.get(msg_id), now_s)

    def interval(self, msg_id: int) -> float | None:
        return self._interval.get(msg_id)

    def due(self, now_s: float) -> list[int]:
        out = []
        for msg_id, interval in self._interval.items():
            if interval is None or self._due[msg_id] > now_s:
                continue
            out.append(msg_id)
            nxt = self._due[msg_id] + interval
            self._due[msg_id] = nxt if nxt > now_s else now_s + interval
        return out


def known(msg_id: int, v: SimVehicle) -> bool:
    """Whether vehicle `v` can send message `msg_id` (when it has the data)."""
    only = _ARDUPILOT_ONLY if not v.ardupilot else _PX4_ONLY
    return msg_id in _BUILDERS and msg_id not in only


def build(msg_id: int, v: SimVehicle) -> mavlink.MAVLink_message | None:
    """The message `msg_id` describing vehicle `v` now, or None if it cannot be sent now (an
    ArduPilot vehicle without a home yet sends no HOME_POSITION) or at all."""
    return _BUILDERS[msg_id](v) if known(msg_id, v) else None


def _clamp(value: float, lo: int, hi: int) -> int:
    return max(lo, min(hi, round(value)))


def _time_boot_ms(v: SimVehicle) -> int:
    return int(v.time_s * 1000) & 0xFFFFFFFF


def heartbeat(v: SimVehicle) -> mavlink.MAVLink_message:
    base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    if v.armed:
        base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    if v.mode in (Mode.GUIDED, Mode.AUTO, Mode.RTL, Mode.LAND, Mode.LOITER, Mode.TAKEOFF):
        base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
    if v.mode in (Mode.AUTO, Mode.RTL, Mode.LAND, Mode.TAKEOFF):
        base |= mavlink.MAV_MODE_FLAG_AUTO_ENABLED
    if not v.armed or (v.ardupilot and v.landed):
        status = mavlink.MAV_STATE_STANDBY  # ArduPilot: ACTIVE only once flying
    elif v.failsafe != FailsafeLevel.NONE:
        status = mavlink.MAV_STATE_CRITICAL
    else:
        status = mavlink.MAV_STATE_ACTIVE
    return mavlink.MAVLink_heartbeat_message(v.mav_type, v.mav_autopilot, base, v.custom_mode, status, 3)


def global_position_int(v: SimVehicle) -> mavlink.MAVLink_message:
    s = v.airframe.kin
    hdg = round(math.degrees(s.heading_rad) % 360 * 100) % 36000
    if not v.position_known:  # the estimator has no origin yet
        return mavlink.MAVLink_global_position_int_message(_time_boot_ms(v), 0, 0, 0, 0, 0, 0, 0, hdg)
    lat, lon = v.airframe.lat_lon_deg
    vn = s.speed_m_s * math.cos(s.heading_rad)
    ve = s.speed_m_s * math.sin(s.heading_rad)
    return mavlink.MAVLink_global_position_int_message(
        _time_boot_ms(v), round(lat * 1e7), round(lon * 1e7),
        round((v.home.alt_m + s.alt_m) * 1000), round(s.alt_m * 1000),
        round(vn * 100), round(ve * 100), round(-s.climb_m_s * 100), hdg,
    )


def gps_raw_int(v: SimVehicle) -> mavlink.MAVLink_message:
    """SITL's GPS: no fix and zeros until `gps_fix_s`, then 10 satellites, fix type 6
    (ArduPilot) or 3 (PX4's SIH)."""
    if not v.gps_fixed:
        return mavlink.MAVLink_gps_raw_int_message(0, mavlink.GPS_FIX_TYPE_NO_FIX, 0, 0, 0, 65535, 65535, 0, 0, 0)
    fix = mavlink.GPS_FIX_TYPE_RTK_FIXED if v.ardupilot else mavlink.GPS_FIX_TYPE_3D_FIX
    s = v.airframe.kin
    lat, lon = v.airframe.lat_lon_deg
    alt_mm = round((v.home.alt_m + s.alt_m) * 1000)
    cog = round(math.degrees(s.heading_rad) % 360 * 100) % 36000
    return mavlink.MAVLink_gps_raw_int_message(
        int(v.time_s * 1e6), fix, round(lat * 1e7), round(lon * 1e7), alt_mm,
        121, 200, round(s.speed_m_s * 100), cog, 10, alt_mm, 300, 300, 0, 0, 0)


def estimator_status(v: SimVehicle) -> mavlink.MAVLink_message:
    """PX4's estimator flags: vertical only (CONST_POS_MODE) until `estimator_s`."""
    flags = px4.ESTIMATOR_POSITION_OK if v.time_s >= v.boot.estimator_s else px4.ESTIMATOR_BOOTING
    return mavlink.MAVLink_estimator_status_message(int(v.time_s * 1e6), flags, 0, 0, 0, 0, 0, 0, 0, 0)


def ekf_status_report(v: SimVehicle) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_ekf_status_report_message(v.ekf_flags, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def gps_global_origin(v: SimVehicle) -> mavlink.MAVLink_message | None:
    if v.origin is None:
        return None
    lat, lon, alt = v.origin
    return mavlink.MAVLink_gps_global_origin_message(round(lat * 1e7), round(lon * 1e7), round(alt * 1000),
                                                     int(v.time_s * 1e6))


#: A multicopter's lean against 10 m/s of air speed and its growth with speed (ArduCopter SITL's
#: quad: `benchmarks/lean_wind.py`): the simulated copter flies in still air, nose first.
COPTER_LEAN_AT_10_M_S = 0.507
COPTER_LEAN_EXPONENT = 4.0 / 3.0


def attitude(v: SimVehicle) -> mavlink.MAVLink_message:
    """A plane's bank in its turns and pitch in its climb; a multicopter's lean forward into the
    air it flies through (never its climb: it climbs level) and sideways into its turns."""
    s = v.airframe.kin
    roll = math.atan(s.speed_m_s * s.turn_rate_rad_s / _GRAVITY_M_S2)
    pitch = math.atan2(s.climb_m_s, max(s.speed_m_s, 1.0))
    if v.copter:
        pitch = -math.atan(COPTER_LEAN_AT_10_M_S * (s.speed_m_s / 10.0) ** COPTER_LEAN_EXPONENT)
        roll = math.atan(math.tan(roll) * math.cos(pitch))
    return mavlink.MAVLink_attitude_message(_time_boot_ms(v), roll, pitch, s.heading_rad, 0.0, 0.0, s.turn_rate_rad_s)


def vfr_hud(v: SimVehicle) -> mavlink.MAVLink_message:
    s = v.airframe.kin
    airspeed = 0.0 if not v.ardupilot and v.copter else s.speed_m_s  # the SIH quad has no airspeed sensor
    return mavlink.MAVLink_vfr_hud_message(
        airspeed, s.speed_m_s, round(math.degrees(s.heading_rad)) % 360, round(100 * v.throttle),
        v.home.alt_m + s.alt_m, s.climb_m_s,
    )


def sys_status(v: SimVehicle) -> mavlink.MAVLink_message:
    if not v.ardupilot:  # PX4 sets the pre-arm bit in `health` only (px4 §3)
        ready = int(v.time_s >= v.boot.prearm_s)
        health = px4.SENSORS_HEALTH[int(v.prearm_ok)]
        return mavlink.MAVLink_sys_status_message(
            px4.SENSORS_PRESENT[ready], px4.SENSORS_ENABLED[ready], health, 400, round(v.battery_voltage_v * 1000),
            -100, round(v.battery_pct), 0, 0, 0, 0, 0, 0)
    b = v.airframe.battery
    assert isinstance(b, Battery)
    present = _SENSORS | mavlink.MAV_SYS_STATUS_PREARM_CHECK
    # the pre-arm bit: healthy when its pre-arm checks pass in the current mode
    health = _SENSORS | (mavlink.MAV_SYS_STATUS_PREARM_CHECK if v.prearm_ok else 0)
    return mavlink.MAVLink_sys_status_message(
        present, present, health, 200, round(v.battery_voltage_v * 1000), _clamp(b.current_a * 100, -1, 32767),
        round(b.remaining_pct), 0, 0, 0, 0, 0, 0,
    )


def battery_status(v: SimVehicle) -> mavlink.MAVLink_message:
    """ArduPilot (docs/energy.md): the pack voltage in voltages[0], the current, consumed charge
    and energy, no time remaining (0); px4: SIH's battery as PX4 reports it (px4 §7)."""
    b = v.airframe.battery
    voltages = [round(v.battery_voltage_v * 1000)] + [0xFFFF] * 9
    if not isinstance(b, Battery):
        return mavlink.MAVLink_battery_status_message(
            0, mavlink.MAV_BATTERY_FUNCTION_ALL, mavlink.MAV_BATTERY_TYPE_LIPO, 0x7FFF, voltages, -100, 0, -1,
            round(v.battery_pct), 0, v.charge_state)
    if b.remaining_fraction <= 0.0:
        charge = mavlink.MAV_BATTERY_CHARGE_STATE_FAILED
    else:
        charge = {
            FailsafeLevel.NONE: mavlink.MAV_BATTERY_CHARGE_STATE_OK,
            FailsafeLevel.LOW: mavlink.MAV_BATTERY_CHARGE_STATE_LOW,
            FailsafeLevel.CRITICAL: mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL,
        }[v.failsafe]
    return mavlink.MAVLink_battery_status_message(
        0, mavlink.MAV_BATTERY_FUNCTION_ALL, mavlink.MAV_BATTERY_TYPE_LIPO, 0x7FFF, voltages,
        _clamp(b.current_a * 100, -1, 32767), _clamp(b.consumed_mah, -1, 2**31 - 1),
        _clamp(b.energy_j / 100.0, -1, 2**31 - 1), round(b.remaining_pct), 0, charge,
    )


def extended_sys_state(v: SimVehicle) -> mavlink.MAVLink_message:
    if v.landed and v.landing:  # an ArduCopter is LANDING until it disarms (flight §2)
        landed = mavlink.MAV_LANDED_STATE_LANDING
    elif v.landed:
        landed = mavlink.MAV_LANDED_STATE_ON_GROUND
    elif v.landing:
        landed = mavlink.MAV_LANDED_STATE_LANDING
    elif v.taking_off:  # TAKEOFF until the take-off is done (ardupilot_flight §2, px4 §4)
        landed = mavlink.MAV_LANDED_STATE_TAKEOFF
    else:
        landed = mavlink.MAV_LANDED_STATE_IN_AIR
    return mavlink.MAVLink_extended_sys_state_message(mavlink.MAV_VTOL_STATE_UNDEFINED, landed)


def mission_current(v: SimVehicle) -> mavlink.MAVLink_message:
    if not v.ardupilot:  # no current item yet: 65535; no mission: total 65535; v1.15 sends no state
        return mavlink.MAVLink_mission_current_message(v.reported_seq & 0xFFFF, v.mission_total or 0xFFFF, 0, 0)
    return mavlink.MAVLink_mission_current_message(
        v.mission_seq, v.mission_total, v.mission_state, int(v.mode == Mode.AUTO)
    )


def home_position(v: SimVehicle) -> mavlink.MAVLink_message | None:
    if not v.home_set:
        return None
    h = v.home
    east, north = v.frame.geodetic2en(h.lat_deg, h.lon_deg)
    return mavlink.MAVLink_home_position_message(
        round(h.lat_deg * 1e7), round(h.lon_deg * 1e7), round(h.alt_m * 1000),
        east, north, 0.0, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, int(v.time_s * 1e6),
    )


def autopilot_version(v: SimVehicle) -> mavlink.MAVLink_message:
    if v.ardupilot:
        version = (4 << 24) | (5 << 16) | mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL
    else:  # the peers' build reports v1.15.3-dirty as a development version
        version = (1 << 24) | (15 << 16) | (3 << 8) | mavlink.FIRMWARE_VERSION_TYPE_DEV
    return mavlink.MAVLink_autopilot_version_message(
        CAPABILITIES, version, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, v.sysid,
    )


_BUILDERS = {
    HEARTBEAT: heartbeat,
    SYS_STATUS: sys_status,
    BATTERY_STATUS: battery_status,
    EXTENDED_SYS_STATE: extended_sys_state,
    MISSION_CURRENT: mission_current,
    GLOBAL_POSITION_INT: global_position_int,
    ATTITUDE: attitude,
    VFR_HUD: vfr_hud,
    HOME_POSITION: home_position,
    AUTOPILOT_VERSION: autopilot_version,
    GPS_RAW_INT: gps_raw_int,
    EKF_STATUS_REPORT: ekf_status_report,
    GPS_GLOBAL_ORIGIN: gps_global_origin,
    ESTIMATOR_STATUS: estimator_status,
}
_ARDUPILOT_ONLY = frozenset({EKF_STATUS_REPORT})
_PX4_ONLY = frozenset({ESTIMATOR_STATUS})


def reading_message(obs: Observation, config: SensorConfig, alt_m: float, relative_alt_m: float
                    ) -> mavlink.MAVLink_camera_image_captured_message:
    """CAMERA_IMAGE_CAPTURED of one reading: the cell centre's lat/lon, the vehicle's altitudes
    (AMSL and above home, metres) when it read the cell, and `detect?cell=..&hit=..` with the
    sensor model in `file_url`."""
    url = f"detect?cell={obs.cell[0]},{obs.cell[1]}&hit={int(obs.reported)}&pc={config.pc:g}&pf={config.pf:g}"
    return mavlink.MAVLink_camera_image_captured_message(
        int(obs.time_s * 1000), 0, 0, round(obs.lat_deg * 1e7), round(obs.lon_deg * 1e7), round(alt_m * 1000),
        round(relative_alt_m * 1000), [1.0, 0.0, 0.0, 0.0], obs.index, 1, url.encode(),
    )


def reading_text(obs: Observation) -> str:
    """The STATUSTEXT that announces a positive reading to people (severity NOTICE)."""
    return f"DETECT cell {obs.cell[0]},{obs.cell[1]} img {obs.index}"
