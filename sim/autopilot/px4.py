"""What the `px4` profile does as PX4 v1.15.3 SITL (SIH, copter and plane) did when measured
(research report `px4`, /work/research/px4/README.md; "§3" below names its section): tables
and pure functions, no state.

- readiness after boot (§3): milestones in vehicle seconds, SYS_STATUS's sensor masks;
- telemetry (§3): the default stream rates, which SET_MESSAGE_INTERVAL ids PX4 takes;
- mission items (§1, §2): which are accepted, and with which MAV_MISSION_RESULT (the measured
  commands, and PX4's `mavlink_mission.cpp` lists for the others), capacities; what is kept of
  an item is `gcs.autopilots.px4_storage.stored_item`, the station's own model (`stored`);
- the navigator's feasibility check of a mission (§2, §13), whose reasons PX4 prints only on
  its console (`mission_problems`), and its geofence (`geofence.cpp`: every area must allow a
  point, areas home does not satisfy are dropped);
- the SIH battery and PX4's voltage-based estimate (§7); parameters and their defaults.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, fields

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.capacity import PX4_FENCE, mission_capacity
from gcs.autopilots.px4_storage import stored_item
from gcs.autopilots.wire_item import MissionType, WireItem
from planner.georef import LocalFrame

# ---- readiness after boot (§3) ----------------------------------------------------------------


@dataclass(frozen=True, slots=True, kw_only=True)
class Px4BootTimes:
    """Vehicle seconds after boot at which each readiness milestone is reached.

    `gps_fix_s`: GPS_RAW_INT fix 3, GPS_GLOBAL_ORIGIN; `home_s`: HOME_POSITION set;
    `position_s`: GLOBAL_POSITION_INT leaves 0, 0 and the navigator starts (it checks missions
    and takes up a current item from then on); `estimator_s`: ESTIMATOR_STATUS has
    POS_HORIZ_ABS and not CONST_POS_MODE; `prearm_s`: SYS_STATUS health has the pre-arm bit,
    arming is possible."""

    gps_fix_s: float
    home_s: float
    position_s: float
    estimator_s: float
    prearm_s: float

    def scaled(self, k: float) -> Px4BootTimes:
        """Every milestone k times as late (k = 0: ready at once; tests use small k)."""
        return Px4BootTimes(**{f.name: getattr(self, f.name) * k for f in fields(self)})


# copter at SPEEDUP 1 (x5 agrees within 0.7 s); the plane's pre-arm time is its estimator's
# plus the copter's 1.0 s (its first accepted arm came 2.5 s after the estimator)
BOOT_TIMES = {
    "copter": Px4BootTimes(gps_fix_s=1.1, home_s=2.1, position_s=34.6, estimator_s=36.1, prearm_s=37.1),
    "plane": Px4BootTimes(gps_fix_s=2.2, home_s=2.2, position_s=33.6, estimator_s=34.2, prearm_s=35.2),
}

# SYS_STATUS as PX4 sends it before and after it is ready: the pre-arm bit only ever in `health`
SENSORS_PRESENT = (35651597, 35651629)
SENSORS_ENABLED = (35717133, 35717165)
SENSORS_HEALTH = (572555327, 572555327 | mavlink.MAV_SYS_STATUS_PREARM_CHECK)
ESTIMATOR_BOOTING = (mavlink.ESTIMATOR_VELOCITY_VERT | mavlink.ESTIMATOR_POS_VERT_ABS
                     | mavlink.ESTIMATOR_POS_VERT_AGL | mavlink.ESTIMATOR_CONST_POS_MODE)
ESTIMATOR_POSITION_OK = (mavlink.ESTIMATOR_ATTITUDE | mavlink.ESTIMATOR_VELOCITY_HORIZ
                         | mavlink.ESTIMATOR_VELOCITY_VERT | mavlink.ESTIMATOR_POS_HORIZ_REL
                         | mavlink.ESTIMATOR_POS_HORIZ_ABS | mavlink.ESTIMATOR_POS_VERT_ABS
                         | mavlink.ESTIMATOR_POS_VERT_AGL | mavlink.ESTIMATOR_PRED_POS_HORIZ_REL
                         | mavlink.ESTIMATOR_PRED_POS_HORIZ_ABS)

# ---- telemetry (§3) ---------------------------------------------------------------------------

# what the GCS link streams unasked, per vehicle second (of the messages the simulator has)
DEFAULT_RATES_HZ = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0, mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 5.0, mavlink.MAVLINK_MSG_ID_VFR_HUD: 4.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 50.0, mavlink.MAVLINK_MSG_ID_ATTITUDE: 50.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 0.5, mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
    mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS: 0.5,
}
# MISSION_CURRENT is sent by PX4's mission manager, not a stream: SET_MESSAGE_INTERVAL fails
# for it (and it comes at 1 Hz anyway); EKF_STATUS_REPORT does not exist on PX4
NOT_SETTABLE = frozenset({mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT})

# ---- mission items (§1, §2) -------------------------------------------------------------------

CAPACITY = {MissionType.MISSION: mission_capacity("px4", False), MissionType.FENCE: PX4_FENCE.items,
            MissionType.RALLY: 32}  # missions and fences: the station's measured table (gcs.autopilots.capacity)
MISSION_RETRY_S = 0.25  # re-request of an awaited item (MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT)
MISSION_TIMEOUT_S = 5.0  # "Operation timeout" after this long without a message of the transfer

_FENCE_POLYGONS = frozenset({mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                             mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION})
_FENCE_CIRCLES = frozenset({mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION})
# commands taken in a global frame (parse_mavlink_mission_item)
GLOBAL_COMMANDS = frozenset({
    mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LOITER_TIME,
    mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LOITER_TO_ALT,
    mavlink.MAV_CMD_NAV_ROI, mavlink.MAV_CMD_DO_SET_ROI, mavlink.MAV_CMD_DO_SET_ROI_LOCATION,
    mavlink.MAV_CMD_NAV_VTOL_TAKEOFF, mavlink.MAV_CMD_NAV_VTOL_LAND, mavlink.MAV_CMD_CONDITION_GATE,
    mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT, mavlink.MAV_CMD_NAV_RALLY_POINT, mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
    mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE,
}) | _FENCE_POLYGONS | _FENCE_CIRCLES
# commands taken only in MAV_FRAME_MISSION
MISSION_FRAME_COMMANDS = frozenset({
    mavlink.MAV_CMD_DO_JUMP, mavlink.MAV_CMD_NAV_ROI, mavlink.MAV_CMD_DO_SET_ROI, mavlink.MAV_CMD_DO_WINCH,
    mavlink.MAV_CMD_DO_GRIPPER, mavlink.MAV_CMD_DO_CHANGE_SPEED, mavlink.MAV_CMD_DO_SET_HOME,
    mavlink.MAV_CMD_DO_LAND_START, mavlink.MAV_CMD_DO_TRIGGER_CONTROL, mavlink.MAV_CMD_DO_DIGICAM_CONTROL,
    mavlink.MAV_CMD_DO_MOUNT_CONFIGURE, mavlink.MAV_CMD_DO_MOUNT_CONTROL, mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
    mavlink.MAV_CMD_SET_CAMERA_FOCUS, mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, mavlink.MAV_CMD_IMAGE_START_CAPTURE,
    mavlink.MAV_CMD_IMAGE_STOP_CAPTURE, mavlink.MAV_CMD_VIDEO_START_CAPTURE, mavlink.MAV_CMD_VIDEO_STOP_CAPTURE,
    mavlink.MAV_CMD_DO_CONTROL_VIDEO, mavlink.MAV_CMD_DO_SET_CAM_TRIGG_DIST, mavlink.MAV_CMD_OBLIQUE_SURVEY,
    mavlink.MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL, mavlink.MAV_CMD_SET_CAMERA_MODE, mavlink.MAV_CMD_SET_CAMERA_SOURCE,
    mavlink.MAV_CMD_DO_VTOL_TRANSITION, mavlink.MAV_CMD_NAV_DELAY, mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH,
    mavlink.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET, mavlink.MAV_CMD_DO_SET_ROI_NONE, mavlink.MAV_CMD_CONDITION_DELAY,
    mavlink.MAV_CMD_CONDITION_DISTANCE, mavlink.MAV_CMD_DO_SET_ACTUATOR, mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE,
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
})
_ROI_COMMANDS = frozenset({mavlink.MAV_CMD_NAV_ROI, mavlink.MAV_CMD_DO_SET_ROI})
_NOT_IN_MISSION = _FENCE_POLYGONS | _FENCE_CIRCLES | {mavlink.MAV_CMD_NAV_RALLY_POINT}
RELATIVE_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
_LEGACY_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT})
_INT_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
# what a MISSION_REQUEST (not _INT) read-back answers in place of the stored _INT frames
LEGACY_FRAME = {mavlink.MAV_FRAME_GLOBAL_INT: mavlink.MAV_FRAME_GLOBAL,
                mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT}


def f32(value: float) -> float:
    """The nearest float32 (C's float); beyond its range, infinity."""
    try:
        return struct.unpack("<f", struct.pack("<f", value))[0]
    except OverflowError:
        return math.copysign(math.inf, value)


def stored(item: WireItem) -> WireItem:
    """What PX4 reads back for an accepted item: the station's model
    (`gcs.autopilots.px4_storage.stored_item`), which the comparison with PX4 SITL keeps true."""
    return stored_item(item)


def item_result(item: WireItem, *, int_mode: bool) -> int:
    """MAV_MISSION_RESULT of PX4's parse of one uploaded item (with the text "IGN MISSION_ITEM:
    Invalid item" when refused). Frames 5 and 6 count as global only in int mode, i.e. in a
    MISSION_ITEM_INT; terrain and local frames are UNSUPPORTED_FRAME; a command outside the
    frame's list UNSUPPORTED; an ROI mode PX4 does not know INVALID_PARAM1."""
    frame, cmd = item.frame, item.command
    if frame in _LEGACY_FRAMES or (int_mode and frame in _INT_FRAMES):
        if cmd not in GLOBAL_COMMANDS:
            return mavlink.MAV_MISSION_UNSUPPORTED
        if cmd in _ROI_COMMANDS and _trunc(item.param1) not in (mavlink.MAV_ROI_LOCATION, mavlink.MAV_ROI_NONE):
            return mavlink.MAV_MISSION_INVALID_PARAM1
        return mavlink.MAV_MISSION_ACCEPTED
    if frame == mavlink.MAV_FRAME_MISSION:
        if cmd not in MISSION_FRAME_COMMANDS:
            return mavlink.MAV_MISSION_UNSUPPORTED
        if cmd in _ROI_COMMANDS and _trunc(item.param1) not in (mavlink.MAV_ROI_NONE, mavlink.MAV_ROI_WPNEXT,
                                                               mavlink.MAV_ROI_WPINDEX):
            return mavlink.MAV_MISSION_INVALID_PARAM1
        return mavlink.MAV_MISSION_ACCEPTED
    return mavlink.MAV_MISSION_UNSUPPORTED_FRAME


def list_result(item: WireItem) -> int:
    """The check after a parsed item is written to its list (no text): a fence or rally point
    in the mission, or a polygon vertex whose count rounds below 3, is MAV_MISSION_ERROR."""
    if item.mission_type == MissionType.MISSION and item.command in _NOT_IN_MISSION:
        return mavlink.MAV_MISSION_ERROR
    if item.mission_type == MissionType.FENCE and item.command in _FENCE_POLYGONS \
            and vertex_count(item.param1) < 3:
        return mavlink.MAV_MISSION_ERROR
    return mavlink.MAV_MISSION_ACCEPTED


def vertex_count(param1: float) -> int:
    """(uint16_t)(param1 + 0.5f), as PX4 reads a polygon's vertex count."""
    return _trunc(f32(f32(param1) + 0.5)) & 0xFFFF


def _trunc(value: float) -> int:
    return math.trunc(value) if math.isfinite(value) else 0


def same_items(a: list[WireItem], b: list[WireItem]) -> bool:
    """Whether two uploads have the same CRC in PX4's sense (frame, command, autocontinue,
    params, x, y, z): an upload identical to the stored list changes nothing, not even the
    current item."""
    def key(it: WireItem) -> tuple:
        return (it.frame, it.command, it.autocontinue, f32(it.param1), f32(it.param2), f32(it.param3),
                f32(it.param4), it.x, it.y, f32(it.z))
    return len(a) == len(b) and all(_same(key(x), key(y)) for x, y in zip(a, b))


def _same(a: tuple, b: tuple) -> bool:
    return all(x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y)) for x, y in zip(a, b))


