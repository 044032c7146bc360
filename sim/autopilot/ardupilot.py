"""What the `ardupilot` profile does as ArduCopter and ArduPlane 4.7 SITL did when measured
(research reports `ardupilot_protocol` and `ardupilot_flight`): pure functions and tables, no
state. The section of the report each value comes from is named beside it.

- readiness after boot: milestones in vehicle seconds, the EKF flags, and the arming refusals
  ArduPilot gives on the way (flight §1);
- mission items: which ones a vehicle refuses at the item, and with which MAV_MISSION_RESULT
  (protocol Q4), the end-of-upload fence validation (Q2), capacities (Q3), the float32
  arithmetic of the legacy MISSION_ITEM messages (Q1);
- names ArduPilot uses in its texts.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, fields, replace

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.capacity import ARDUCOPTER_FENCE, ARDUPLANE_FENCE, mission_capacity
from gcs.autopilots.wire_item import GLOBAL_FRAMES, MissionType, WireItem

# ---- readiness after boot (flight §1) ---------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class BootTimes:
    """Vehicle seconds after boot at which each readiness milestone is reached.

    `attitude_s`: the EKF has its attitude (before: "Need Alt Estimate", "EKF attitude is bad");
    `gps_fix_s`: 3-D fix, GLOBAL_POSITION_INT leaves 0, 0; `home_s`: HOME_POSITION set;
    `origin_s`: GPS_GLOBAL_ORIGIN set; `ekf_position_s`: EKF_STATUS_REPORT has POS_HORIZ_ABS
    and not CONST_POS_MODE; `accels_ok_s`, `gyros_ok_s`: SITL's IMUs stop being "inconsistent"."""

    attitude_s: float
    gps_fix_s: float
    home_s: float
    origin_s: float
    ekf_position_s: float
    accels_ok_s: float
    gyros_ok_s: float

    def scaled(self, k: float) -> BootTimes:
        """Every milestone k times as late (k = 0: ready at once; tests use small k)."""
        return BootTimes(**{f.name: getattr(self, f.name) * k for f in fields(self)})


# ArduCopter in GUIDED and ArduPlane, measured in vehicle time (identical at SPEEDUP 1 and 10).
BOOT_TIMES = {
    "copter": BootTimes(attitude_s=5.8, gps_fix_s=10.0, home_s=19.8, origin_s=19.8, ekf_position_s=42.0,
                        accels_ok_s=14.0, gyros_ok_s=24.0),
    "plane": BootTimes(attitude_s=4.0, gps_fix_s=10.1, home_s=10.1, origin_s=21.5, ekf_position_s=21.1,
                       accels_ok_s=13.3, gyros_ok_s=23.3),
}

EKF_UNINITIALISED = 0x400  # EKF_STATUS_REPORT.flags before the filter runs
EKF_ATTITUDE_ONLY = 0xA7  # attitude, velocities, vertical position, CONST_POS_MODE
EKF_POSITION_OK = 0x33F  # ... + POS_HORIZ_REL/ABS and predicted positions, no CONST_POS_MODE


def ekf_flags(boot: BootTimes, t_s: float) -> int:
    if t_s < boot.attitude_s:
        return EKF_UNINITIALISED
    return EKF_POSITION_OK if t_s >= boot.ekf_position_s else EKF_ATTITUDE_ONLY


def boot_refusals(vehicle_type: str, boot: BootTimes, t_s: float, *, needs_position: bool) -> list[str]:
    """The reasons ArduPilot gives, in its order, for refusing to arm at `t_s` seconds after
    boot (each comes as one STATUSTEXT "Arm: <reason>"). A copter needs the EKF's position
    only in modes that fly by position (not STABILIZE); the plane only needs its home."""
    copter = vehicle_type == "copter"
    out = []
    if copter and t_s < boot.attitude_s:
        out.append("Need Alt Estimate")
    if t_s < boot.accels_ok_s:
        out.append("Accels inconsistent")
    elif t_s < boot.gyros_ok_s:
        out.append("Gyros inconsistent")
    if copter and t_s < boot.attitude_s:
        out.append("EKF attitude is bad")
    if t_s < boot.home_s:
        out.append("AHRS: waiting for home")
    elif copter and needs_position and t_s < boot.ekf_position_s:
        out.append("Need Position Estimate")
    return out


