"""The autopilots the station flies, and what differs between them.

`Autopilot` names the family a vehicle's HEARTBEAT reports. Everything that depends on it lives
here, one method per difference (docs/autopilots.md has the table), so the flight code asks
instead of branching: whether mission item 0 is home, what the autopilot keeps of an uploaded
item (`stored_item`, what a read-back is compared with), its flight modes, the telemetry to ask
for, when it is ready to arm, the mode to arm in and how a mission is started, and the mode
that holds a vehicle while its mission is replaced."""

from __future__ import annotations

import math
import struct
from dataclasses import replace
from enum import Enum

from gcs.autopilots import ardupilot_storage, modes, px4_storage
from gcs.autopilots.wire_item import WireItem
from gcs.links import mavlink

__all__ = ["Autopilot", "compare_items"]


class Autopilot(str, Enum):
    ARDUPILOT = "ardupilot"
    PX4 = "px4"
    GENERIC = "generic"

    @classmethod
    def from_heartbeat(cls, autopilot: int) -> Autopilot:
        """From HEARTBEAT.autopilot (MAV_AUTOPILOT)."""
        if autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA:
            return cls.ARDUPILOT
        if autopilot == mavlink.MAV_AUTOPILOT_PX4:
            return cls.PX4
        return cls.GENERIC

    def home_item(self, mission_type: int) -> bool:
        """Whether item 0 of this list is the home position."""
        return self is Autopilot.ARDUPILOT and mission_type == mavlink.MAV_MISSION_TYPE_MISSION

    def first_mission_seq(self) -> int:
        return 1 if self is Autopilot.ARDUPILOT else 0

    # ---- modes ---------------------------------------------------------------------------

    def mode_name(self, mav_type: int | None, custom_mode: int) -> str:
        if self is Autopilot.PX4:
            return modes.px4_mode_name(custom_mode)
        return modes.ardupilot_mode_name(mav_type, custom_mode)

    def set_mode_params(self, mav_type: int | None, name: str) -> tuple[float, float, float]:
        """MAV_CMD_DO_SET_MODE params 1-3 for a mode by name (AUTO, GUIDED, LOITER, RTL, LAND);
        ValueError when the vehicle has no such mode."""
        flag = float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
        if self is Autopilot.PX4:
            main, sub = modes.PX4[modes.PX4_ALIASES.get(name, name)]
            return flag, float(main), float(sub)
        table = modes.ardupilot_table(mav_type)
        if name not in table:
            raise ValueError(f"mode {name} is not available on this vehicle")
        return flag, float(table[name]), 0.0

    # ---- flying ----------------------------------------------------------------------------

    def streams_hz(self) -> dict[int, float]:
        """Telemetry to ask for with MAV_CMD_SET_MESSAGE_INTERVAL (rates in vehicle time).
        ArduCopter streams nothing until asked; readiness needs GPS_RAW_INT, HOME_POSITION and,
        on ArduPilot, EKF_STATUS_REPORT. PX4 refuses a rate for MISSION_CURRENT (it sends it at
        1 Hz anyway) and has no EKF_STATUS_REPORT."""
        streams = {mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 4.0, mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
                   mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0, mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
                   mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0, mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.5}
        if self is not Autopilot.PX4:
            streams[mavlink.MAVLINK_MSG_ID_MISSION_CURRENT] = 1.0
        if self is Autopilot.ARDUPILOT:
            streams[mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT] = 1.0
        return streams

    def optional_streams_hz(self) -> dict[int, float]:
        """Telemetry worth having but not needed (asked for, and quietly done without when
        refused): the wind estimate the return trigger prices a way home with, ArduPilot's WIND
        (where it comes from) or PX4's WIND_COV (its velocity), and ATTITUDE, from which a
        multicopter's lean shows a wind its autopilot does not estimate (`gcs.flight.lean_wind`)."""
        if self is Autopilot.ARDUPILOT:
            return {mavlink.MAVLINK_MSG_ID_WIND: 1.0, mavlink.MAVLINK_MSG_ID_ATTITUDE: 2.0}
        if self is Autopilot.PX4:
            return {mavlink.MAVLINK_MSG_ID_WIND_COV: 1.0, mavlink.MAVLINK_MSG_ID_ATTITUDE: 2.0}
        return {}

    def capacity_param(self) -> str | None:
        """The parameter holding the battery capacity (mAh) the autopilot counts its percentage
        with: ArduPilot's BATT_CAPACITY, PX4's BAT1_CAPACITY (-1 when not set)."""
        if self is Autopilot.ARDUPILOT:
            return "BATT_CAPACITY"
        return "BAT1_CAPACITY" if self is Autopilot.PX4 else None

    def readiness_signals(self) -> tuple[str, ...]:
        """What says the vehicle may be armed besides a 3-D fix, a home and a position: ArduPilot's
        EKF position flags ("ekf"), PX4's pre-arm bit in SYS_STATUS health ("prearm"), which PX4
        sets once its estimator and every check pass (GPS fix and home come long before)."""
        if self is Autopilot.ARDUPILOT:
            return ("ekf",)
        return ("prearm",) if self is Autopilot.PX4 else ()

    def prearm_bit_always_reported(self) -> bool:
        """Whether SYS_STATUS's pre-arm bit means something even when absent from `present`:
        PX4 sets it in `health` only; others flag it present when they report it."""
        return self is Autopilot.PX4

    def param_changes_before_arming(self, fixed_wing: bool, has_landing_sequence: bool) -> dict[str, float]:
        """Parameters a plan needs on board: ArduPlane refuses to arm with a DO_LAND_START and
        RTL_AUTOLAND 0; with 2 its RTL (the fallback, and its battery failsafe) flies the
        mission's landing sequence."""
        if self is Autopilot.ARDUPILOT and fixed_wing and has_landing_sequence:
            return {"RTL_AUTOLAND": 2.0}
        return {}

    def steers_by_reposition(self, fixed_wing: bool) -> bool:
        """Whether a flying vehicle is steered to a point with DO_REPOSITION rather than a
        streamed SET_POSITION_TARGET: ArduPlane ignores position targets, PX4 follows them only
        in OFFBOARD with an unbroken stream."""
        return self is Autopilot.PX4 or fixed_wing

    def replaces_items_as_they_arrive(self) -> bool:
        """Whether a refused upload leaves a half-replaced list (ArduPilot, measured) that must be
        cleared, rather than the old list (PX4 replaces atomically)."""
        return self is Autopilot.ARDUPILOT

    def arm_mode(self, fixed_wing: bool) -> str | None:
        """The mode to arm in: ArduCopter arms in GUIDED (AUTO is not armable) and is launched
        by MISSION_START; ArduPlane armed in AUTO takes off by itself. None: arm as it is."""
        if self is Autopilot.ARDUPILOT:
            return "AUTO" if fixed_wing else "GUIDED"
        return None

    def start_after_arming(self, fixed_wing: bool) -> bool:
        """Whether MISSION_START is needed once armed (not for a plane armed in AUTO)."""
        return not (self is Autopilot.ARDUPILOT and fixed_wing)

    def mission_start_params(self) -> tuple[float, float]:
        """MISSION_START param1, param2: ArduPilot accepts only (0, 0) and refuses anything
        else; (0, 0) is "the whole mission" for every autopilot. Where to start is set first
        with DO_SET_MISSION_CURRENT."""
        return 0.0, 0.0

    def hold_mode(self, fixed_wing: bool) -> str:
        """The mode that holds a flying vehicle while its mission is replaced: ArduCopter GUIDED
        (LOITER without RC descends), ArduPlane LOITER (circles), PX4 HOLD."""
        if self is Autopilot.ARDUPILOT:
            return "LOITER" if fixed_wing else "GUIDED"
        return "HOLD" if self is Autopilot.PX4 else "GUIDED"

    def command_altitude(self, above_home_m: float, home_amsl_m: float) -> tuple[int, float]:
        """(frame, z) for a command's altitude `above_home_m` (NAV_TAKEOFF param7, DO_REPOSITION):
        PX4 takes them above sea level whatever the frame says (measured: a relative 20 m in
        frame 6 made the copter descend to 20 m AMSL and land); ArduPilot honours the frame."""
        if self is Autopilot.PX4:
            return mavlink.MAV_FRAME_GLOBAL_INT, home_amsl_m + above_home_m
        return mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, above_home_m

    def restart_needs_current_item(self) -> bool:
        """Whether a mission replaced in flight must be pointed at its first item before it is
        started: ArduPilot resumes at the old index (DO_SET_MISSION_CURRENT first); PX4 starts
        a new list at its first item on MISSION_START(0, 0) from HOLD and has no such command."""
        return self is not Autopilot.PX4

    def adapt_item(self, item: WireItem) -> WireItem:
        """An item as this autopilot takes it: PX4 accepts commands without a location (DO_*,
        RETURN_TO_LAUNCH) only in MAV_FRAME_MISSION, and refuses terrain frames (ValueError)."""
        if self is not Autopilot.PX4:
            return item
        if item.frame in (mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT):
            raise ValueError("PX4 refuses terrain-following frames: plan without --terrain-follow for this vehicle")
        if item.command in px4_storage.MISSION_FRAME_COMMANDS:
            return replace(item, frame=mavlink.MAV_FRAME_MISSION)
        return item

    def stored_item(self, item: WireItem, *, fixed_wing: bool = False) -> WireItem:
        """What this autopilot returns on read-back for `item` as sent."""
        if self is Autopilot.ARDUPILOT:
            return ardupilot_storage.stored_item(item, fixed_wing=fixed_wing)
        if self is Autopilot.PX4:
            return px4_storage.stored_item(item)
        p = [_f32(v) for v in (item.param1, item.param2, item.param3, item.param4)]
        return replace(item, param1=p[0], param2=p[1], param3=p[2], param4=p[3], z=_f32(item.z))

    def tolerances(self, item: WireItem) -> tuple[float, float]:
        """(altitude m, params) allowed between `stored_item` and a read-back: float32 where the
        model was measured, ArduPilot's whole centimetres and whole-number params where not."""
        if self is Autopilot.ARDUPILOT and not ardupilot_storage.known_command(item.command, item.mission_type):
            return 0.011, 1.0
        return 1e-3, 1e-6