# ---- the navigator's feasibility check (§2, §13) ----------------------------------------------

_POSITION_COMMANDS = frozenset({
    mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LOITER_TIME,
    mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LOITER_TO_ALT,
    mavlink.MAV_CMD_NAV_VTOL_TAKEOFF, mavlink.MAV_CMD_NAV_VTOL_LAND,
})


@dataclass(frozen=True, slots=True)
class FenceArea:
    """One geofence polygon (vertices as (lat, lon) degrees) or circle (centre in local
    metres, radius), inclusion or exclusion, as PX4's navigator loads it."""

    inclusion: bool
    vertices_deg: tuple[tuple[float, float], ...] = ()
    centre_en: tuple[float, float] = (0.0, 0.0)
    radius_m: float = 0.0

    def contains(self, lat: float, lon: float, frame: LocalFrame) -> bool:
        """PX4's tests: PNPOLY on latitude and longitude, a circle strictly inside |radius|."""
        if not self.vertices_deg:
            x, y = frame.geodetic2en(lat, lon)
            return (x - self.centre_en[0]) ** 2 + (y - self.centre_en[1]) ** 2 < self.radius_m ** 2
        inside = False
        pts = self.vertices_deg
        for (lat_i, lon_i), (lat_j, lon_j) in zip(pts, pts[-1:] + pts[:-1]):
            if (lon_i >= lon) != (lon_j >= lon) and lat <= (lat_j - lat_i) * (lon - lon_i) / (lon_j - lon_i) + lat_i:
                inside = not inside
        return inside

    def allows(self, lat: float, lon: float, frame: LocalFrame) -> bool:
        return self.contains(lat, lon, frame) == self.inclusion