# ---- capacities (protocol Q3) ------------------------------------------------------------------

#: the station's measured table (`gcs.autopilots.capacity`) for missions and fences; rally here only
CAPACITY = {
    "copter": {MissionType.MISSION: mission_capacity("ardupilot", False), MissionType.FENCE: ARDUCOPTER_FENCE.items,
               MissionType.RALLY: 46},
    "plane": {MissionType.MISSION: mission_capacity("ardupilot", True), MissionType.FENCE: ARDUPLANE_FENCE.items,
              MissionType.RALLY: 50},
}

# ---- mission items (protocol Q1, Q4; AP_Mission::mavlink_int_to_mission_cmd) -------------------

# commands that carry a location (lat/lon range, |z| and the frame are checked)
LOCATION_COMMANDS = frozenset({
    mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LOITER_TURNS,
    mavlink.MAV_CMD_NAV_LOITER_TIME, mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_CMD_NAV_TAKEOFF,
    mavlink.MAV_CMD_NAV_CONTINUE_AND_CHANGE_ALT, mavlink.MAV_CMD_NAV_LOITER_TO_ALT,
    mavlink.MAV_CMD_NAV_SPLINE_WAYPOINT, mavlink.MAV_CMD_NAV_GUIDED_ENABLE, mavlink.MAV_CMD_DO_SET_HOME,
    mavlink.MAV_CMD_DO_LAND_START, mavlink.MAV_CMD_DO_GO_AROUND, mavlink.MAV_CMD_DO_SET_ROI,
    mavlink.MAV_CMD_NAV_VTOL_TAKEOFF, mavlink.MAV_CMD_NAV_VTOL_LAND, mavlink.MAV_CMD_NAV_PAYLOAD_PLACE,
    mavlink.MAV_CMD_DO_RETURN_PATH_START,
})
MISSION_COMMANDS = LOCATION_COMMANDS | frozenset({
    mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, mavlink.MAV_CMD_NAV_DELAY, mavlink.MAV_CMD_NAV_ALTITUDE_WAIT,
    mavlink.MAV_CMD_NAV_SET_YAW_SPEED, mavlink.MAV_CMD_NAV_SCRIPT_TIME, mavlink.MAV_CMD_NAV_ATTITUDE_TIME,
    mavlink.MAV_CMD_CONDITION_DELAY, mavlink.MAV_CMD_CONDITION_DISTANCE, mavlink.MAV_CMD_CONDITION_YAW,
    mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_DO_JUMP, mavlink.MAV_CMD_DO_JUMP_TAG, mavlink.MAV_CMD_JUMP_TAG,
    mavlink.MAV_CMD_DO_CHANGE_SPEED, mavlink.MAV_CMD_DO_SET_RELAY, mavlink.MAV_CMD_DO_REPEAT_RELAY,
    mavlink.MAV_CMD_DO_SET_SERVO, mavlink.MAV_CMD_DO_REPEAT_SERVO, mavlink.MAV_CMD_DO_SET_ROI_LOCATION,
    mavlink.MAV_CMD_DO_SET_ROI_NONE, mavlink.MAV_CMD_DO_DIGICAM_CONFIGURE, mavlink.MAV_CMD_DO_DIGICAM_CONTROL,
    mavlink.MAV_CMD_DO_MOUNT_CONTROL, mavlink.MAV_CMD_DO_SET_CAM_TRIGG_DIST, mavlink.MAV_CMD_DO_FENCE_ENABLE,
    mavlink.MAV_CMD_DO_PARACHUTE, mavlink.MAV_CMD_DO_INVERTED_FLIGHT, mavlink.MAV_CMD_DO_GRIPPER,
    mavlink.MAV_CMD_DO_GUIDED_LIMITS, mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE, mavlink.MAV_CMD_DO_VTOL_TRANSITION,
    mavlink.MAV_CMD_DO_SET_REVERSE, mavlink.MAV_CMD_DO_ENGINE_CONTROL, mavlink.MAV_CMD_DO_WINCH,
    mavlink.MAV_CMD_DO_SET_RESUME_REPEAT_DIST, mavlink.MAV_CMD_DO_SPRAYER, mavlink.MAV_CMD_DO_SEND_SCRIPT_MESSAGE,
    mavlink.MAV_CMD_DO_AUX_FUNCTION, mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, mavlink.MAV_CMD_IMAGE_START_CAPTURE,
    mavlink.MAV_CMD_IMAGE_STOP_CAPTURE, mavlink.MAV_CMD_VIDEO_START_CAPTURE, mavlink.MAV_CMD_VIDEO_STOP_CAPTURE,
    mavlink.MAV_CMD_SET_CAMERA_ZOOM, mavlink.MAV_CMD_SET_CAMERA_FOCUS, mavlink.MAV_CMD_SET_CAMERA_SOURCE,
})
# params that may be NaN (AP_Mission::sanity_check_params), 0-based
_NAN_ALLOWED = {
    mavlink.MAV_CMD_NAV_WAYPOINT: {3}, mavlink.MAV_CMD_NAV_LAND: {3}, mavlink.MAV_CMD_NAV_TAKEOFF: {3},
    mavlink.MAV_CMD_NAV_VTOL_TAKEOFF: {3}, mavlink.MAV_CMD_NAV_VTOL_LAND: {2, 3},
}
LOCATION_FRAMES = frozenset({
    mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_MISSION, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
})
FENCE_RALLY_FRAMES = LOCATION_FRAMES - {mavlink.MAV_FRAME_MISSION}
FENCE_COMMANDS = frozenset({
    mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
})
MAX_ALT_M = 83000.0  # LOCATION_ALT_MAX_M: |z| at or above it is MAV_MISSION_INVALID_PARAM7
_PARAM_RESULTS = (mavlink.MAV_MISSION_INVALID_PARAM1, mavlink.MAV_MISSION_INVALID_PARAM2,
                  mavlink.MAV_MISSION_INVALID_PARAM3, mavlink.MAV_MISSION_INVALID_PARAM4)