def _f32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", value))[0]


def compare_items(sent: list[WireItem], got: list[WireItem], autopilot: Autopilot, *,
                  fixed_wing: bool = False) -> list[str]:
    """Differences between what the autopilot should hold after `sent` was uploaded and what a
    read-back returned (`got`); empty when they agree. Item 0 of an ArduPilot mission (home) is
    not compared. Items the model covers must agree to float32; others are allowed the rounding
    of `Autopilot.tolerances`."""
    if len(sent) != len(got):
        return [f"{len(got)} items read back, {len(sent)} sent"]
    problems = []
    for a, b in zip(sent, got):
        if a.seq == 0 and autopilot.home_item(a.mission_type):
            continue
        expected = autopilot.stored_item(a, fixed_wing=fixed_wing)
        alt_tol, param_tol = autopilot.tolerances(a)
        if (expected.command, expected.frame) != (b.command, b.frame):
            problems.append(f"item {a.seq}: command/frame {b.command}/{b.frame}, expected {expected.command}/"
                            f"{expected.frame}")
            continue
        if expected.x != b.x or expected.y != b.y:
            problems.append(f"item {a.seq}: position {b.x / 1e7:.7f},{b.y / 1e7:.7f}, sent "
                            f"{a.x / 1e7:.7f},{a.y / 1e7:.7f}")
        if not _close(expected.z, b.z, alt_tol):
            problems.append(f"item {a.seq}: altitude {b.z:g}, expected {expected.z:g} (sent {a.z:g})")
        for name in ("param1", "param2", "param3", "param4"):
            want, have = getattr(expected, name), getattr(b, name)
            if not _close(want, have, param_tol):
                problems.append(f"item {a.seq}: {name} {have:g}, expected {want:g} (sent {getattr(a, name):g})")
        if a.mission_type == mavlink.MAV_MISSION_TYPE_MISSION and expected.autocontinue != b.autocontinue:
            problems.append(f"item {a.seq}: autocontinue {b.autocontinue}, expected {expected.autocontinue}")
    return problems


def _close(a: float, b: float, tol: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= max(tol, 1e-6 * abs(a))