def fence_areas(fence: list[WireItem], frame: LocalFrame) -> list[FenceArea]:
    """The polygons and circles of a stored fence list, as `Geofence::_updateFence` groups
    them: a polygon is as many items as its first vertex's count; return points and other
    commands are skipped."""
    out: list[FenceArea] = []
    i = 0
    while i < len(fence):
        it = fence[i]
        if it.command in _FENCE_POLYGONS and vertex_count(it.param1) > 0:
            n = vertex_count(it.param1)
            run = fence[i:i + n]
            out.append(FenceArea(it.command == mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                                 vertices_deg=tuple((v.x / 1e7, v.y / 1e7) for v in run)))
            i += n
            continue
        if it.command in _FENCE_CIRCLES:
            out.append(FenceArea(it.command == mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
                                 centre_en=frame.geodetic2en(it.x / 1e7, it.y / 1e7), radius_m=f32(it.param1)))
        i += 1
    return out


def usable_areas(areas: list[FenceArea], home: tuple[float, float] | None, frame: LocalFrame
                 ) -> tuple[list[FenceArea], int]:
    """The areas PX4 keeps and how many it drops ("Geofence invalid, doesn't contain Home
    position" each): an area home does not satisfy is ignored (with no home yet, all kept)."""
    if home is None:
        return list(areas), 0
    kept = [a for a in areas if a.allows(*home, frame)]
    return kept, len(areas) - len(kept)


