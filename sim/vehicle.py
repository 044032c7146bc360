"""One simulated autopilot: modes, commands, mission execution, battery and sensor.

`SimVehicle` is transport-free: `handle(msg, wall_s)` answers one MAVLink message, `step(dt_s)`
advances simulated time, `emit()` returns telemetry and events due. The fleet owns the clock
and the sockets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim import telemetry
from sim.battery import Battery, BatteryConfig, FailsafeLevel, failsafe_level, failsafe_to_trigger
from sim.geo import HomePose, LocalFrame
from sim.kinematics import KinematicLimits, KinematicState, step_toward
from sim.mission_protocol import MissionItem, MissionProtocol, MissionType, ProtocolConfig
from sim.modes import Mode, custom_mode_of, mode_from_custom, mode_table
from sim.sensor import DownwardSensor, Observation, SensorConfig

MAVMessage = mavlink.MAVLink_message
_FORCE_MAGIC = 21196
_ABSOLUTE_ALT_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT})
_NAV_COMMANDS = frozenset(
    {
        mavlink.MAV_CMD_NAV_WAYPOINT,
        mavlink.MAV_CMD_NAV_LOITER_UNLIM,
        mavlink.MAV_CMD_NAV_LOITER_TIME,
        mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH,
        mavlink.MAV_CMD_NAV_LAND,
        mavlink.MAV_CMD_NAV_TAKEOFF,
    }
)
_TYPE_DEFAULTS = {
    # cruise m/s, turn deg/s, climb m/s, descent m/s, acceptance m, RTL altitude m
    "copter": (10.0, 90.0, 2.5, 1.5, 2.0, 15.0),
    "plane": (20.0, 20.0, 5.0, 3.0, 90.0, 100.0),
}


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleConfig:
    """Vehicle behaviour; None fields take the per-type defaults of `_TYPE_DEFAULTS`."""

    vehicle_type: str = "copter"
    profile: str = "ardupilot"
    cruise_speed_m_s: float | None = None
    turn_rate_deg_s: float | None = None
    climb_rate_m_s: float | None = None
    descent_rate_m_s: float | None = None
    acceptance_radius_m: float | None = None
    rtl_alt_m: float | None = None
    takeoff_alt_m: float = 10.0
    telemetry_hz: float = 4.0
    battery: BatteryConfig = field(default_factory=BatteryConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    mission_timeout_s: float = 1.0

    def __post_init__(self) -> None:
        if self.vehicle_type not in _TYPE_DEFAULTS:
            raise ValueError(f"vehicle_type must be copter or plane, not {self.vehicle_type!r}")
        if self.profile not in ("ardupilot", "px4"):
            raise ValueError(f"profile must be ardupilot or px4, not {self.profile!r}")
        names = ("cruise_speed_m_s", "turn_rate_deg_s", "climb_rate_m_s", "descent_rate_m_s",
                 "acceptance_radius_m", "rtl_alt_m")
        for name, default in zip(names, _TYPE_DEFAULTS[self.vehicle_type], strict=True):
            if getattr(self, name) is None:
                object.__setattr__(self, name, default)

    @property
    def limits(self) -> KinematicLimits:
        return KinematicLimits(
            cruise_speed_m_s=self.cruise_speed_m_s, turn_rate_rad_s=math.radians(self.turn_rate_deg_s),
            climb_rate_m_s=self.climb_rate_m_s, descent_rate_m_s=self.descent_rate_m_s,
            can_hover=self.vehicle_type == "copter",
        )


@dataclass(frozen=True, slots=True)
class VehicleState:
    """True state, for assertions."""

    lat_deg: float
    lon_deg: float
    alt_rel_m: float
    heading_deg: float
    speed_m_s: float
    mode: Mode
    armed: bool
    landed: bool
    battery_pct: float
    mission_seq: int
    failsafe: FailsafeLevel


@dataclass(slots=True)
class _Goal:
    target_en: tuple[float, float] | None
    alt_m: float
    landing: bool = False


class SimVehicle:
    def __init__(
        self,
        sysid: int,
        home: HomePose,
        config: VehicleConfig | None = None,
        *,
        frame: LocalFrame | None = None,
        targets: list[tuple[float, float]] | None = None,
        seed: int = 0,
        grid_origin_en: tuple[float, float] | None = None,
    ) -> None:
        self.sysid = sysid
        self.home = home
        self.config = config = config or VehicleConfig()
        self.frame = frame or LocalFrame(home.lat_deg, home.lon_deg)
        self.limits = config.limits
        east, north = self.frame.geodetic2en(home.lat_deg, home.lon_deg)
        self.home_en = (east, north)
        self.kin = KinematicState(east, north, 0.0, math.radians(home.heading_deg))
        self.time_s = 0.0
        self.mode = Mode.MANUAL
        self.armed = False
        self.landed = True
        self.landing = False
        self.failsafe = FailsafeLevel.NONE
        self.battery = Battery(config.battery)
        self.mission = MissionProtocol(
            ProtocolConfig(home_item=config.profile == "ardupilot", timeout_s=config.mission_timeout_s)
        )
        self.mission.set_home(home.lat_deg, home.lon_deg, home.alt_m)
        self._mission_version = self.mission.versions[MissionType.MISSION]
        self.mission_seq = self._first_seq
        self.mission_complete = False
        self.reached: list[int] = []
        self._jumps_done: dict[int, int] = {}
        self._hold_until_s: float | None = None
        self._takeoff_alt_m: float | None = None
        self._target_en: tuple[float, float] | None = None
        self._target_alt_m = 0.0
        self._speed_m_s: float | None = None
        self._rtl_alt_m = 0.0
        half = 0.5 * config.sensor.cell_size_m
        self.sensor = DownwardSensor(config.sensor, self.frame, targets or [], seed=seed, vehicle_id=sysid,
                                     origin_en=grid_origin_en or (east - half, north - half))
        self.streams = telemetry.StreamScheduler(telemetry.default_intervals_s(config.telemetry_hz))
        self.params: dict[str, float] = {
            "SYSID_THISMAV": float(sysid),
            "RTL_ALT": config.rtl_alt_m * 100.0,
            "WPNAV_SPEED": config.cruise_speed_m_s * 100.0,
            "WPNAV_RADIUS": config.acceptance_radius_m * 100.0,
            "SIM_DRAIN_MULT": 1.0,
            "SIM_BATT_FAIL": 0.0,
        }
        self._pending: list[MAVMessage] = []

    # ---- true state and the Python API -------------------------------------------------

    @property
    def lat_lon_deg(self) -> tuple[float, float]:
        return self.frame.en2geodetic(self.kin.east_m, self.kin.north_m)

    @property
    def state(self) -> VehicleState:
        lat, lon = self.lat_lon_deg
        return VehicleState(
            lat, lon, self.kin.alt_m, math.degrees(self.kin.heading_rad) % 360.0, self.kin.speed_m_s,
            self.mode, self.armed, self.landed, self.battery.remaining_pct, self.mission_seq, self.failsafe,
        )

    @property
    def observations(self) -> list[Observation]:
        return self.sensor.observations

    @property
    def mav_type(self) -> int:
        return mavlink.MAV_TYPE_FIXED_WING if self.config.vehicle_type == "plane" else mavlink.MAV_TYPE_QUADROTOR

    @property
    def mav_autopilot(self) -> int:
        return mavlink.MAV_AUTOPILOT_PX4 if self.config.profile == "px4" else mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA

    @property
    def custom_mode(self) -> int:
        return custom_mode_of(self.mode, self.config.profile, self.config.vehicle_type)

    @property
    def mission_total(self) -> int:
        items = self.mission.items()
        return len(items) - self._first_seq if len(items) > self._first_seq else 0xFFFF

    @property
    def mission_state(self) -> int:
        if len(self.mission.items()) <= self._first_seq:
            return mavlink.MISSION_STATE_NO_MISSION
        if self.mission_complete:
            return mavlink.MISSION_STATE_COMPLETE
        if self.mode == Mode.AUTO:
            return mavlink.MISSION_STATE_ACTIVE
        return mavlink.MISSION_STATE_NOT_STARTED if self.mission_seq == self._first_seq else mavlink.MISSION_STATE_PAUSED

    def fail_battery(self) -> None:
        """Immediate battery failure (the critical failsafe follows on the next step)."""
        self.battery.fail()

    def set_drain_multiplier(self, k: float) -> None:
        self.battery.drain_multiplier = k
        self.params["SIM_DRAIN_MULT"] = k

    def arm(self, force: bool = False) -> int:
        return self._arm(True, force)

    def set_mode(self, mode: Mode) -> int:
        return self._set_mode(mode)

    def load_mission(self, items: list[MissionItem]) -> None:
        self.mission.replace(items)

    def statustext(self, text: str, severity: int = mavlink.MAV_SEVERITY_INFO) -> None:
        self._pending.append(mavlink.MAVLink_statustext_message(severity, text[:50].encode()))

    # ---- messages ----------------------------------------------------------------------

    def handle(self, msg: MAVMessage, wall_s: float) -> list[MAVMessage]:
        """Answer one incoming message; `wall_s` times the mission protocol's retries."""
        kind = msg.get_type()
        target = getattr(msg, "target_system", None)
        if target not in (None, 0, self.sysid):
            return []
        if getattr(msg, "target_component", 0) not in (0, mavlink.MAV_COMP_ID_AUTOPILOT1):
            return []
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind.startswith("MISSION_") and kind not in ("MISSION_SET_CURRENT",):
            out = self.mission.handle(msg, wall_s)
            self._check_new_mission()
            return out
        handler = _HANDLERS.get(kind)
        return handler(self, msg, sender) if handler else []

    def poll(self, wall_s: float) -> list[MAVMessage]:
        return self.mission.poll(wall_s)

    def emit(self) -> list[MAVMessage]:
        """Events since the last call, then the telemetry due now."""
        out, self._pending = self._pending, []
        for msg_id in self.streams.due(self.time_s):
            out.append(telemetry.build(msg_id, self))
        return out

    def _check_new_mission(self) -> None:
        version = self.mission.versions[MissionType.MISSION]
        if version != self._mission_version:
            self._mission_version = version
            self._restart_mission()

    def _on_command(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        p = (msg.param1, msg.param2, msg.param3, msg.param4)
        if msg.get_type() == "COMMAND_INT":
            lat, lon = msg.x / 1e7, msg.y / 1e7
            frame = msg.frame
        else:
            lat, lon = msg.param5, msg.param6
            frame = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
        alt = msg.z if msg.get_type() == "COMMAND_INT" else msg.param7
        result, extra = self._command(msg.command, p, lat, lon, alt, frame)
        ack = mavlink.MAVLink_command_ack_message(msg.command, result, 0, 0, sender[0], sender[1])
        return [ack, *extra]

    def _command(self, cmd: int, p: tuple[float, ...], lat: float, lon: float, alt: float, frame: int
                 ) -> tuple[int, list[MAVMessage]]:
        ok, denied = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED
        if cmd == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            return self._arm(p[0] > 0.5, p[1] == _FORCE_MAGIC), []
        if cmd == mavlink.MAV_CMD_DO_SET_MODE:
            if not int(p[0]) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                return denied, []
            custom = int(p[1])
            if self.config.profile == "px4":
                custom = (int(p[1]) << 16) | (int(p[2]) << 24)
            mode = mode_from_custom(custom, self.config.profile, self.config.vehicle_type)
            return (self._set_mode(mode) if mode else denied), []
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            return self._takeoff(alt), []
        if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._set_mode(Mode.RTL), []
        if cmd == mavlink.MAV_CMD_NAV_LAND:
            return self._set_mode(Mode.LAND), []
        if cmd == mavlink.MAV_CMD_MISSION_START:
            if p[0] > 0:
                self._set_seq(int(p[0]))
            return self._set_mode(Mode.AUTO), []
        if cmd == mavlink.MAV_CMD_DO_REPOSITION:
            return self._reposition(p, lat, lon, alt, frame), []
        if cmd == mavlink.MAV_CMD_DO_SET_MISSION_CURRENT:
            return (ok if self._set_seq(int(p[0])) else denied), []
        if cmd == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            return self._set_interval(int(p[0]), p[1]), []
        if cmd == mavlink.MAV_CMD_GET_MESSAGE_INTERVAL:
            interval = self.streams.interval(int(p[0]))
            us = -1 if interval is None else round(interval * 1e6)
            return ok, [mavlink.MAVLink_message_interval_message(int(p[0]), us)]
        if cmd == mavlink.MAV_CMD_REQUEST_MESSAGE:
            reply = self._requested(int(p[0]), p[1])
            return (ok, [reply]) if reply else (mavlink.MAV_RESULT_UNSUPPORTED, [])
        if cmd == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            return ok, [telemetry.autopilot_version(self)]
        if cmd == mavlink.MAV_CMD_GET_HOME_POSITION:
            return ok, [telemetry.home_position(self)]
        return mavlink.MAV_RESULT_UNSUPPORTED, []

    def _requested(self, msg_id: int, param2: float) -> MAVMessage | None:
        if msg_id == mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED:
            index = int(param2)
            obs = self.sensor.observations
            return self._capture_msg(obs[index]) if 0 <= index < len(obs) else None
        return telemetry.build(msg_id, self)

    def _set_interval(self, msg_id: int, interval_us: float) -> int:
        if telemetry.build(msg_id, self) is None:
            return mavlink.MAV_RESULT_UNSUPPORTED
        if interval_us == 0:
            self.streams.reset_default(msg_id, self.time_s)
        elif interval_us < 0:
            self.streams.set_interval(msg_id, None, self.time_s)
        else:
            self.streams.set_interval(msg_id, interval_us / 1e6, self.time_s)
        return mavlink.MAV_RESULT_ACCEPTED

    def _on_set_mode(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        mode = None
        if msg.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            mode = mode_from_custom(msg.custom_mode, self.config.profile, self.config.vehicle_type)
        result = self._set_mode(mode) if mode else mavlink.MAV_RESULT_DENIED
        return [mavlink.MAVLink_command_ack_message(mavlink.MAVLINK_MSG_ID_SET_MODE, result, 0, 0, *sender)]

    def _on_position_target(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if self.mode != Mode.GUIDED or self.landed:
            return []
        if msg.type_mask & 0b111 == 0b111:
            return []
        self._target_en = self.frame.geodetic2en(msg.lat_int / 1e7, msg.lon_int / 1e7)
        self._target_alt_m = self._alt_rel(msg.alt, msg.coordinate_frame)
        return []

    def _on_mission_set_current(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if not self._set_seq(msg.seq):
            self.statustext(f"Mission item {msg.seq} does not exist", mavlink.MAV_SEVERITY_WARNING)
        return [telemetry.mission_current(self)]

    def _on_request_data_stream(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        interval = 1.0 / msg.req_message_rate if msg.start_stop and msg.req_message_rate > 0 else None
        for msg_id in telemetry.DATA_STREAM_GROUPS.get(msg.req_stream_id, ()):
            self.streams.set_interval(msg_id, interval, self.time_s)
        return []

    def _on_param_request_list(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        return [self._param_value(name) for name in self.params]

    def _on_param_request_read(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        names = list(self.params)
        name = _param_name(msg.param_id)
        if msg.param_index >= 0:
            name = names[msg.param_index] if msg.param_index < len(names) else ""
        return [self._param_value(name)] if name in self.params else []

    def _on_param_set(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        name = _param_name(msg.param_id)
        if name not in self.params:
            return []
        self.params[name] = msg.param_value
        if name == "SIM_DRAIN_MULT":
            self.battery.drain_multiplier = msg.param_value
        elif name == "SIM_BATT_FAIL" and msg.param_value > 0:
            self.fail_battery()
        return [self._param_value(name)]

    def _param_value(self, name: str) -> MAVMessage:
        names = list(self.params)
        return mavlink.MAVLink_param_value_message(
            name.encode(), self.params[name], mavlink.MAV_PARAM_TYPE_REAL32, len(names), names.index(name)
        )

    def _on_timesync(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if msg.tc1 != 0:
            return []
        return [mavlink.MAVLink_timesync_message(int(self.time_s * 1e9), msg.ts1)]

    # ---- modes and commands ------------------------------------------------------------

    def _arm(self, arm: bool, force: bool) -> int:
        if not arm:
            if not self.landed and not force:
                self.statustext("Disarm: vehicle is flying", mavlink.MAV_SEVERITY_WARNING)
                return mavlink.MAV_RESULT_DENIED
            self._disarm()
            return mavlink.MAV_RESULT_ACCEPTED
        if self.armed:
            return mavlink.MAV_RESULT_ACCEPTED
        if not force:
            if failsafe_level(self.battery.remaining_pct, self.config.battery) != FailsafeLevel.NONE:
                self.statustext("PreArm: Battery below minimum arming level", mavlink.MAV_SEVERITY_CRITICAL)
                return mavlink.MAV_RESULT_DENIED
            if self.mode in (Mode.RTL, Mode.LAND):
                self.statustext("Arm: Mode not armable", mavlink.MAV_SEVERITY_CRITICAL)
                return mavlink.MAV_RESULT_DENIED
        self.armed = True
        self.statustext("Arming motors")
        return mavlink.MAV_RESULT_ACCEPTED

    def _disarm(self) -> None:
        if self.armed:
            self.statustext("Disarming motors")
        self.armed = False
        self._takeoff_alt_m = None

    def _set_mode(self, mode: Mode | None) -> int:
        if mode is None or mode not in mode_table(self.config.profile, self.config.vehicle_type):
            return mavlink.MAV_RESULT_DENIED
        if mode == Mode.AUTO and len(self.mission.items()) <= self._first_seq:
            self.statustext("Mode change to AUTO failed: no mission", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_DENIED
        if mode == Mode.AUTO and self.mission_complete:
            self._restart_mission()
        self.mode = mode
        self.landing = False
        self._hold_until_s = None
        if mode in (Mode.GUIDED, Mode.LOITER):
            self._target_en = (self.kin.east_m, self.kin.north_m)
            self._target_alt_m = self.kin.alt_m
        elif mode == Mode.RTL:
            self._rtl_alt_m = max(self.kin.alt_m, self.config.rtl_alt_m)
        elif mode == Mode.TAKEOFF:
            self._takeoff_alt_m = self.config.takeoff_alt_m
        if mode != Mode.TAKEOFF and mode != Mode.GUIDED:
            self._takeoff_alt_m = None
        return mavlink.MAV_RESULT_ACCEPTED

    def _takeoff(self, alt_m: float) -> int:
        if not self.armed:
            self.statustext("Takeoff: vehicle is not armed", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_DENIED
        if self.config.vehicle_type == "plane" or self.config.profile == "px4":
            self._set_mode(Mode.TAKEOFF)
        elif self.mode != Mode.GUIDED:
            self.statustext("Takeoff: requires GUIDED mode", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_DENIED
        self._takeoff_alt_m = alt_m if alt_m > 0 else self.config.takeoff_alt_m
        self._target_en, self._target_alt_m = None, self._takeoff_alt_m
        return mavlink.MAV_RESULT_ACCEPTED

    def _reposition(self, p: tuple[float, ...], lat: float, lon: float, alt: float, frame: int) -> int:
        change_mode = int(p[1]) & mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
        if self.config.profile == "px4":
            change_mode = True
        if self.mode not in (Mode.GUIDED, Mode.LOITER) and not change_mode:
            self.statustext("Reposition: requires GUIDED mode", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_DENIED
        if self.landed:
            self.statustext("Reposition: vehicle is landed", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_DENIED
        if self.mode not in (Mode.GUIDED, Mode.LOITER):
            self._set_mode(Mode.LOITER if self.config.profile == "px4" else Mode.GUIDED)
        if not (math.isnan(lat) or math.isnan(lon)):
            self._target_en = self.frame.geodetic2en(lat, lon)
        if not math.isnan(alt):
            self._target_alt_m = self._alt_rel(alt, frame)
        self._speed_m_s = p[0] if p[0] > 0 else None
        return mavlink.MAV_RESULT_ACCEPTED

    # ---- flight ------------------------------------------------------------------------

    @property
    def _first_seq(self) -> int:
        return 1 if self.config.profile == "ardupilot" else 0

    def _restart_mission(self) -> None:
        self.mission_seq = self._first_seq
        self.mission_complete = False
        self._jumps_done.clear()
        self._hold_until_s = None

    def _set_seq(self, seq: int) -> bool:
        if not self._first_seq <= seq < len(self.mission.items()):
            return False
        self.mission_seq = seq
        self.mission_complete = False
        self._hold_until_s = None
        self._pending.append(telemetry.mission_current(self))
        return True

    def _alt_rel(self, alt_m: float, frame: int) -> float:
        return alt_m - self.home.alt_m if frame in _ABSOLUTE_ALT_FRAMES else alt_m

    def step(self, dt_s: float) -> None:
        """Advance simulated time by dt (seconds; the fleet keeps dt at or under 0.1 s)."""
        self.time_s += dt_s
        self.battery.step(dt_s, flying=self.armed and not self.landed)
        self._check_failsafe()
        if not self.armed:
            self.kin.speed_m_s = self.kin.climb_m_s = self.kin.turn_rate_rad_s = 0.0
            return
        goal = self._goal()
        if goal is None:
            return
        if self.landed and (goal.landing or goal.alt_m <= 0.5):
            if goal.landing:
                self._touchdown()
            return
        self.landed = False
        self.landing = goal.landing
        step_toward(self.kin, self.limits, dt_s, target_en=goal.target_en, target_alt_m=goal.alt_m,
                    speed_m_s=self._speed_m_s)
        if goal.landing and self.kin.alt_m <= 0.0:
            self._touchdown()
        elif self.mode == Mode.AUTO:
            self._check_reached()
        obs = self.sensor.update(self.kin.east_m, self.kin.north_m, self.kin.alt_m, self.time_s)
        if obs is not None:
            self._pending.append(self._capture_msg(obs))
            if obs.reported:
                self.statustext(f"DETECT cell {obs.cell[0]},{obs.cell[1]} img {obs.index}", mavlink.MAV_SEVERITY_NOTICE)

    def _capture_msg(self, obs: Observation) -> MAVMessage:
        cfg = self.config.sensor
        url = f"detect?cell={obs.cell[0]},{obs.cell[1]}&hit={int(obs.reported)}&pc={cfg.pc:g}&pf={cfg.pf:g}"
        return mavlink.MAVLink_camera_image_captured_message(
            int(obs.time_s * 1000), 0, 0, round(obs.lat_deg * 1e7), round(obs.lon_deg * 1e7),
            round((self.home.alt_m + self.kin.alt_m) * 1000), round(self.kin.alt_m * 1000),
            [1.0, 0.0, 0.0, 0.0], obs.index, 1, url.encode(),
        )

    def _check_failsafe(self) -> None:
        reached = failsafe_level(self.battery.remaining_pct, self.config.battery)
        trigger = failsafe_to_trigger(self.failsafe, reached)
        if trigger is None:
            return
        self.failsafe = trigger
        if not self.armed or self.landed:
            return
        pct = self.battery.remaining_pct
        if trigger == FailsafeLevel.LOW:
            self.statustext(f"Battery failsafe: low {pct:.0f}%, RTL", mavlink.MAV_SEVERITY_CRITICAL)
            self._set_mode(Mode.RTL)
        else:
            can_land = Mode.LAND in mode_table(self.config.profile, self.config.vehicle_type)
            self.statustext(f"Battery failsafe: critical {pct:.0f}%, {'LAND' if can_land else 'RTL'}",
                            mavlink.MAV_SEVERITY_EMERGENCY)
            self._set_mode(Mode.LAND if can_land else Mode.RTL)

    def _touchdown(self) -> None:
        self.kin.alt_m = 0.0
        self.kin.speed_m_s = self.kin.climb_m_s = self.kin.turn_rate_rad_s = 0.0
        was_flying = not self.landed
        self.landed = True
        self.landing = False
        if was_flying:
            self.statustext("Land complete")
        if self.mode == Mode.AUTO and self.mission_seq < len(self.mission.items()):
            self._reach(self.mission_seq)
        self._disarm()

    def _goal(self) -> _Goal | None:
        here = (self.kin.east_m, self.kin.north_m)
        if self._takeoff_alt_m is not None and self.mode in (Mode.GUIDED, Mode.TAKEOFF):
            if self.kin.alt_m >= self._takeoff_alt_m - 0.5:
                self._takeoff_alt_m = None
                if self.mode == Mode.TAKEOFF:
                    self.mode = Mode.LOITER
                if self._target_en is None:  # no reposition arrived during the climb
                    self._target_en, self._target_alt_m = here, self.kin.alt_m
            else:
                return _Goal(self._climb_point(), self._takeoff_alt_m)
        if self.mode in (Mode.GUIDED, Mode.LOITER, Mode.TAKEOFF):
            if self.landed:
                return None
            return _Goal(self._hold_or(self._target_en), self._target_alt_m)
        if self.mode == Mode.LAND:
            return _Goal(None if self.limits.can_hover else self._hold_or(None), -1.0, landing=True)
        if self.mode == Mode.RTL:
            return self._rtl_goal()
        if self.mode == Mode.AUTO:
            return self._auto_goal()
        return None if self.landed else _Goal(None, self.kin.alt_m)

    def _climb_point(self) -> tuple[float, float] | None:
        """Copters climb vertically; planes climb straight ahead."""
        if self.limits.can_hover:
            return None
        far = 10_000.0
        return (self.kin.east_m + far * math.sin(self.kin.heading_rad),
                self.kin.north_m + far * math.cos(self.kin.heading_rad))

    def _hold_or(self, target: tuple[float, float] | None) -> tuple[float, float] | None:
        """A plane near its target circles (target None) instead of chasing it."""
        if target is None or self.limits.can_hover:
            return target
        if math.dist(target, (self.kin.east_m, self.kin.north_m)) < self.limits.turn_radius_m:
            return None
        return target

    def _rtl_goal(self) -> _Goal:
        dist = math.dist(self.home_en, (self.kin.east_m, self.kin.north_m))
        radius = self.config.acceptance_radius_m
        if self.landing or dist <= radius:
            return _Goal(None if self.limits.can_hover else self._hold_or(None), -1.0, landing=True)
        if self.limits.can_hover and self.kin.alt_m < self._rtl_alt_m - 0.5:
            return _Goal(None, self._rtl_alt_m)
        return _Goal(self.home_en, self._rtl_alt_m)

    def _auto_goal(self) -> _Goal | None:
        items = self.mission.items()
        for _ in range(len(items) + 1):
            if self.mission_seq >= len(items):
                if not self.mission_complete:
                    self.mission_complete = True
                    self.statustext("Mission complete")
                return None if self.landed else _Goal(self._hold_or(None), self.kin.alt_m)
            item = items[self.mission_seq]
            if item.command == mavlink.MAV_CMD_DO_JUMP:
                self._do_jump(item)
                continue
            if item.command == mavlink.MAV_CMD_DO_CHANGE_SPEED and item.param2 > 0:
                self._speed_m_s = item.param2
            if item.command not in _NAV_COMMANDS:
                self._advance()
                continue
            return self._nav_goal(item)
        return None

    def _do_jump(self, item: MissionItem) -> None:
        done = self._jumps_done.get(item.seq, 0)
        if item.param2 < 0 or done < item.param2:
            self._jumps_done[item.seq] = done + 1
            self.mission_seq = int(item.param1)
        else:
            self._advance()
        self._pending.append(telemetry.mission_current(self))

    def _item_en(self, item: MissionItem) -> tuple[float, float]:
        if item.x == 0 and item.y == 0:
            return (self.kin.east_m, self.kin.north_m)
        return self.frame.geodetic2en(item.x / 1e7, item.y / 1e7)

    def _nav_goal(self, item: MissionItem) -> _Goal:
        cmd = item.command
        alt = self._alt_rel(item.z, item.frame)
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            return _Goal(self._climb_point(), alt)
        if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            if not self.landing and self._rtl_alt_m <= 0.0:
                self._rtl_alt_m = max(self.kin.alt_m, self.config.rtl_alt_m)
            return self._rtl_goal()
        if cmd == mavlink.MAV_CMD_NAV_LAND:
            target = self._item_en(item)
            if self.landing or math.dist(target, (self.kin.east_m, self.kin.north_m)) <= self._radius(item):
                return _Goal(None if self.limits.can_hover else self._hold_or(None), -1.0, landing=True)
            return _Goal(target, self.kin.alt_m)
        return _Goal(self._item_en(item), alt)

    def _radius(self, item: MissionItem) -> float:
        radius = item.param2 if item.command == mavlink.MAV_CMD_NAV_WAYPOINT and item.param2 > 0 \
            else self.config.acceptance_radius_m
        if not self.limits.can_hover:
            radius = max(radius, self.limits.turn_radius_m)
        return radius

    def _check_reached(self) -> None:
        items = self.mission.items()
        if self.mission_seq >= len(items):
            return
        item = items[self.mission_seq]
        cmd = item.command
        here = (self.kin.east_m, self.kin.north_m)
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            if self.kin.alt_m >= self._alt_rel(item.z, item.frame) - 0.5:
                self._reach(item.seq)
            return
        if cmd not in (mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME, mavlink.MAV_CMD_NAV_LOITER_UNLIM):
            return
        if self._hold_until_s is not None:
            if self.time_s >= self._hold_until_s:
                self._hold_until_s = None
                self._advance()
            return
        close = math.dist(self._item_en(item), here) <= self._radius(item)
        if self.limits.can_hover:
            close = close and abs(self.kin.alt_m - self._alt_rel(item.z, item.frame)) <= 1.0
        if not close:
            return
        if cmd == mavlink.MAV_CMD_NAV_LOITER_UNLIM:
            return
        self._pending.append(mavlink.MAVLink_mission_item_reached_message(item.seq))
        self.reached.append(item.seq)
        hold_s = item.param1 if self.limits.can_hover or cmd == mavlink.MAV_CMD_NAV_LOITER_TIME else 0.0
        if hold_s > 0:
            self._hold_until_s = self.time_s + hold_s
        else:
            self._advance()

    def _reach(self, seq: int) -> None:
        self._pending.append(mavlink.MAVLink_mission_item_reached_message(seq))
        self.reached.append(seq)
        self._advance()

    def _advance(self) -> None:
        self.mission_seq += 1
        self._rtl_alt_m = 0.0
        self._pending.append(telemetry.mission_current(self))


def _param_name(raw: bytes | str) -> str:
    if isinstance(raw, bytes):
        raw = raw.decode(errors="replace")
    return raw.rstrip("\x00")


_HANDLERS = {
    "COMMAND_LONG": SimVehicle._on_command,
    "COMMAND_INT": SimVehicle._on_command,
    "SET_MODE": SimVehicle._on_set_mode,
    "SET_POSITION_TARGET_GLOBAL_INT": SimVehicle._on_position_target,
    "MISSION_SET_CURRENT": SimVehicle._on_mission_set_current,
    "REQUEST_DATA_STREAM": SimVehicle._on_request_data_stream,
    "PARAM_REQUEST_LIST": SimVehicle._on_param_request_list,
    "PARAM_REQUEST_READ": SimVehicle._on_param_request_read,
    "PARAM_SET": SimVehicle._on_param_set,
    "TIMESYNC": SimVehicle._on_timesync,
}
