"""The `px4` profile: one simulated PX4 v1.15.3 (SIH SITL, copter; the plane only where
measured) as the research report `px4` (/work/research/px4/README.md; "§4" below names its
section) found it. docs/sim.md lists each behaviour.

- start-up (§3): GPS and HOME_POSITION at once, the position estimate at 34.6 vehicle seconds,
  the SYS_STATUS pre-arm bit (in `health` only) at 37.1; arming before: TEMPORARILY_REJECTED;
- the mission manager of `sim.autopilot.px4_mission` (§1, §2) and the navigator's current item: 65535
  until the first start or until the navigator runs, the old index kept (clamped) when a new
  list arrives (§5 R2, R3);
- commands (§4, §5, §8, §9): MISSION_START(first, _) arms and flies from HOLD, DENIED for an
  infeasible mission; DO_SET_MISSION_CURRENT UNSUPPORTED; NAV_TAKEOFF and DO_REPOSITION
  altitudes above sea level whatever the frame; NAV_LAND where it is; RTL climbing to
  RTL_RETURN_ALT above the nearest of home and the rally points; OFFBOARD from a setpoint
  stream, POSCTL (sinking, no RC) when it stops; disarming refused in flight;
- auto-disarm (§4, §8): 10.96 s armed on the ground, at once after a mission's landing, 3.5 s
  after one in LAND or RTL; the mode reads MISSION again after a flight that flew one;
- the SIH battery (§7), draining only while armed at 100 / SIM_BAT_DRAIN % per second down to
  SIM_BAT_MIN_PCT, its voltage-based estimate and COM_LOW_BAT_ACT's failsafes;
- GCS link loss (§8): NAV_DLL_ACT after COM_DL_LOSS_T; parameters with PX4's names and
  types (INT32 bytewise); STATUSTEXTs ending in a tab, over 50 characters in chunks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import MissionType, WireItem
from sim.autopilot import px4, telemetry
from sim.autopilot.failsafe import FailsafeLevel, failsafe_to_trigger
from sim.autopilot.guidance import climb_point, hold_or
from sim.autopilot.mission_protocol import ProtocolConfig
from sim.autopilot.modes import Mode, mode_table
from sim.autopilot.px4_mission import Px4MissionProtocol, px4_texts
from sim.autopilot.vehicle import MAVMessage, SimVehicle, VehicleConfig, param_name
from sim.physics.airframe import Goal, HomePose
from sim.physics.battery import SihBattery

ACCEPTED, REJECTED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED
DENIED, UNSUPPORTED, FAILED = mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_UNSUPPORTED, mavlink.MAV_RESULT_FAILED
INFO, CRITICAL = mavlink.MAV_SEVERITY_INFO, mavlink.MAV_SEVERITY_CRITICAL

_SPOOL_S = {"copter": 4.5, "plane": 2.0}  # from the start to leaving the ground (§4: 1 m at 5.3 s)
_PREFLIGHT_DISARM_EXTRA_S = 0.96  # COM_DISARM_PRFLT 10 disarmed after 10.96 s (§8)
_LAND_DISARM_S = 3.5  # "Disarmed by landing" after a landing in LAND or RTL (§4, §6)
_LAND_SLOW_BELOW_M = 10.0  # MPC_LAND_SPEED below this height (§6: 0.64 m/s over the last 10 m)
_FAILSAFE_HOLD_S = 5.0  # "entering Hold for 5 seconds" (§7), and NAV_DLL_ACT's hold (§8)
_OFFBOARD_LOSS_S = 3.5  # setpoint stream gone: failsafe to POSCTL (§9)
_OFFBOARD_FRESH_S = 1.0  # OFFBOARD needs a setpoint this recent
_POSCTL_SINK_M_S = 0.75  # POSCTL without RC: 19 m to 7 m in 16 s (§9)
_FRAME_TEXT_S = 2.0  # "RTL: unsupported MAV_FRAME" while armed with a rally point in frame 5/6 (§6)
# the navigator takes up a new list this long after it arrives (§5 R4: MISSION_CURRENT 0.57 s
# after a MISSION_START that followed an upload; after an upload on the ground over 1 s); a
# command that needs the mission takes it up at once
_NAVIGATOR_TAKE_UP_S = 0.5
_MODE_NAMES = {Mode.AUTO: "Mission", Mode.RTL: "Return", Mode.LAND: "Land", Mode.LOITER: "Hold",
               Mode.TAKEOFF: "Takeoff", Mode.GUIDED: "Offboard", Mode.POSCTL: "Position", Mode.MANUAL: "Manual"}
_LEVELS = {mavlink.MAV_BATTERY_CHARGE_STATE_OK: FailsafeLevel.NONE,
           mavlink.MAV_BATTERY_CHARGE_STATE_LOW: FailsafeLevel.LOW,
           mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL: FailsafeLevel.CRITICAL,
           mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY: FailsafeLevel.EMERGENCY}


@dataclass(slots=True)
class _Rtl:
    """A return in progress: to `dest_en` at `return_alt_m`, down to RTL_DESCEND_ALT above
    `dest_alt_m`, then land; `broken`: 5 or 6, a rally point in that frame (PX4 cannot)."""

    dest_en: tuple[float, float]
    dest_alt_m: float
    return_alt_m: float
    phase: str = "climb"
    broken: int = 0


class Px4Vehicle(SimVehicle):
    """The px4 profile's vehicle (`sim.autopilot.profiles.new_vehicle` makes it for a config with
    `profile="px4"`)."""

    PROFILE = "px4"
    HANDLERS = {kind: name for kind, name in SimVehicle.HANDLERS.items() if kind != "REQUEST_DATA_STREAM"}

    def __init__(self, sysid: int, home: HomePose, config: VehicleConfig | None = None, **kwargs) -> None:
        super().__init__(sysid, home, config, **kwargs)
        self.mission = Px4MissionProtocol(
            ProtocolConfig(home_item=False, capacity=dict(px4.CAPACITY)), lambda: self.reported_seq, self._next_text_id)
        self._mission_version = self.mission.versions[MissionType.MISSION]
        self._fence_version = self.mission.versions[MissionType.FENCE]
        self.home_set = False  # HOME_POSITION at `home_s`
        self.mode = Mode.LOITER  # PX4 boots in Hold
        self.seq_unset = False  # MISSION_CURRENT 65535: an upload flagged no current item
        self.navigator_running = False
        self._text_id = 0
        self._start_on_arm = False  # a MISSION_START whose arming was refused: the next arm starts
        self._flew_mission = False
        self._disarm_reason = ""
        self._mode_after_disarm: Mode | None = None
        self._after_hold: tuple[float, Mode, str] | None = None  # a failsafe's hold: when, then what, its text
        self._heard_s: float | None = None
        self._link_lost = False
        self._setpoint: tuple[tuple[float, float], float] | None = None
        self._setpoint_s: float | None = None
        self._rtl: _Rtl | None = None
        self._new_lists: tuple[bool, bool] = (False, False)  # mission, fence: not yet taken up by the navigator
        self._new_lists_s = 0.0
        self._land_reported: int | None = None
        self._frame_text_s = 0.0
        self._dt_s = 0.0
        self._voltage_v = px4.battery_voltage_v(1.0)

    def _new_battery(self) -> SihBattery:
        return SihBattery()

    def _default_params(self) -> dict[str, float]:
        defaults = px4.default_params(self.config.vehicle_type, self.sysid)
        cfg = self.config
        if self.config.vehicle_type == "copter":
            defaults["MPC_XY_CRUISE"] = (cfg.cruise_speed_m_s, px4.REAL32)
        defaults["NAV_ACC_RAD"] = (cfg.acceptance_radius_m, px4.REAL32)
        if cfg.battery.endurance_s is not None:  # a pack that lasts that long, down to empty
            defaults["SIM_BAT_DRAIN"] = (cfg.battery.endurance_s, px4.REAL32)
            defaults["SIM_BAT_MIN_PCT"] = (0.0, px4.REAL32)
        defaults["RTL_RETURN_ALT"] = (cfg.rtl_alt_m, px4.REAL32)
        self.param_types = {name: kind for name, (_, kind) in defaults.items()}
        return {name: float(value) for name, (value, _) in defaults.items()}

    def started_at_speedup(self, speedup: float) -> None:
        """SITL's rcS multiplies COM_DL_LOSS_T by the speed-up, so the link-loss timeout stays
        the same in real time (§8)."""
        self.params["COM_DL_LOSS_T"] = float(round(10 * speedup))

    # ---- state ----------------------------------------------------------------------------

    @property
    def gps_fixed(self) -> bool:
        return self.time_s >= self.boot.gps_fix_s

    @property
    def position_known(self) -> bool:
        return self.time_s >= self.boot.position_s

    @property
    def prearm_ok(self) -> bool:
        """SYS_STATUS health's pre-arm bit: ready, and COM_ARMABLE not 0."""
        return self.time_s >= self.boot.prearm_s and self.params["COM_ARMABLE"] != 0

    @property
    def reported_seq(self) -> int:
        """The current item MISSION_CURRENT and read-backs report (-1: none)."""
        return -1 if self.seq_unset else self.mission_seq

    @property
    def mission_total(self) -> int:
        return len(self.mission.items())

    @property
    def throttle(self) -> float:
        if not self.armed:
            return 0.0
        if self.landed:
            return px4.SPOOL_THROTTLE if self._lift_at_s is not None else 0.0
        if not self.copter:
            return px4.HOVER_THROTTLE
        kin = self.airframe.kin
        return px4.copter_throttle(kin.speed_m_s, kin.climb_m_s)

    @property
    def battery_voltage_v(self) -> float:
        """The voltage PX4 reports: SIH's, through PX4's filter."""
        return self._voltage_v

    @property
    def battery_pct(self) -> float:
        return 100.0 * px4.battery_remaining(self.battery_voltage_v, self.throttle)

    @property
    def charge_state(self) -> int:
        return px4.battery_level(self.battery_pct / 100.0, self.params)

    def mission_problems(self) -> list[str]:
        """Why the navigator would not fly the stored mission (empty: it would)."""
        problems = px4.mission_problems(self.mission.items(), self.home_en, self.frame, plane=not self.copter,
                                        landed=self.landed, params=self.params)
        seq = px4.first_geofence_violation(self.mission.items(), self._fence()[0], self.frame)
        return problems + ([] if seq is None else [f"Geofence violation for waypoint {seq + 1}"])

    def _fence(self) -> tuple[list[px4.FenceArea], int]:
        """The geofence's areas PX4 keeps, and how many it dropped for leaving out home."""
        areas = px4.fence_areas(self.mission.items(MissionType.FENCE), self.frame)
        home = (self.home.lat_deg, self.home.lon_deg) if self.home_set else None
        return px4.usable_areas(areas, home, self.frame)

    # ---- the Python API ---------------------------------------------------------------------

    def fail_battery(self) -> None:
        self.airframe.battery.fail()

    def set_drain_multiplier(self, k: float) -> None:
        """The SIH drain times k (a simulator extra; PX4's own knob is SIM_BAT_DRAIN)."""
        self.airframe.battery.drain_multiplier = k

    def load_mission(self, items: list[WireItem]) -> None:
        self.mission.replace(items)
        self._check_new_lists()
        self._navigator_cycle()

    def statustext(self, text: str, severity: int = INFO) -> None:
        self._pending += px4_texts(text, severity, self._next_text_id())

    def _next_text_id(self) -> int:
        """STATUSTEXT ids count from 0, one per text, wrapping as PX4's uint8 does."""
        text_id = self._text_id
        self._text_id = (text_id + 1) % 256
        return text_id

    # ---- messages ---------------------------------------------------------------------------

    def handle(self, msg: MAVMessage, wall_s: float) -> list[MAVMessage]:
        """Answer one message; the mission manager runs on vehicle time (SITL's lockstep)."""
        kind = msg.get_type()
        if getattr(msg, "target_system", None) not in (None, 0, self.sysid):
            return []
        if getattr(msg, "target_component", 0) not in (0, mavlink.MAV_COMP_ID_AUTOPILOT1):
            return []
        self._heard()
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind.startswith("MISSION_") and kind != "MISSION_SET_CURRENT":
            out = self.mission.handle(msg, self.time_s)
            self._check_new_lists()
            return out
        handler = self.HANDLERS.get(kind)
        return getattr(self, handler)(msg, sender) if handler else []

    def poll(self, wall_s: float) -> list[MAVMessage]:
        return self.mission.poll(self.time_s)

    def _heard(self) -> None:
        self._heard_s = self.time_s
        if self._link_lost:
            self._link_lost = False
            self.statustext("GCS connection regained")

    def _check_new_lists(self) -> None:
        """New lists reach the navigator `_NAVIGATOR_TAKE_UP_S` later (a read-back right after
        the ACK still shows no current item)."""
        versions = self.mission.versions
        mission_new = versions[MissionType.MISSION] != self._mission_version
        fence_new = versions[MissionType.FENCE] != self._fence_version
        self._mission_version, self._fence_version = versions[MissionType.MISSION], versions[MissionType.FENCE]
        if mission_new:
            self._take_new_mission()
        if mission_new or fence_new:
            self._new_lists = (self._new_lists[0] or mission_new, self._new_lists[1] or fence_new)
            self._new_lists_s = self.time_s

    def _take_new_mission(self) -> None:
        """The mission's current item when a new list arrives: the one uploaded as current,
        else the old index (clamped: a vehicle flying it goes on there, §5 R2, R3), which
        MISSION_CURRENT and read-backs show only once the navigator has taken the list up
        (65535 until then, §1)."""
        n = len(self.mission.items())
        flagged = self.mission.uploaded_current[MissionType.MISSION]
        self.mission_complete = False
        self._hold_until_s = None
        self._nav_item = None
        self._land_reported = None
        self._jumps_done.clear()
        if n == 0 or flagged >= 0:
            self.mission_seq, self.seq_unset = max(flagged, 0), False
        else:
            self.mission_seq, self.seq_unset = min(self.mission_seq, n - 1), True

    def _navigator_cycle(self, *, now: bool = True) -> None:
        """The running navigator takes up new lists: at once for a command, else once they
        are `_NAVIGATOR_TAKE_UP_S` old. It publishes the current item, drops fence areas
        that leave out home and checks the mission against the rest."""
        if not self.navigator_running or not any(self._new_lists) \
                or (not now and self.time_s - self._new_lists_s < _NAVIGATOR_TAKE_UP_S):
            return
        mission_new, fence_new = self._new_lists
        self._new_lists = (False, False)
        if mission_new and self.seq_unset:
            self.seq_unset = False
            self._pending.append(telemetry.mission_current(self))
        if fence_new and self.home_set:
            for _ in range(self._fence()[1]):
                self.statustext("Geofence invalid, doesn't contain Home position", CRITICAL)
        self._geofence_texts()

    def _geofence_texts(self) -> None:
        """The feasibility check's one text: the first item outside the fence."""
        seq = px4.first_geofence_violation(self.mission.items(), self._fence()[0], self.frame)
        if seq is not None:
            self.statustext(f"Geofence violation for waypoint {seq + 1}", CRITICAL)

    def _on_command(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        """PX4 reads a command's altitude above sea level, also a COMMAND_INT's in a relative
        frame (§9)."""
        p = (msg.param1, msg.param2, msg.param3, msg.param4)
        command_int = msg.get_type() == "COMMAND_INT"
        lat, lon = (msg.x / 1e7, msg.y / 1e7) if command_int else (msg.param5, msg.param6)
        alt_amsl = msg.z if command_int else msg.param7
        result, extra = self._px4_command(msg.command, p, lat, lon, alt_amsl, command_int)
        return [mavlink.MAVLink_command_ack_message(msg.command, result, 0, 0, sender[0], sender[1]), *extra]

    def _px4_command(self, cmd: int, p: tuple[float, ...], lat: float, lon: float, alt_amsl: float,
                     command_int: bool) -> tuple[int, list[MAVMessage]]:
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            return self._takeoff(alt_amsl), []
        if cmd == mavlink.MAV_CMD_DO_REPOSITION:
            return self._reposition_amsl(p, lat, lon, alt_amsl, command_int), []
        if cmd == mavlink.MAV_CMD_NAV_LAND:
            result = self._set_mode(Mode.LAND)
            if result == ACCEPTED:
                self.statustext("Landing at current position")  # param5, param6 are not used (§9)
            return result, []
        if cmd in (mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, mavlink.MAV_CMD_DO_LAND_START):
            return UNSUPPORTED, []
        if cmd == mavlink.MAV_CMD_GET_MESSAGE_INTERVAL:
            return ACCEPTED, []  # no MESSAGE_INTERVAL follows (§3)
        if cmd == mavlink.MAV_CMD_REQUEST_MESSAGE and not self._can_request(int(p[0])):
            return DENIED, []
        return self._command(cmd, p, lat, lon, alt_amsl, mavlink.MAV_FRAME_GLOBAL)

    def _set_interval(self, msg_id: int, interval_us: float) -> int:
        if msg_id in px4.NOT_SETTABLE or not telemetry.known(msg_id, self):
            return FAILED
        return super()._set_interval(msg_id, interval_us)

    def _on_position_target(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        """A setpoint is kept in any mode and flown only in OFFBOARD (§9)."""
        if msg.type_mask & 0b111 == 0b111:
            return []
        target = self.frame.geodetic2en(msg.lat_int / 1e7, msg.lon_int / 1e7)
        self._setpoint = (target, self._alt_rel(msg.alt, msg.coordinate_frame))
        self._setpoint_s = self.time_s
        if self.mode == Mode.GUIDED:
            self._target_en, self._target_alt_m = self._setpoint
        return []

    def _on_mission_set_current(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        self._navigator_cycle()
        if self.mission.busy:
            self.statustext("WPM: IGN WP CURR CMD: Busy", CRITICAL)
        elif not self._set_seq(msg.seq):
            self.statustext("WPM: WP CURR CMD: Not in list", CRITICAL)
        return []

    def _on_param_set(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        name = param_name(msg.param_id)
        if name not in self.params:
            return []
        value = px4.decode_param(msg.param_value, msg.param_type)
        if self.param_types[name] == px4.INT32:
            value = float(round(value))
        if name == "COM_ARMABLE" and value == 0 and self.params[name] != 0:
            self.statustext("Preflight Fail: Vehicle is in safety configuration", CRITICAL)
        self.params[name] = value
        return [self._param_value(name)]

    def _param_value(self, name: str) -> MAVMessage:
        names = list(self.params)
        kind = self.param_types[name]
        return mavlink.MAVLink_param_value_message(name.encode(), px4.encode_param(self.params[name], kind), kind,
                                                   len(names), names.index(name))

    # ---- arming and modes -------------------------------------------------------------------

    def _arm(self, arm: bool, force: bool) -> int:
        self._navigator_cycle()
        if not arm:
            if not self.landed and not force:
                self.statustext("Disarming denied: not landed", CRITICAL)
                return REJECTED
            self._disarm("Disarmed by external command")
            return ACCEPTED
        if self.armed:
            return ACCEPTED
        if not force and not self._armable():
            self.statustext("Arming denied: Resolve system health failures first", CRITICAL)
            return REJECTED
        self._do_arm("Armed by external command")
        return ACCEPTED

    def _armable(self) -> bool:
        return self.prearm_ok and not (self.mode == Mode.AUTO and self.mission_problems())

    def _do_arm(self, text: str) -> None:
        self.armed = True
        self.statustext(text)
        self.failsafe = FailsafeLevel.NONE
        self._flew_mission = False
        if self.landed:
            lat, lon = self.airframe.lat_lon_deg
            self._set_home(lat, lon, self.home.alt_m)  # home is where it arms (§3)
            if self.params["COM_DISARM_PRFLT"] > 0:
                self._disarm_at_s = self.time_s + self.params["COM_DISARM_PRFLT"] + _PREFLIGHT_DISARM_EXTRA_S
                self._disarm_reason = "Disarmed by auto preflight disarming"
        if self._start_on_arm or self.mode == Mode.AUTO:
            self._start_on_arm = False
            self.mode = Mode.LOITER
            self._enter(Mode.AUTO)

    def _disarm(self, reason: str = "") -> None:
        if self.armed and reason:
            self.statustext(reason)
        self._clear_flight()
        self._after_hold = None
        self._rtl = None
        self.failsafe = FailsafeLevel.NONE
        self.airframe.battery.refill()  # SIH's battery is full again once disarmed (§7)
        if self._mode_after_disarm is not None:
            self.mode, self._mode_after_disarm = self._mode_after_disarm, None

    def _set_mode(self, mode: Mode | None) -> int:
        self._navigator_cycle()
        if mode is None or mode not in mode_table(self.config.profile, self.config.vehicle_type):
            return self._mode_refused()
        if self._unavailable(mode):
            self.statustext(f"Switching to {_MODE_NAMES[mode]} is currently not available", CRITICAL)
            return REJECTED
        self._start_on_arm = False
        if mode == Mode.RTL:
            self.statustext("Returning to launch")
        self._enter(mode)
        return ACCEPTED

    def _unavailable(self, mode: Mode) -> bool:
        if mode in (Mode.MANUAL, Mode.POSCTL):
            return False
        if mode == Mode.GUIDED:
            return self._setpoint_s is None or self.time_s - self._setpoint_s > _OFFBOARD_FRESH_S
        if not (self.navigator_running and self.home_set):
            return True
        return mode == Mode.AUTO and bool(self.mission_problems())

    def _enter(self, mode: Mode) -> None:
        """Switch to an available mode."""
        was = self.mode
        self.mode = mode
        self.landing = False
        self._hold_until_s = None
        self._after_hold = None
        self._rtl = None
        self._speed_m_s = None
        here = self.airframe.position_en
        if mode in (Mode.LOITER, Mode.GUIDED):
            self._target_en, self._target_alt_m = here, self.airframe.kin.alt_m
            if mode == Mode.GUIDED and self._setpoint is not None:
                self._target_en, self._target_alt_m = self._setpoint
                self._speed_m_s = self.params["MPC_XY_VEL_MAX"]
        elif mode == Mode.RTL:
            self._start_rtl()
        elif mode == Mode.TAKEOFF:
            self._takeoff_alt_m = self.params["MIS_TAKEOFF_ALT"]
        elif mode == Mode.AUTO and (was != Mode.AUTO or self.mission_complete):
            self._start_or_resume()
            if self.armed:
                self._executing()
        if mode != Mode.TAKEOFF:
            self._takeoff_alt_m = None

    def _executing(self) -> None:
        self._flew_mission = True
        self.statustext("Executing Mission")
        items = self.mission.items()
        item = items[self.mission_seq] if self.mission_seq < len(items) else None
        if self.landed and item is not None and item.command == mavlink.MAV_CMD_NAV_TAKEOFF:
            self.statustext(f"Climb to {self._alt_rel(item.z, item.frame):.1f} meters above home")

    def _start_or_resume(self) -> None:
        if self.seq_unset:
            self.mission_seq, self.seq_unset = 0, False
        super()._start_or_resume()

    def _restart_mission(self) -> None:
        super()._restart_mission()
        self.seq_unset = False
        self._land_reported = None

    def _set_seq(self, seq: int) -> bool:
        if not super()._set_seq(seq):
            return False
        self.seq_unset = False
        self._land_reported = None
        return True

    def _mission_start(self, p: tuple[float, ...]) -> int:
        """MISSION_START(first, _): DENIED with "Mission start denied! No valid mission" for an
        infeasible mission, DENIED without a text for first outside -1..count-1; else from
        `first` (-1: where it is), arming first ("Armed by mission start") (§2, §4)."""
        self._navigator_cycle()
        if self.mission_problems():
            self.statustext("Mission start denied! No valid mission", CRITICAL)
            return DENIED
        first = p[0]
        if math.isnan(first) or not -1 <= first < len(self.mission.items()):
            return DENIED
        if first >= 0:
            self._set_seq(int(first))
        if not self.armed:
            if not self.prearm_ok:
                self.statustext("Arming denied: Resolve system health failures first", CRITICAL)
                self.statustext("Switching to Mission is currently not available", CRITICAL)
                self._start_on_arm = True
                return REJECTED
            self._start_on_arm = True
            self._do_arm("Armed by mission start")
            return ACCEPTED
        if self.mode == Mode.AUTO:
            self._executing()
        else:
            self._enter(Mode.AUTO)
        return ACCEPTED

    def _takeoff(self, alt_amsl: float) -> int:
        """NAV_TAKEOFF: param7 above sea level, NaN for MIS_TAKEOFF_ALT; a height below the
        vehicle's is taken without effect (§9)."""
        if not self.armed:
            return REJECTED
        if math.isnan(alt_amsl):
            height = self.params["MIS_TAKEOFF_ALT"]
            self.statustext(f"Using default takeoff altitude: {height:.1f} m")
        else:
            height = alt_amsl - self.home.alt_m
        if height <= self.airframe.kin.alt_m:
            self.statustext("Already higher than takeoff altitude", CRITICAL)
            return ACCEPTED
        self._enter(Mode.TAKEOFF)
        self._takeoff_alt_m = height
        return ACCEPTED

    def _reposition_amsl(self, p: tuple[float, ...], lat: float, lon: float, alt_amsl: float, command_int: bool
                         ) -> int:
        """DO_REPOSITION into Hold: z above sea level (NaN: this altitude); a point below the
        ground is descended to where the vehicle is, and it lands. A COMMAND_INT without
        CHANGE_MODE is answered UNSUPPORTED and flown all the same (§9)."""
        if not self.armed or self.landed:
            return REJECTED
        result = ACCEPTED
        if command_int and not int(p[1]) & mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE:
            result = UNSUPPORTED
        if self.mode != Mode.LOITER:
            self._enter(Mode.LOITER)
        if not (math.isnan(lat) or math.isnan(lon)):
            self._target_en = self.frame.geodetic2en(lat, lon)
        if not math.isnan(alt_amsl):
            self._target_alt_m = alt_amsl - self.home.alt_m
            if self._target_alt_m <= 0:
                self._target_en = self.airframe.position_en
        self._speed_m_s = p[0] if p[0] > 0 else None
        return result

    # ---- guidance: RTL (§6) and the goals of `sim.autopilot.guidance` as PX4 flies them ------

    def _start_rtl(self) -> None:
        here = self.airframe.position_en
        rally = self.mission.items(MissionType.RALLY)
        frames = self.mission.sent_frames[MissionType.RALLY]
        options = [(self.home_en, 0.0, 0)]
        for item, frame in zip(rally, frames, strict=True):
            alt = item.z - self.home.alt_m if frame == mavlink.MAV_FRAME_GLOBAL else item.z
            broken = frame if frame in (mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT) else 0
            options.append((self.frame.geodetic2en(item.x / 1e7, item.y / 1e7), alt, broken))
        dest_en, dest_alt, broken = min(options, key=lambda o: math.dist(o[0], here))
        ret = max(self.airframe.kin.alt_m, dest_alt + self.params["RTL_RETURN_ALT"])
        self._rtl = _Rtl(dest_en, dest_alt, ret, broken=broken)
        self._rtl_alt_m = ret
        amsl = self.home.alt_m + self.airframe.kin.alt_m
        if broken == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT:
            self.statustext("RTL: start return at -2147483648 m (0 m above destination)")
        elif broken:
            self.statustext(f"RTL: start return at {amsl:.0f} m ({amsl:.0f} m above destination)")
        else:
            self.statustext(f"RTL: start return at {self.home.alt_m + ret:.0f} m ({ret - dest_alt:.0f} m above "
                            "destination)")

    def _rtl_goal(self) -> Goal:
        r = self._rtl
        if r is None or not self.copter:
            return super()._rtl_goal()
        here = self.airframe.position_en
        if r.broken == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT:
            return Goal(None, self.airframe.kin.alt_m + 100.0)  # climbs without end (§6 T3)
        if r.broken:
            far = 10_000.0  # flies off at its altitude (§6 T6)
            heading = self.airframe.kin.heading_rad
            return Goal((here[0] + far * math.sin(heading), here[1] + far * math.cos(heading)), self.airframe.kin.alt_m)
        if r.phase == "climb":
            if self.airframe.kin.alt_m < r.return_alt_m - 0.5:
                return Goal(None, r.return_alt_m)
            r.phase = "return"
        if r.phase == "return":
            if math.dist(here, r.dest_en) > self.config.acceptance_radius_m:
                return Goal(r.dest_en, r.return_alt_m)
            r.phase = "descend"
        if r.phase == "descend":
            low = r.dest_alt_m + self.params["RTL_DESCEND_ALT"]
            if self.airframe.kin.alt_m > low + 0.5:
                return Goal(r.dest_en, low)
            r.phase = "land"
            self.statustext("RTL: land at destination")
        return Goal(None, -1.0, landing=True)

    def _nav_goal(self, item: WireItem) -> Goal:
        """PX4 reports a NAV_LAND reached over its point, before it descends (§4); a mission's
        NAV_RETURN_TO_LAUNCH flies PX4's RTL."""
        cmd = item.command
        if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH and self.copter:
            if self._rtl is None:
                self._start_rtl()
            return self._rtl_goal()
        if cmd == mavlink.MAV_CMD_NAV_LAND and self.copter:
            target = self._item_en(item)
            here = self.airframe.position_en
            if self.landing or math.dist(target, here) <= self._radius(item):
                if self._land_reported != item.seq:
                    self._land_reported = item.seq
                    self._report_reached(item.seq)
                return Goal(target, -1.0, landing=True)  # onto the point on the way down (§4: 0.1-0.8 m)
            return Goal(target, self.airframe.kin.alt_m)
        return super()._nav_goal(item)

    _finished_text = "Mission finished, loitering"

    def _goal(self) -> Goal | None:
        alt = self.airframe.kin.alt_m
        if self.mode == Mode.TAKEOFF:
            if self._takeoff_alt_m is not None:
                if alt < self._takeoff_alt_m - 0.5:
                    return Goal(climb_point(self.airframe), self._takeoff_alt_m)
                self._takeoff_alt_m = None
                self._enter(Mode.LOITER)
            return None if self.landed else Goal(hold_or(self.airframe, None), alt)
        if self.mode in (Mode.LOITER, Mode.GUIDED):
            if self.landed:
                return None
            if self._target_alt_m <= 0:
                return Goal(None, -1.0, landing=True)
            return Goal(hold_or(self.airframe, self._target_en), self._target_alt_m)
        if self.mode == Mode.POSCTL:
            return None if self.landed else Goal(None, alt - _POSCTL_SINK_M_S * self._dt_s, landing=True)
        if self.mode == Mode.LAND:
            if self.landed:
                return None
            return Goal(None if self.airframe.limits.can_hover else hold_or(self.airframe, None), -1.0, landing=True)
        if self.mode == Mode.RTL:
            return None if self.landed else self._rtl_goal()
        if self.mode == Mode.AUTO:
            return self._auto_goal()
        return None if self.landed else Goal(None, alt)

    # ---- flight -----------------------------------------------------------------------------

    def step(self, dt_s: float) -> None:
        """Advance simulated time by dt (seconds; the fleet keeps dt at or under 0.1 s)."""
        self.time_s += dt_s
        self._dt_s = dt_s
        self._boot_step()
        self._navigator_cycle(now=False)
        self._battery_step(dt_s)
        self._check_failsafe()
        self._check_link()
        self._check_offboard()
        self._rtl_frame_texts()
        if self._after_hold is not None and self.time_s >= self._after_hold[0]:
            _, mode, text = self._after_hold
            self._after_hold = None
            if text:
                self.statustext(text, CRITICAL)
            self._enter(mode)
        if self._disarm_at_s is not None and self.landed and self.time_s >= self._disarm_at_s:
            self._disarm(self._disarm_reason)
        if not self.armed:
            self.airframe.stop()
            return
        goal = self._goal()
        if goal is None:
            return
        if self.landed:
            if goal.landing or goal.alt_m <= 0.5:
                return
            if self._lift_at_s is None:
                self._lift_at_s = self.time_s + _SPOOL_S[self.config.vehicle_type]
            if self.time_s < self._lift_at_s:
                return
            self._lift_at_s = None
            self._disarm_at_s = None
            self.landed = False
            self.statustext("Takeoff detected")
        self.landing = goal.landing
        body = self.airframe
        if goal.landing and self.copter and body.kin.alt_m <= _LAND_SLOW_BELOW_M:
            goal.alt_m = max(goal.alt_m, body.kin.alt_m - self.params["MPC_LAND_SPEED"] * dt_s)
        speed = self._speed_m_s
        if speed is not None:  # the SIH quad's top speed, whatever is asked
            speed = min(speed, max(px4.MAX_SPEED_M_S, self.config.cruise_speed_m_s))
        body.step(dt_s, goal, speed)
        if goal.landing and body.kin.alt_m <= 0.0:
            self._touchdown()
        elif self.mode == Mode.AUTO:
            self._check_reached()
        self._sense()

    def _touchdown(self) -> None:
        """"Landing detected"; a mission's landing ends it and disarms at once, any other
        landing 3.5 s later (and the mode reads MISSION again if the flight flew one)."""
        self.airframe.touch_down()
        self.landed = True
        self.landing = False
        self.statustext("Landing detected")
        if self.mode == Mode.AUTO:
            self.mission_complete = True
            self.statustext("Mission finished, landed")
            self._disarm("Disarmed by landing")
            return
        if self.mode in (Mode.RTL, Mode.LAND) and self._flew_mission:
            self._mode_after_disarm = Mode.AUTO
        self._disarm_at_s = self.time_s + _LAND_DISARM_S
        self._disarm_reason = "Disarmed by landing"

    def _boot_step(self) -> None:
        """GPS fix and origin, home, then the position estimate: the navigator starts, takes
        up a current item and checks the fence (§3)."""
        b, t = self.boot, self.time_s
        if self.origin is None and t >= b.gps_fix_s:
            self.origin = (self.home.lat_deg, self.home.lon_deg, self.home.alt_m)
            self._pending.append(telemetry.gps_global_origin(self))
        if not self.home_set and t >= b.home_s:
            self._set_home(self.home.lat_deg, self.home.lon_deg, self.home.alt_m)
        if not self.navigator_running and t >= b.position_s:
            self.navigator_running = True
            self._new_lists = (bool(self.mission.items()), bool(self.mission.items(MissionType.FENCE)))
            self._navigator_cycle()

    def _battery_step(self, dt_s: float) -> None:
        """SIH drains its battery only while armed (§7); PX4 filters the voltage it reads."""
        battery = self.airframe.battery
        if self.armed:
            battery.step(dt_s, drain_s=self.params["SIM_BAT_DRAIN"],
                         floor_fraction=self.params["SIM_BAT_MIN_PCT"] / 100.0)
        sih_v = px4.battery_voltage_v(battery.charge)
        self._voltage_v += (sih_v - self._voltage_v) * (1.0 - math.exp(-dt_s / px4.VOLTAGE_TAU_S))

    def _check_failsafe(self) -> None:
        """COM_LOW_BAT_ACT (§7): 2 holds 5 s at critical, then lands; 3 returns instead, and
        lands at emergency; every level says so in PX4's words. Levels jumped over act too."""
        if not self.armed:
            return
        reached = _LEVELS[self.charge_state]
        trigger = failsafe_to_trigger(self.failsafe, reached)
        if trigger is None:
            return
        levels = [lvl for lvl in FailsafeLevel if self.failsafe.value < lvl.value <= trigger.value]
        self.failsafe = trigger
        act = int(self.params["COM_LOW_BAT_ACT"])
        flying = not self.landed
        for level in levels:
            if level == FailsafeLevel.LOW:
                self.statustext("Low battery level", mavlink.MAV_SEVERITY_EMERGENCY)
                self.statustext("Failsafe activated", CRITICAL)
            elif level == FailsafeLevel.CRITICAL:
                self.statustext("Low battery level", mavlink.MAV_SEVERITY_EMERGENCY)
                if act in (2, 3) and flying:
                    self.statustext("Failsafe activated: entering Hold for 5 seconds", CRITICAL)
                    self._enter(Mode.LOITER)
                    self._after_hold = (self.time_s + _FAILSAFE_HOLD_S, Mode.LAND if act == 2 else Mode.RTL,
                                        "Failsafe activated")
            elif level == FailsafeLevel.EMERGENCY:
                self.statustext("System does not support shutdown", CRITICAL)
                if act == 3 and flying:
                    self.statustext("Failsafe activated", CRITICAL)
                    self._enter(Mode.LAND)

    def _check_link(self) -> None:
        """No message from the station for COM_DL_LOSS_T: NAV_DLL_ACT 1 holds, 2 holds 5 s then
        returns, 3 holds 5 s then lands, without a text (§8)."""
        if self._heard_s is None or self._link_lost or self.time_s - self._heard_s <= self.params["COM_DL_LOSS_T"]:
            return
        self._link_lost = True
        act = int(self.params["NAV_DLL_ACT"])
        if not self.armed or self.landed or act not in (1, 2, 3):
            return
        self._enter(Mode.LOITER)
        if act in (2, 3):
            self._after_hold = (self.time_s + _FAILSAFE_HOLD_S, Mode.RTL if act == 2 else Mode.LAND, "")

    def _check_offboard(self) -> None:
        if self.mode == Mode.GUIDED and self._setpoint_s is not None \
                and self.time_s - self._setpoint_s > _OFFBOARD_LOSS_S:
            self.statustext("Failsafe activated", CRITICAL)
            self._enter(Mode.POSCTL)

    def _rtl_frame_texts(self) -> None:
        if not self.armed or self.time_s < self._frame_text_s:
            return
        frames = self.mission.sent_frames[MissionType.RALLY]
        if any(f in (mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT) for f in frames):
            self._frame_text_s = self.time_s + _FRAME_TEXT_S
            self.statustext("RTL: unsupported MAV_FRAME", CRITICAL)