def first_geofence_violation(items: list[WireItem], areas: list[FenceArea], frame: LocalFrame) -> int | None:
    """The seq of the first mission item with a position that some area does not allow (in
    every inclusion, out of every exclusion); legs between items are not checked."""
    for it in items:
        if it.command in _POSITION_COMMANDS and it.frame != mavlink.MAV_FRAME_MISSION \
                and not all(a.allows(it.x / 1e7, it.y / 1e7, frame) for a in areas):
            return it.seq
    return None


def mission_problems(items: list[WireItem], home_en: tuple[float, float], frame: LocalFrame, *,
                     plane: bool, landed: bool, params: dict[str, float]) -> list[str]:
    """Why PX4's navigator finds the mission infeasible, in its words (its console; the
    station only sees "Mission start denied! No valid mission"); empty when it is valid.
    Copter: the take-off first, no landing first (landed), the first position within
    MIS_DIST_1WP of home. Plane: a landing when MIS_TKO_LAND_REQ asks for one, at most one
    DO_LAND_START, an approach above the landing point and no steeper than FW_LND_ANG."""
    if not items:
        return ["No valid mission"]
    problems: list[str] = []
    nav = [it for it in items if it.command in _POSITION_COMMANDS and it.frame != mavlink.MAV_FRAME_MISSION]
    takeoffs = [it for it in nav if it.command in (mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_VTOL_TAKEOFF)]
    if takeoffs and nav[0] is not takeoffs[0]:
        problems.append("Mission rejected: takeoff not first waypoint item")
    if landed and nav and nav[0].command in (mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_CMD_NAV_VTOL_LAND):
        problems.append("Mission rejected: starts with landing")
    limit = params.get("MIS_DIST_1WP", 900.0)
    if nav and limit > 0 and not takeoffs:
        dist = math.dist(home_en, frame.geodetic2en(nav[0].x / 1e7, nav[0].y / 1e7))
        if dist > limit:
            problems.append(f"First waypoint too far away: {dist:.0f}m, {limit:.0f} max")
    if plane:
        problems += _landing_problems(items, nav, frame, params)
    return problems