def f32(value: float) -> float:
    """The nearest float32 (C's float); beyond its range, infinity."""
    try:
        return struct.unpack("<f", struct.pack("<f", value))[0]
    except OverflowError:
        return math.copysign(math.inf, value)


def _lat_lon_result(x: int, y: int) -> int:
    """ArduPilot compares degE7 as float32, so lat up to +32 and lon up to +64 degE7 past the
    limits get through (Q4)."""
    if f32(abs(x)) > 9e8:
        return mavlink.MAV_MISSION_INVALID_PARAM5_X
    if f32(abs(y)) > 1.8e9:
        return mavlink.MAV_MISSION_INVALID_PARAM6_Y
    return mavlink.MAV_MISSION_ACCEPTED


def item_result(item: WireItem) -> int:
    """MAV_MISSION_RESULT for one uploaded item, checked as it arrives (Q4, Q2): NaN or inf in
    a param (NaN allowed only in p4 of WAYPOINT / LAND / TAKEOFF), command 0, an unknown
    command, a location out of range, |z| >= 83000 m or NaN, an unsupported frame."""
    kind = item.mission_type
    if kind == MissionType.FENCE:
        if item.command not in FENCE_COMMANDS:
            return mavlink.MAV_MISSION_UNSUPPORTED
        if item.frame not in FENCE_RALLY_FRAMES:
            return mavlink.MAV_MISSION_UNSUPPORTED_FRAME
        return mavlink.MAV_MISSION_ACCEPTED
    if kind == MissionType.RALLY:
        if item.frame not in FENCE_RALLY_FRAMES:
            return mavlink.MAV_MISSION_UNSUPPORTED_FRAME
        if item.command != mavlink.MAV_CMD_NAV_RALLY_POINT:
            return mavlink.MAV_MISSION_UNSUPPORTED
        where = _lat_lon_result(item.x, item.y)
        if where != mavlink.MAV_MISSION_ACCEPTED:
            return where
        if not math.isfinite(item.z) or not -32768 <= math.trunc(f32(item.z)) <= 32767:
            return mavlink.MAV_MISSION_INVALID_PARAM7
        return mavlink.MAV_MISSION_ACCEPTED
    nan_ok = _NAN_ALLOWED.get(item.command, set())
    for i, p in enumerate((item.param1, item.param2, item.param3, item.param4)):
        if math.isinf(p) or (math.isnan(p) and i not in nan_ok):
            return _PARAM_RESULTS[i]
    if item.command == 0:
        return mavlink.MAV_MISSION_INVALID
    if item.command not in MISSION_COMMANDS:
        return mavlink.MAV_MISSION_UNSUPPORTED
    if item.command in LOCATION_COMMANDS:
        where = _lat_lon_result(item.x, item.y)
        if where != mavlink.MAV_MISSION_ACCEPTED:
            return where
        if math.isnan(item.z) or abs(f32(item.z)) >= MAX_ALT_M:
            return mavlink.MAV_MISSION_INVALID_PARAM7
        if item.frame not in LOCATION_FRAMES:
            return mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    return mavlink.MAV_MISSION_ACCEPTED