def _landing_problems(items: list[WireItem], nav: list[WireItem], frame: LocalFrame,
                      params: dict[str, float]) -> list[str]:
    lands = [it for it in nav if it.command == mavlink.MAV_CMD_NAV_LAND]
    if sum(it.command == mavlink.MAV_CMD_DO_LAND_START for it in items) > 1:
        return ["Mission rejected: more than one land start."]
    if not lands:
        return ["Mission rejected: Landing waypoint/pattern required."] if params.get("MIS_TKO_LAND_REQ") in (2, 4) \
            else []
    land = lands[0]
    before = [it for it in nav if it.seq < land.seq and it.command != mavlink.MAV_CMD_NAV_TAKEOFF]
    if not before:
        return []
    approach = before[-1]
    height = approach.z - land.z
    if height < 0:
        return ["Mission rejected: the approach waypoint must be above the landing point."]
    dist = math.dist(frame.geodetic2en(approach.x / 1e7, approach.y / 1e7),
                     frame.geodetic2en(land.x / 1e7, land.y / 1e7))
    limit = params.get("FW_LND_ANG", 5.0)
    if dist > 0 and round(math.degrees(math.atan2(height, dist)), 1) > limit:  # 30 m over 340 m (5.04°) passed
        return ["Mission rejected: the landing glide slope is steeper than the vehicle setting of "
                f"{limit:.1f} degrees."]
    return []


# ---- the SIH battery and PX4's estimate (§7) --------------------------------------------------

CELLS = 4
V_EMPTY, V_CHARGED, V_LOAD_DROP = 3.6, 4.05, 0.1  # per cell: BAT1_V_EMPTY, BAT1_V_CHARGED, BAT1_V_LOAD_DROP
VOLTAGE_TAU_S = 1.0  # PX4's battery filters the voltage it reports: 15.3 V to 16.2 V on disarm in ~3 s
# the SIH quad's thrust (VFR_HUD throttle, docs/energy.md): 0.48 hovering, 0.54 at 5 m/s, 0.69 at
# 9.8 m/s (its top speed: SIH_KDV drag at MPC_TILTMAX_AIR), 0.55-0.64 climbing 1.4-2.9 m/s,
# 0.40-0.45 descending; 0.5 spooling up
HOVER_THROTTLE, THROTTLE_PER_SPEED2, THROTTLE_PER_CLIMB, THROTTLE_PER_DESCENT = 0.48, 0.0022, 0.055, 0.07
SPOOL_THROTTLE = 0.5
MAX_SPEED_M_S = 9.8