def from_legacy_item(msg: mavlink.MAVLink_message) -> tuple[WireItem, int]:
    """A MISSION_ITEM (float32 degrees) as ArduPilot converts it, and the result of the
    conversion: degrees * 1e7f in float32, cut towards zero (Q1: up to 0.5 m off at |lon| > 128)."""
    item = WireItem.from_msg(msg)
    if msg.command in (mavlink.MAV_CMD_DO_DIGICAM_CONTROL, mavlink.MAV_CMD_DO_DIGICAM_CONFIGURE):
        return replace(item, x=int(msg.x), y=int(msg.y)), mavlink.MAV_MISSION_ACCEPTED
    if not abs(f32(msg.x)) <= 90.0:
        return item, mavlink.MAV_MISSION_INVALID_PARAM5_X
    if not abs(f32(msg.y)) <= 180.0:
        return item, mavlink.MAV_MISSION_INVALID_PARAM6_Y
    scale = f32(1e7)
    return replace(item, x=math.trunc(f32(f32(msg.x) * scale)), y=math.trunc(f32(f32(msg.y) * scale))), \
        mavlink.MAV_MISSION_ACCEPTED


def to_legacy_item(item: WireItem, target: tuple[int, int]) -> mavlink.MAVLink_message:
    """The MISSION_ITEM ArduPilot answers a MISSION_REQUEST with: degE7 * 1e-7f in float32,
    two roundings (Q1: up to 34 degE7 off in latitude near 47 deg)."""
    x, y = float(item.x), float(item.y)
    if item.command not in (mavlink.MAV_CMD_DO_DIGICAM_CONTROL, mavlink.MAV_CMD_DO_DIGICAM_CONFIGURE) \
            and item.frame in GLOBAL_FRAMES | {mavlink.MAV_FRAME_MISSION}:
        scale = f32(1e-7)
        x, y = f32(f32(item.x) * scale), f32(f32(item.y) * scale)
    return mavlink.MAVLink_mission_item_message(
        target[0], target[1], item.seq, item.frame, item.command, item.current, item.autocontinue,
        item.param1, item.param2, item.param3, item.param4, x, y, item.z, item.mission_type)


# ---- the fence, validated when the whole list has arrived (protocol Q2, Q3) ---------------------

_POLYGONS = (mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
_CIRCLES = (mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION)
# AC_PolyFenceType numbers, as ArduPilot names them in "Received incorrect type"
_FENCE_TYPE = {
    mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION: 98, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION: 97,
    mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT: 95, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION: 93,
    mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION: 92,
}


def fence_problems(items: list[WireItem], capacity: int) -> list[str]:
    """ArduPilot's texts refusing a complete fence upload (MAV_MISSION_ERROR follows, the old
    fence stays), empty when it is accepted: vertex counts, circle radii, return points,
    coordinates, and the storage of 8 bytes per COUNT of capacity."""
    problems: list[str] = []
    returns = 0
    i = 0
    while i < len(items) and not problems:
        it = items[i]
        if _lat_lon_result(it.x, it.y) != mavlink.MAV_MISSION_ACCEPTED:
            problems.append("Bad lat or lon")
        elif it.command in _POLYGONS:
            n = int(it.param1) if math.isfinite(it.param1) else 0
            if n < 3:
                problems.append(f"Invalid vertex count ({n})")
                break
            run = items[i:i + n]
            other = next((r for r in run if r.command != it.command), None)
            if other is not None:
                problems.append(f"Received incorrect type (want={_FENCE_TYPE[it.command]} "
                                f"got={_FENCE_TYPE.get(other.command, 0)})")
            elif len(run) < n or any(int(r.param1) != n for r in run):
                problems.append("Incorrect item count")
            i += n
            continue
        elif it.command in _CIRCLES:
            if not it.param1 > 0:
                problems.append("Non-positive circle radius")
        else:
            returns += 1
            if returns > 1:
                problems.append("Multiple return points")
        i += 1
    if not problems and fence_storage_bytes(items) > 8 * capacity:
        problems.append("Fence exceeds storage size")
    return problems + ["Fence validation failed"] if problems else []


def fence_storage_bytes(items: list[WireItem]) -> int:
    """The bytes a valid fence list takes in ArduPilot's storage (`fence_storage_space_required`):
    a 4-byte header, per polygon 2 and 8 a vertex, 13 a circle, 9 a return point."""
    storage, i = 4, 0
    while i < len(items):
        if items[i].command in _POLYGONS:
            n = max(1, int(items[i].param1))
            storage, i = storage + 2 + 8 * n, i + n
        else:
            storage, i = storage + (13 if items[i].command in _CIRCLES else 9), i + 1
    return storage


def fence_leaves_no_end_marker(items: list[WireItem], capacity: int) -> bool:
    """Whether a fence that passed its checks fills the storage to the last byte: ArduPilot then
    cannot write its end-of-storage marker, and the upload is never answered (ArduCopter SITL,
    a 41-vertex inclusion with a 28-vertex exclusion: 560 of 560 bytes)."""
    return fence_storage_bytes(items) + 1 > 8 * capacity


def fence_total(items: list[WireItem]) -> int:
    """FENCE_TOTAL after an upload: polygon vertices and circles, plus 2, if at least 3, else 0."""
    counted = sum(it.command in _POLYGONS or it.command in _CIRCLES for it in items)
    return counted + 2 if counted >= 3 else 0


# ---- names in ArduPilot's texts -----------------------------------------------------------------

MISSION_TEXT_NAMES = {
    mavlink.MAV_CMD_NAV_WAYPOINT: "WP", mavlink.MAV_CMD_NAV_TAKEOFF: "Takeoff", mavlink.MAV_CMD_NAV_LAND: "Land",
    mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH: "RTL", mavlink.MAV_CMD_NAV_LOITER_UNLIM: "LoitUnlim",
    mavlink.MAV_CMD_NAV_LOITER_TIME: "LoitTime", mavlink.MAV_CMD_DO_LAND_START: "LandStart",
    mavlink.MAV_CMD_DO_CHANGE_SPEED: "ChangeSpeed", mavlink.MAV_CMD_DO_JUMP: "Jump",
}