def copter_throttle(speed_m_s: float, climb_m_s: float) -> float:
    """The SIH quad's thrust flying at a speed (m/s) and climb rate (m/s, negative down)."""
    per_climb = THROTTLE_PER_CLIMB if climb_m_s > 0 else THROTTLE_PER_DESCENT
    return min(1.0, max(0.3, HOVER_THROTTLE + THROTTLE_PER_SPEED2 * speed_m_s ** 2 + per_climb * climb_m_s))


def battery_voltage_v(charge: float) -> float:
    """SIH's pack voltage for its state of charge (0..1): 14.4 V empty, 16.2 V full."""
    return CELLS * (V_EMPTY + (V_CHARGED - V_EMPTY) * charge)


def battery_remaining(voltage_v: float, throttle: float) -> float:
    """PX4's estimate (0..1) from the cell voltage, compensated for the load by BAT1_V_LOAD_DROP
    times the thrust (SIH reports no current, so BAT1_R_INTERNAL is not used): 11 % above the
    charge while hovering (SIM_BAT_MIN_PCT 50 reads 61 %, 65 % cruising at 9.8 m/s)."""
    cell = voltage_v / CELLS + V_LOAD_DROP * throttle
    return min(1.0, max(0.0, (cell - V_EMPTY) / (V_CHARGED - V_EMPTY)))


def battery_level(remaining: float, params: dict[str, float]) -> int:
    """BATTERY_STATUS.charge_state for an estimate: OK, LOW, CRITICAL, EMERGENCY at BAT_LOW_THR,
    BAT_CRIT_THR, BAT_EMERGEN_THR."""
    if remaining <= params["BAT_EMERGEN_THR"]:
        return mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY
    if remaining <= params["BAT_CRIT_THR"]:
        return mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL
    if remaining <= params["BAT_LOW_THR"]:
        return mavlink.MAV_BATTERY_CHARGE_STATE_LOW
    return mavlink.MAV_BATTERY_CHARGE_STATE_OK


# ---- parameters -------------------------------------------------------------------------------

INT32, REAL32 = mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32


def default_params(vehicle_type: str, sysid: int) -> dict[str, tuple[float, int]]:
    """(value, MAV_PARAM_TYPE) of the parameters the profile acts on, PX4's defaults as the
    SITL's rcS leaves them (results/params_*.json); COM_DL_LOSS_T is 10 (rcS multiplies it by
    the speed-up, the simulator counts vehicle seconds)."""
    plane = vehicle_type == "plane"
    return {
        "MAV_SYS_ID": (sysid, INT32), "COM_ARMABLE": (1, INT32), "COM_DISARM_PRFLT": (10.0, REAL32),
        "COM_DISARM_LAND": (2.0, REAL32), "COM_LOW_BAT_ACT": (2, INT32), "COM_DL_LOSS_T": (10, INT32),
        "NAV_DLL_ACT": (0, INT32), "NAV_ACC_RAD": (2.0, REAL32), "MIS_TAKEOFF_ALT": (2.5, REAL32),
        "MIS_DIST_1WP": (900.0, REAL32), "MIS_TKO_LAND_REQ": (2 if plane else 0, INT32),
        "FW_LND_ANG": (5.0, REAL32), "MPC_XY_CRUISE": (5.0, REAL32), "MPC_XY_VEL_MAX": (12.0, REAL32),
        "MPC_LAND_SPEED": (0.7, REAL32), "RTL_RETURN_ALT": (30.0, REAL32), "RTL_DESCEND_ALT": (10.0, REAL32),
        "SIM_BAT_DRAIN": (60.0, REAL32), "SIM_BAT_MIN_PCT": (50.0, REAL32), "BAT_LOW_THR": (0.15, REAL32),
        "BAT_CRIT_THR": (0.07, REAL32), "BAT_EMERGEN_THR": (0.05, REAL32),
    }


def encode_param(value: float, param_type: int) -> float:
    """PARAM_VALUE's float for a value: PX4 sends INT32 parameters bytewise."""
    if param_type == INT32:
        return struct.unpack("<f", struct.pack("<i", int(value)))[0]
    return float(value)


def decode_param(raw: float, param_type: int) -> float:
    """A PARAM_SET value: INT32 parameters arrive bytewise."""
    if param_type == INT32:
        return float(struct.unpack("<i", struct.pack("<f", raw))[0])
    return raw
