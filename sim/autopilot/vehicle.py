"""One simulated autopilot: commands, modes, arming, parameters, failsafes and telemetry,
flying an `Airframe` (`sim.physics.airframe`: motion, battery, sensor).

`SimVehicle` is transport-free: `handle(msg, wall_s)` answers one MAVLink message, `step(dt_s)`
advances simulated time, `emit()` returns telemetry and events due. The fleet owns the clock
and the sockets. Each step the autopilot decides a `Goal` from its mode and mission and the
airframe flies toward it; the autopilot reads back where the airframe is (`airframe.kin`, in
the fleet's local frame) to reach waypoints, land and report. Where it steers (each mode's goal,
the mission's progress, RTL, the landings) is `sim.autopilot.guidance`.

The `ardupilot` profile behaves as ArduCopter / ArduPlane 4.7 SITL did when measured (research
reports `ardupilot_protocol` and `ardupilot_flight`; docs/sim.md lists each behaviour): readiness
milestones after boot and the arming refusals before them, no telemetry streams on a copter
until asked, MISSION_START (0, 0) only and resuming where the mission was, the copter's GUIDED,
arm, MISSION_START launch and auto-disarm, the plane's landing sequence, DO_REPOSITION as
COMMAND_INT only, BATT_CAPACITY and the arming battery checks. The `px4` profile is
`sim.autopilot.px4_vehicle.Px4Vehicle`, PX4 v1.15.3 as measured; `sim.autopilot.profiles.new_vehicle`
makes the vehicle of a config's profile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.ardupilot_storage import stored_item
from gcs.autopilots.wire_item import MissionType, WireItem
from planner.georef import LocalFrame
from sim.autopilot import telemetry
from sim.autopilot.ardupilot import BOOT_TIMES, CAPACITY, BootTimes, boot_refusals, ekf_flags
from sim.autopilot.ardupilot_mission import UPLOAD_GIVE_UP_S, ArduPilotMissionProtocol
from sim.autopilot.failsafe import FailsafeLevel, failsafe_level, failsafe_to_trigger
from sim.autopilot.guidance import NAV_COMMANDS, Guidance
from sim.autopilot.mission_protocol import MissionProtocol, ProtocolConfig
from sim.autopilot.modes import Mode, custom_mode_of, mode_from_custom, mode_table
from sim.autopilot.px4 import BOOT_TIMES as PX4_BOOT_TIMES, Px4BootTimes
from sim.autopilot.telemetry import reading_message, reading_text
from sim.physics.airframe import Airframe, HomePose
from sim.physics.battery import Battery, BatteryConfig, Load, SihBattery, draw_for
from sim.physics.kinematics import COPTER_ACCEL_M_S2, KinematicLimits
from sim.physics.sensor import DownwardSensor, Observation, SensorConfig

MAVMessage = mavlink.MAVLink_message
_FORCE_MAGIC = 21196
_ABSOLUTE_ALT_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT})
_LAND_SLOW_BELOW_M, _LAND_SLOW_M_S = 10.0, 0.5  # ArduCopter's LAND_ALT_LOW and LAND_SPEED
# from the take-off command to leaving the ground: ArduCopter 3.25 s after MISSION_START, ArduPlane
# 3.0 s after arming in AUTO, at full throttle (landed_state TAKEOFF then, flight §2, §3; 2 m up
# 3.2-3.4 s after the throttle, docs/energy.md)
_COPTER_SPOOL_S, _PLANE_ROLL_S = 3.25, 3.0
# ArduCopter SITL's quad flies no faster than this, whatever DO_CHANGE_SPEED asks (its lean angle
# limit; docs/energy.md)
_COPTER_MAX_SPEED_M_S = 10.3
_TYPE_DEFAULTS = {
    # cruise m/s, turn deg/s, climb m/s, descent m/s, acceptance m, RTL altitude m
    # (the copter's turn: the direction it moves in, fitted with sim.physics.kinematics's corners)
    ("ardupilot", "copter"): (10.0, 360.0, 2.5, 1.5, 2.0, 15.0),
    ("ardupilot", "plane"): (20.0, 20.0, 5.0, 3.0, 90.0, 100.0),
    # PX4 (px4 §4, §6): MPC_XY_CRUISE 5, 29 m climbed in 14.6 s, 20 m descended in 15 s (then
    # MPC_LAND_SPEED below 10 m), NAV_ACC_RAD 2, RTL_RETURN_ALT 30; the plane was not flown
    ("px4", "copter"): (5.0, 90.0, 1.9, 1.35, 2.0, 30.0),
    ("px4", "plane"): (20.0, 20.0, 5.0, 3.0, 90.0, 30.0),
}


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleConfig:
    """Vehicle behaviour; None fields take the per-type defaults of `_TYPE_DEFAULTS`.

    `boot`: when a vehicle reaches each readiness milestone after boot (None: as measured on
    SITL for its profile and type, `sim.autopilot.ardupilot.BOOT_TIMES`, `sim.autopilot.px4.BOOT_TIMES`), every
    time multiplied by `boot_scale` (0: ready at once; tests that are not about start-up use a
    small scale). `telemetry_hz`: GLOBAL_POSITION_INT, ATTITUDE and VFR_HUD of the px4 profile
    (None: PX4's 50, 50 and 4 Hz)."""

    vehicle_type: str = "copter"
    profile: str = "ardupilot"
    cruise_speed_m_s: float | None = None
    turn_rate_deg_s: float | None = None
    climb_rate_m_s: float | None = None
    descent_rate_m_s: float | None = None
    acceptance_radius_m: float | None = None
    rtl_alt_m: float | None = None
    takeoff_alt_m: float = 10.0
    telemetry_hz: float | None = None
    battery: BatteryConfig = field(default_factory=BatteryConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    mission_timeout_s: float = 1.0
    boot: BootTimes | Px4BootTimes | None = None
    boot_scale: float = 1.0

    def __post_init__(self) -> None:
        if self.vehicle_type not in ("copter", "plane"):
            raise ValueError(f"vehicle_type must be copter or plane, not {self.vehicle_type!r}")
        if self.profile not in ("ardupilot", "px4"):
            raise ValueError(f"profile must be ardupilot or px4, not {self.profile!r}")
        boot_type = Px4BootTimes if self.profile == "px4" else BootTimes
        if self.boot is not None and not isinstance(self.boot, boot_type):
            raise ValueError(f"boot must be a {boot_type.__name__} for the {self.profile} profile")
        if not self.boot_scale >= 0:
            raise ValueError(f"boot_scale must be 0 or more, not {self.boot_scale!r}")
        names = ("cruise_speed_m_s", "turn_rate_deg_s", "climb_rate_m_s", "descent_rate_m_s",
                 "acceptance_radius_m", "rtl_alt_m")
        for name, default in zip(names, _TYPE_DEFAULTS[self.profile, self.vehicle_type], strict=True):
            if getattr(self, name) is None:
                object.__setattr__(self, name, default)

    @property
    def limits(self) -> KinematicLimits:
        return KinematicLimits(
            cruise_speed_m_s=self.cruise_speed_m_s, turn_rate_rad_s=math.radians(self.turn_rate_deg_s),
            climb_rate_m_s=self.climb_rate_m_s, descent_rate_m_s=self.descent_rate_m_s,
            can_hover=self.vehicle_type == "copter",
            accel_m_s2=COPTER_ACCEL_M_S2 if (self.profile, self.vehicle_type) == ("ardupilot", "copter") else None,
        )

    @property
    def boot_times(self) -> BootTimes | Px4BootTimes:
        table = PX4_BOOT_TIMES if self.profile == "px4" else BOOT_TIMES
        return (self.boot or table[self.vehicle_type]).scaled(self.boot_scale)


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


class SimVehicle(Guidance):
    """The `ardupilot` profile's vehicle, and the base of the others (`sim.autopilot.profiles`
    makes the vehicle a config's profile names)."""

    PROFILE = "ardupilot"
    #: the method answering each message type (looked up on the instance: a profile's own answers)
    HANDLERS: dict[str, str] = {
        "COMMAND_LONG": "_on_command", "COMMAND_INT": "_on_command", "SET_MODE": "_on_set_mode",
        "SET_POSITION_TARGET_GLOBAL_INT": "_on_position_target", "MISSION_SET_CURRENT": "_on_mission_set_current",
        "REQUEST_DATA_STREAM": "_on_request_data_stream", "PARAM_REQUEST_LIST": "_on_param_request_list",
        "PARAM_REQUEST_READ": "_on_param_request_read", "PARAM_SET": "_on_param_set", "TIMESYNC": "_on_timesync",
    }

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
        config = config or VehicleConfig(profile=self.PROFILE)
        if config.profile != self.PROFILE:
            raise ValueError(f"a {type(self).__name__} flies the {self.PROFILE} profile, not {config.profile}: "
                             "make vehicles with sim.autopilot.profiles.new_vehicle")
        self.sysid = sysid
        self.home = home
        self.config = config
        self.ardupilot = config.profile == "ardupilot"
        self.copter = config.vehicle_type == "copter"
        self.boot = config.boot_times
        self.frame = frame or LocalFrame(home.lat_deg, home.lon_deg)  # the fleet's, where it navigates
        east, north = self.frame.geodetic2en(home.lat_deg, home.lon_deg)
        self.home_en = (east, north)
        half = 0.5 * config.sensor.cell_size_m
        sensor = DownwardSensor(config.sensor, self.frame, targets or [], seed=seed, vehicle_id=sysid,
                                origin_en=grid_origin_en or (east - half, north - half))
        self.airframe = Airframe(home, self.frame, config.limits, self._new_battery(), sensor)
        self.time_s = 0.0
        self.mode = Mode.MANUAL
        self.armed = False
        self.landed = True
        self.landing = False
        self.failsafe = FailsafeLevel.NONE
        if self.ardupilot:
            store = partial(stored_item, fixed_wing=not self.copter)
            self.mission: MissionProtocol = ArduPilotMissionProtocol(ProtocolConfig(
                home_item=True, store=store, capacity=dict(CAPACITY[config.vehicle_type]),
                timeout_s=config.mission_timeout_s))
        else:
            self.mission = MissionProtocol(ProtocolConfig(home_item=False, timeout_s=config.mission_timeout_s))
        # ArduPilot knows its home only some time after boot (`_boot_step`); PX4 here at once
        self.home_set = not self.ardupilot
        self.origin: tuple[float, float, float] | None = None  # the EKF origin (ArduPilot), set once
        if self.home_set:
            self.mission.set_home(home.lat_deg, home.lon_deg, home.alt_m)
        self._mission_version = self.mission.versions[MissionType.MISSION]
        self._init_guidance()
        # the setpoints commands and modes give guidance
        self._takeoff_alt_m: float | None = None
        self._target_en: tuple[float, float] | None = None
        self._target_alt_m = 0.0
        self._speed_m_s: float | None = None
        self._rtl_alt_m = 0.0
        self._auto_armed = False  # ArduCopter: AUTO flies from the ground only after MISSION_START
        self._disarm_at_s: float | None = None
        self._station_time_scale = 1.0  # vehicle seconds per real second of a station's wait
        self._lift_at_s: float | None = None
        self._prearm_report_s = 30.0
        self.streams = telemetry.StreamScheduler(telemetry.default_intervals_s(
            config.telemetry_hz, profile=config.profile, vehicle_type=config.vehicle_type))
        self.params = self._default_params()
        self._pending: list[MAVMessage] = []

    def _new_battery(self) -> Battery | SihBattery:
        """The airframe's battery: ArduPilot SITL's simulated pack drawn as its copter or plane
        draws (the px4 profile: SIH's); an endurance is counted at the cruise speed's current."""
        cfg = self.config
        draw = draw_for(cfg.vehicle_type)
        return Battery(cfg.battery, draw, draw.cruise_current_a(cfg.cruise_speed_m_s))

    def _default_params(self) -> dict[str, float]:
        cfg = self.config
        if not self.ardupilot:
            return {"SYSID_THISMAV": float(self.sysid), "RTL_ALT": cfg.rtl_alt_m * 100.0,
                    "WPNAV_SPEED": cfg.cruise_speed_m_s * 100.0, "WPNAV_RADIUS": cfg.acceptance_radius_m * 100.0,
                    "SIM_DRAIN_MULT": 1.0, "SIM_BATT_FAIL": 0.0}
        # ArduPilot 4.7 names (MAV_SYSID, not SYSID_THISMAV); unknown names get no answer
        params = {"MAV_SYSID": float(self.sysid)}
        if self.copter:
            params |= {"RTL_ALT": cfg.rtl_alt_m * 100.0, "WPNAV_SPEED": cfg.cruise_speed_m_s * 100.0,
                       "WPNAV_RADIUS": cfg.acceptance_radius_m * 100.0, "DISARM_DELAY": 10.0}
        else:
            params |= {"RTL_ALTITUDE": cfg.rtl_alt_m, "WP_RADIUS": cfg.acceptance_radius_m, "RTL_AUTOLAND": 0.0,
                       "LAND_DISARMDELAY": 20.0}
        return params | {
            "MIS_RESTART": 0.0, "BATT_CAPACITY": round(self.airframe.battery.capacity_mah), "BATT_ARM_VOLT": 0.0,
            "BATT_ARM_MAH": 0.0, "BATT_LOW_VOLT": 10.5 if self.copter else 0.0, "SIM_BATT_VOLTAGE": 12.6,
            "SIM_DRAIN_MULT": 1.0, "SIM_BATT_FAIL": 0.0,
        }

    def started_at_speedup(self, speedup: float) -> None:
        """The fleet runs this many times faster than real time. An ArduPilot upload is given up
        8 s after the last item, and an ArduCopter armed on the ground disarms DISARM_DELAY after
        arming unless its mission has started: both time the station, whose round trips do not
        speed up with the simulation, so they are real seconds here, as on a vehicle at speed-up 1
        (SITL keeps them in its own time: at speed-up 60 a station on a loaded machine had 0.13 s
        to answer an upload and 0.17 s to start a mission after arming, and lost both). Its
        re-requests stay in vehicle time, as often as SITL's. The px4 profile scales its link-loss
        timeout likewise."""
        self._station_time_scale = max(1.0, speedup)
        if isinstance(self.mission, ArduPilotMissionProtocol):
            self.mission.give_up_s = UPLOAD_GIVE_UP_S * self._station_time_scale

    # ---- true state and the Python API -------------------------------------------------

    @property
    def state(self) -> VehicleState:
        body = self.airframe
        lat, lon = body.lat_lon_deg
        return VehicleState(
            lat, lon, body.kin.alt_m, body.heading_deg, body.kin.speed_m_s,
            self.mode, self.armed, self.landed, self.battery_pct, self.mission_seq, self.failsafe,
        )

    @property
    def sensor(self) -> DownwardSensor:
        """The airframe's downward sensor."""
        return self.airframe.sensor

    @property
    def observations(self) -> list[Observation]:
        return self.airframe.sensor.observations

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
    def gps_fixed(self) -> bool:
        return not self.ardupilot or self.time_s >= self.boot.gps_fix_s

    @property
    def position_known(self) -> bool:
        """GLOBAL_POSITION_INT carries a position (before: 0, 0)."""
        return self.gps_fixed

    @property
    def ekf_flags(self) -> int:
        return ekf_flags(self.boot, self.time_s) if self.ardupilot else 0x33F

    @property
    def taking_off(self) -> bool:
        """Climbing to a take-off altitude: NAV_TAKEOFF in GUIDED or TAKEOFF, or the mission's."""
        if self._takeoff_alt_m is not None and self.mode in (Mode.GUIDED, Mode.TAKEOFF):
            return True
        items = self.mission.items()
        return self.mode == Mode.AUTO and self._first_seq <= self.mission_seq < len(items) \
            and items[self.mission_seq].command == mavlink.MAV_CMD_NAV_TAKEOFF

    @property
    def prearm_ok(self) -> bool:
        """SYS_STATUS's pre-arm bit: ArduPilot's pre-arm checks pass in the current mode."""
        return not self._prearm_refusals()

    @property
    def battery_pct(self) -> float:
        """The remaining charge the vehicle reports, %."""
        return self.airframe.battery.remaining_pct

    @property
    def load(self) -> Load:
        """What the airframe draws on its battery now."""
        kin = self.airframe.kin
        return Load(self.armed, flying=self.armed and not self.landed,
                    launching=self.armed and self.landed and self._lift_at_s is not None,
                    airspeed_m_s=kin.speed_m_s, climb_m_s=kin.climb_m_s)

    @property
    def throttle(self) -> float:
        """0..1, as VFR_HUD reports it."""
        battery = self.airframe.battery
        assert isinstance(battery, Battery)
        return battery.draw.throttle(self.load)

    @property
    def battery_voltage_v(self) -> float:
        """ArduPilot SITL: a copter's battery stays at SIM_BATT_VOLTAGE; a plane's sags by 0.7 V
        at full throttle (11.9 V taking off, 12.26 V cruising; docs/energy.md)."""
        battery = self.airframe.battery
        assert isinstance(battery, Battery)
        return self.params["SIM_BATT_VOLTAGE"] - battery.draw.sag_v(self.load)

    @property
    def mission_total(self) -> int:
        items = self.mission.items()
        if self.ardupilot:
            return max(len(items) - 1, 0)
        return len(items) if items else 0xFFFF

    @property
    def mission_state(self) -> int:
        if self.ardupilot:  # AP_Mission's stopped / running / complete (flight §1)
            if self.mission_total == 0:
                return mavlink.MISSION_STATE_NO_MISSION
            if self.mission_complete:
                return mavlink.MISSION_STATE_COMPLETE
            return mavlink.MISSION_STATE_ACTIVE if self.mode == Mode.AUTO else mavlink.MISSION_STATE_NOT_STARTED
        if not self.mission.items():
            return mavlink.MISSION_STATE_NO_MISSION
        if self.mission_complete:
            return mavlink.MISSION_STATE_COMPLETE
        if self.mode == Mode.AUTO:
            return mavlink.MISSION_STATE_ACTIVE
        return mavlink.MISSION_STATE_NOT_STARTED if self.mission_seq == 0 else mavlink.MISSION_STATE_PAUSED

    def fail_battery(self) -> None:
        """Immediate battery failure (the critical failsafe follows on the next step)."""
        self.airframe.battery.fail()

    def set_drain_multiplier(self, k: float) -> None:
        self.airframe.battery.drain_multiplier = k
        self.params["SIM_DRAIN_MULT"] = k

    def arm(self, force: bool = False) -> int:
        return self._arm(True, force)

    def set_mode(self, mode: Mode) -> int:
        return self._set_mode(mode)

    def load_mission(self, items: list[WireItem]) -> None:
        self.mission.replace(items)

    def statustext(self, text: str, severity: int = mavlink.MAV_SEVERITY_INFO) -> None:
        self._pending.append(mavlink.MAVLink_statustext_message(severity, text[:50].encode()))

    # ---- messages ----------------------------------------------------------------------

    def handle(self, msg: MAVMessage, wall_s: float) -> list[MAVMessage]:
        """Answer one incoming message; `wall_s` times the PX4 profile's mission retries
        (ArduPilot's run on the vehicle's own clock, as SITL's do, but for `started_at_speedup`)."""
        kind = msg.get_type()
        target = getattr(msg, "target_system", None)
        if target not in (None, 0, self.sysid):
            return []
        if getattr(msg, "target_component", 0) not in (0, mavlink.MAV_COMP_ID_AUTOPILOT1):
            return []
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind.startswith("MISSION_") and kind not in ("MISSION_SET_CURRENT",):
            out = self.mission.handle(msg, self.time_s if self.ardupilot else wall_s)
            self._check_new_mission()
            return out
        handler = self.HANDLERS.get(kind)
        return getattr(self, handler)(msg, sender) if handler else []

    def poll(self, wall_s: float) -> list[MAVMessage]:
        return self.mission.poll(self.time_s if self.ardupilot else wall_s)

    def emit(self) -> list[MAVMessage]:
        """Events since the last call, then the telemetry due now."""
        out, self._pending = self._pending, []
        for msg_id in self.streams.due(self.time_s):
            msg = telemetry.build(msg_id, self)
            if msg is not None:
                out.append(msg)
        return out

    def _check_new_mission(self) -> None:
        version = self.mission.versions[MissionType.MISSION]
        if version == self._mission_version:
            return
        self._mission_version = version
        if not self.ardupilot:
            self._restart_mission()
            return
        # ArduPilot writes items as they arrive and keeps its place in the mission (MIS_RESTART
        # 0); a copter flying AUTO restarts its current command whenever an item at or before it
        # is replaced and flies whatever is there now; a plane finishes its nav command (flight §4b)
        writes, self.mission.writes = self.mission.writes, []
        for mission_type, seq in writes:
            if mission_type == MissionType.MISSION and self.copter and self.mode == Mode.AUTO \
                    and seq <= self.mission_seq:
                self.statustext("Auto mission changed, restarted command", mavlink.MAV_SEVERITY_CRITICAL)
                self._hold_until_s = None

    def _on_command(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        p = (msg.param1, msg.param2, msg.param3, msg.param4)
        command_int = msg.get_type() == "COMMAND_INT"
        if command_int:
            lat, lon = msg.x / 1e7, msg.y / 1e7
            frame = msg.frame
        else:
            lat, lon = msg.param5, msg.param6
            frame = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
        alt = msg.z if command_int else msg.param7
        if self.ardupilot and msg.command == mavlink.MAV_CMD_DO_REPOSITION and not command_int:
            result, extra = mavlink.MAV_RESULT_UNSUPPORTED, []  # COMMAND_INT only (flight §7)
        else:
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
            return (self._set_mode(mode) if mode else self._mode_refused()), []
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            return self._takeoff(alt), []
        if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._set_mode(Mode.RTL), []
        if cmd == mavlink.MAV_CMD_NAV_LAND:
            return self._set_mode(Mode.LAND), []
        if cmd == mavlink.MAV_CMD_MISSION_START:
            return self._mission_start(p), []
        if cmd == mavlink.MAV_CMD_DO_LAND_START and self.ardupilot and not self.copter:
            return (ok if self._start_landing_sequence() else mavlink.MAV_RESULT_FAILED), []
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
            if not self._can_request(int(p[0])):
                return mavlink.MAV_RESULT_UNSUPPORTED, []
            reply = self._requested(int(p[0]), p[1])
            return ok, [reply] if reply else []  # ArduPilot: accepted, nothing sent before home is set
        if cmd == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            return ok, [telemetry.autopilot_version(self)]
        if cmd == mavlink.MAV_CMD_GET_HOME_POSITION:
            home = telemetry.home_position(self)
            return (ok, [home]) if home else (mavlink.MAV_RESULT_FAILED, [])
        return mavlink.MAV_RESULT_UNSUPPORTED, []

    def _can_request(self, msg_id: int) -> bool:
        return msg_id == mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED or telemetry.known(msg_id, self)

    def _requested(self, msg_id: int, param2: float) -> MAVMessage | None:
        if msg_id == mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED:
            index = int(param2)
            obs = self.airframe.sensor.observations
            return self._capture_msg(obs[index]) if 0 <= index < len(obs) else None
        return telemetry.build(msg_id, self)

    def _set_interval(self, msg_id: int, interval_us: float) -> int:
        if not telemetry.known(msg_id, self):
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
        result = self._set_mode(mode) if mode else self._mode_refused()
        return [mavlink.MAVLink_command_ack_message(mavlink.MAVLINK_MSG_ID_SET_MODE, result, 0, 0, *sender)]

    def _on_position_target(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if self.mode != Mode.GUIDED or self.landed:
            return []
        if self.ardupilot and not self.copter:
            return []  # ArduPlane ignores position targets; it flies DO_REPOSITION (flight §7)
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
        name = param_name(msg.param_id)
        if msg.param_index >= 0:
            name = names[msg.param_index] if msg.param_index < len(names) else ""
        return [self._param_value(name)] if name in self.params else []

    def _on_param_set(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        name = param_name(msg.param_id)
        if name not in self.params:
            return []
        self.params[name] = msg.param_value
        if name == "SIM_DRAIN_MULT":
            self.airframe.battery.drain_multiplier = msg.param_value
        elif name == "SIM_BATT_FAIL" and msg.param_value > 0:
            self.fail_battery()
        elif name == "BATT_CAPACITY" and msg.param_value > 0:
            self.airframe.battery.capacity_mah = msg.param_value  # remaining % follows at once (flight §5)
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

    @property
    def _rtl_alt_setting_m(self) -> float:
        if not self.ardupilot:
            return self.config.rtl_alt_m
        return self.params["RTL_ALT"] / 100.0 if self.copter else self.params["RTL_ALTITUDE"]

    def _mode_refused(self) -> int:
        return mavlink.MAV_RESULT_FAILED if self.ardupilot else mavlink.MAV_RESULT_DENIED

    def _prearm_refusals(self) -> list[str]:
        """ArduPilot's failing pre-arm checks, in its words (flight §1, §6): the boot milestones,
        the mission the mode needs, the battery. A copter needs the EKF's position only in
        modes that fly by position."""
        if not self.ardupilot:
            return []
        position_mode = self.mode in (Mode.GUIDED, Mode.AUTO, Mode.LOITER, Mode.RTL, Mode.LAND)
        reasons = boot_refusals(self.config.vehicle_type, self.boot, self.time_s, needs_position=position_mode)
        if self.copter and self.mode == Mode.AUTO and self.mission_total == 0:
            reasons.append("Mode requires mission")
        if not self.copter and self.params["RTL_AUTOLAND"] == 0 and self._land_start_seq() is not None:
            reasons.append("DO_LAND_START set and RTL_AUTOLAND disabled")
        return reasons + self._battery_refusals()

    def _arm_refusals(self) -> list[str]:
        """Why arming is refused now, one STATUSTEXT each; empty: it arms. ArduCopter's AUTO,
        RTL and LAND are not armable (checked once the pre-arm checks pass)."""
        if not self.ardupilot:
            if failsafe_level(self.airframe.battery.remaining_pct, self.config.battery) != FailsafeLevel.NONE:
                return ["PreArm: Battery below minimum arming level"]
            if self.mode in (Mode.RTL, Mode.LAND):
                return ["Arm: Mode not armable"]
            return []
        reasons = self._prearm_refusals()
        if not reasons and self.copter and self.mode in (Mode.AUTO, Mode.RTL, Mode.LAND):
            reasons.append(f"{self.mode.value} mode not armable")
        return [f"Arm: {r}" for r in reasons]

    def _battery_refusals(self) -> list[str]:
        b, p = self.airframe.battery, self.params
        volts = self.battery_voltage_v
        if 0 < p["BATT_ARM_VOLT"] and volts < p["BATT_ARM_VOLT"]:
            return ["Battery 1 below minimum arming voltage"]
        if 0 < p["BATT_ARM_MAH"] and b.remaining_mah < p["BATT_ARM_MAH"]:
            return ["Battery 1 below minimum arming capacity"]
        if 0 < p["BATT_LOW_VOLT"] and volts < p["BATT_LOW_VOLT"]:
            return ["Battery 1 low voltage failsafe"]
        level = failsafe_level(b.remaining_pct, self.config.battery)
        if level == FailsafeLevel.CRITICAL:
            return ["Battery 1 critical capacity failsafe"]
        if level == FailsafeLevel.LOW:
            return ["Battery 1 low capacity failsafe"]
        return []

    def _arm(self, arm: bool, force: bool) -> int:
        if not arm:
            if not self.landed and not force:
                if self.ardupilot:
                    return mavlink.MAV_RESULT_FAILED  # no text (flight §6)
                self.statustext("Disarm: vehicle is flying", mavlink.MAV_SEVERITY_WARNING)
                return mavlink.MAV_RESULT_DENIED
            self._disarm()
            return mavlink.MAV_RESULT_ACCEPTED
        if self.armed:
            return mavlink.MAV_RESULT_ACCEPTED
        if not force:
            refusals = self._arm_refusals()
            for text in refusals:
                self.statustext(text, mavlink.MAV_SEVERITY_CRITICAL)
            if refusals:
                return mavlink.MAV_RESULT_FAILED if self.ardupilot else mavlink.MAV_RESULT_DENIED
        self.armed = True
        self._auto_armed = False
        if not self.ardupilot:
            self.statustext("Arming motors")
            return mavlink.MAV_RESULT_ACCEPTED
        self.statustext("Arming motors" if self.copter else "Throttle armed")
        lat, lon = self.airframe.lat_lon_deg
        self._set_home(lat, lon, self.home.alt_m + self.airframe.kin.alt_m)  # home is where it arms
        if self.copter and self.params["DISARM_DELAY"] > 0:  # 0: never (ArduPilot's DISARM_DELAY)
            self._disarm_at_s = self.time_s + self.params["DISARM_DELAY"] * self._station_time_scale  # unless it flies
        return mavlink.MAV_RESULT_ACCEPTED

    def _clear_flight(self) -> None:
        """Disarmed: no landing, take-off or pending (auto-)disarm left over."""
        self.armed = False
        self.landing = False
        self._takeoff_alt_m = None
        self._disarm_at_s = None
        self._lift_at_s = None

    def _disarm(self) -> None:
        if self.armed:
            self.statustext("Disarming motors" if self.copter or not self.ardupilot else "Auto disarmed")
        self._clear_flight()
        self._auto_armed = False
        if self.ardupilot and self.copter and self.mode == Mode.AUTO:
            # the mission is reset: MISSION_CURRENT 0, then "Mission: 1 Takeoff" (flight §2)
            self.mission_seq = 0
            self._pending.append(telemetry.mission_current(self))
            self._restart_mission()
            self._announce_item()
            self._pending.append(telemetry.mission_current(self))

    def _set_home(self, lat_deg: float, lon_deg: float, alt_m: float) -> None:
        self.home = HomePose(lat_deg, lon_deg, alt_m, self.home.heading_deg)
        self.home_en = self.frame.geodetic2en(lat_deg, lon_deg)
        self.mission.set_home(lat_deg, lon_deg, alt_m)
        self.home_set = True
        self._pending.append(telemetry.home_position(self))

    def _set_mode(self, mode: Mode | None) -> int:
        if mode is None or mode not in mode_table(self.config.profile, self.config.vehicle_type):
            return self._mode_refused()
        if mode == Mode.AUTO:
            refused = self._auto_refused()
            if refused is not None:
                return refused
        if self.ardupilot and mode == Mode.RTL and not self.copter and not self.landed:
            if self.params["RTL_AUTOLAND"] == 2 and self._start_landing_sequence():
                return mavlink.MAV_RESULT_ACCEPTED  # straight to the runway (flight §3)
        was_auto = self.mode == Mode.AUTO
        self.mode = mode
        self.landing = False
        self._hold_until_s = None
        self._land_from = None
        if mode in (Mode.GUIDED, Mode.LOITER):
            self._target_en = self.airframe.position_en
            self._target_alt_m = self.airframe.kin.alt_m
        elif mode == Mode.RTL:
            # ArduCopter returns at RTL_ALT or higher; ArduPlane at RTL_ALTITUDE
            self._rtl_alt_m = self._rtl_alt_setting_m if self.ardupilot and not self.copter \
                else max(self.airframe.kin.alt_m, self._rtl_alt_setting_m)
        elif mode == Mode.TAKEOFF:
            self._takeoff_alt_m = self.config.takeoff_alt_m
        elif mode == Mode.AUTO and (not was_auto or self.mission_complete):
            self._start_or_resume()
        if mode != Mode.TAKEOFF and mode != Mode.GUIDED:
            self._takeoff_alt_m = None
        return mavlink.MAV_RESULT_ACCEPTED

    def _auto_refused(self) -> int | None:
        """Why AUTO cannot be entered now (None: it can). ArduCopter disarmed takes AUTO even
        without a mission; armed it needs one, and on the ground it must start with a take-off."""
        empty = len(self.mission.items()) <= self._first_seq
        if not self.ardupilot or not self.copter:
            if empty:
                self.statustext("Mode change to AUTO failed: no mission", mavlink.MAV_SEVERITY_WARNING)
                return self._mode_refused()
            return None
        if not self.armed:
            return None
        if self.landed and not empty and not self._starts_with_takeoff():
            self.statustext("Auto: Missing Takeoff Cmd", mavlink.MAV_SEVERITY_CRITICAL)
            empty = True
        if empty:
            self.statustext("Mode change to AUTO failed: init failed", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_FAILED
        return None

    def _starts_with_takeoff(self) -> bool:
        items = self.mission.items()
        seq = max(self.mission_seq, self._first_seq)
        nav = next((it for it in items[seq:] if it.command in NAV_COMMANDS), None)
        return nav is not None and nav.command == mavlink.MAV_CMD_NAV_TAKEOFF

    def _mission_start(self, p: tuple[float, ...]) -> int:
        if not self.ardupilot:
            if p[0] > 0:
                self._set_seq(int(p[0]))
            return self._set_mode(Mode.AUTO)
        if p[0] != 0 or p[1] != 0:
            return mavlink.MAV_RESULT_DENIED  # only (0, 0): DO_SET_MISSION_CURRENT says where (flight §2)
        if self.mode == Mode.AUTO:  # already running: a completed mission starts again
            if self.mission_complete:
                self._start_or_resume()
            result = mavlink.MAV_RESULT_ACCEPTED
        else:
            result = self._set_mode(Mode.AUTO)
        if result == mavlink.MAV_RESULT_ACCEPTED and self.armed:
            self._auto_armed = True  # a copter takes off without any throttle
        return result

    def _land_start_seq(self) -> int | None:
        return next((it.seq for it in self.mission.items()[1:] if it.command == mavlink.MAV_CMD_DO_LAND_START), None)

    def _start_landing_sequence(self) -> bool:
        """ArduPlane: AUTO from the first DO_LAND_START of the mission (its RTL with RTL_AUTOLAND
        2 does this at once, with 1 once home is reached, and MAV_CMD_DO_LAND_START on demand)."""
        seq = self._land_start_seq()
        if seq is None:
            return False
        self.statustext("Landing sequence start")
        self.mode = Mode.AUTO
        self.landing = False
        self._hold_until_s = None
        self._takeoff_alt_m = None
        self._set_seq(seq + 1)
        self._announce_item()
        return True

    def _takeoff(self, alt_m: float) -> int:
        if not self.armed:
            self.statustext("Takeoff: vehicle is not armed", mavlink.MAV_SEVERITY_WARNING)
            return self._mode_refused()
        if self.config.vehicle_type == "plane" or self.config.profile == "px4":
            self._set_mode(Mode.TAKEOFF)
        elif self.mode != Mode.GUIDED:
            self.statustext("Takeoff: requires GUIDED mode", mavlink.MAV_SEVERITY_WARNING)
            return self._mode_refused()
        self._takeoff_alt_m = alt_m if alt_m > 0 else self.config.takeoff_alt_m
        self._target_en, self._target_alt_m = None, self._takeoff_alt_m
        self._auto_armed = True
        return mavlink.MAV_RESULT_ACCEPTED

    def _reposition(self, p: tuple[float, ...], lat: float, lon: float, alt: float, frame: int) -> int:
        change_mode = int(p[1]) & mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
        if self.config.profile == "px4":
            change_mode = True
        holding = (Mode.GUIDED,) if self.ardupilot else (Mode.GUIDED, Mode.LOITER)
        if self.mode not in holding and not change_mode:
            self.statustext("Reposition: requires GUIDED mode", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_DENIED
        if self.landed:
            self.statustext("Reposition: vehicle is landed", mavlink.MAV_SEVERITY_WARNING)
            return mavlink.MAV_RESULT_DENIED
        if self.mode not in holding:
            self._set_mode(Mode.LOITER if self.config.profile == "px4" else Mode.GUIDED)
        if not (math.isnan(lat) or math.isnan(lon)):
            self._target_en = self.frame.geodetic2en(lat, lon)
        if not math.isnan(alt):
            self._target_alt_m = self._alt_rel(alt, frame)
        self._speed_m_s = p[0] if p[0] > 0 else None
        return mavlink.MAV_RESULT_ACCEPTED

    # ---- flight ------------------------------------------------------------------------

    def _alt_rel(self, alt_m: float, frame: int) -> float:
        absolute = frame in _ABSOLUTE_ALT_FRAMES or (self.ardupilot and frame == mavlink.MAV_FRAME_MISSION)
        return alt_m - self.home.alt_m if absolute else alt_m

    def step(self, dt_s: float) -> None:
        """Advance simulated time by dt (seconds; the fleet keeps dt at or under 0.1 s)."""
        self.time_s += dt_s
        if self.ardupilot:
            self._boot_step()
        battery = self.airframe.battery
        assert isinstance(battery, Battery)
        battery.step(dt_s, self.load, self.battery_voltage_v)
        self._check_failsafe()
        if self._disarm_at_s is not None and self.landed and self.time_s >= self._disarm_at_s:
            self._disarm()
        if not self.armed:
            self.airframe.stop()
            return
        goal = self._goal()
        if goal is None:
            return
        if self.landed and (goal.landing or goal.alt_m <= 0.5):
            if goal.landing and not self.ardupilot:
                self._touchdown()
            return
        if self.landed:
            self._disarm_at_s = None  # taking off
            if self.ardupilot:  # motors spool up / the plane rolls before it leaves the ground
                if self._lift_at_s is None:
                    self._lift_at_s = self.time_s + (_COPTER_SPOOL_S if self.copter else _PLANE_ROLL_S)
                if self.time_s < self._lift_at_s:
                    return
        self._lift_at_s = None
        self.landed = False
        self.landing = goal.landing
        body = self.airframe
        if goal.landing and self.ardupilot and self.copter and body.kin.alt_m < _LAND_SLOW_BELOW_M:
            goal.alt_m = max(goal.alt_m, body.kin.alt_m - _LAND_SLOW_M_S * dt_s)  # LAND_SPEED (flight §2)
        speed = self._speed_m_s
        if speed is not None and self.copter:
            speed = min(speed, max(_COPTER_MAX_SPEED_M_S, self.config.cruise_speed_m_s))
        body.step(dt_s, goal, speed)
        if goal.landing and body.kin.alt_m <= 0.0:
            self._touchdown()
        elif self.mode == Mode.AUTO:
            self._check_reached()
        if self.ardupilot and self.mode == Mode.RTL and not self.copter and self.params["RTL_AUTOLAND"] == 1 \
                and math.dist(self.home_en, body.position_en) <= body.limits.turn_radius_m * 2:
            self._start_landing_sequence()
        self._sense()

    def _sense(self) -> None:
        """The downward sensor's reading of this step, if any."""
        obs = self.airframe.sense(self.time_s)
        if obs is not None:
            self._pending.append(self._capture_msg(obs))
            if obs.reported:
                self.statustext(reading_text(obs), mavlink.MAV_SEVERITY_NOTICE)

    def _boot_step(self) -> None:
        """ArduPilot's start-up: the GPS fix, then home (HOME_POSITION is sent when it is set)
        and the EKF origin (GPS_GLOBAL_ORIGIN), and "PreArm:" every 30 s while it would
        refuse to arm (flight §1)."""
        b, t = self.boot, self.time_s
        if not self.home_set and t >= b.home_s:
            self._set_home(self.home.lat_deg, self.home.lon_deg, self.home.alt_m)
        if self.origin is None and t >= b.origin_s:
            self.origin = (self.home.lat_deg, self.home.lon_deg, self.home.alt_m)
            self._pending.append(telemetry.gps_global_origin(self))
        if t >= self._prearm_report_s:
            self._prearm_report_s += 30.0
            refusals = [] if self.armed else self._prearm_refusals()
            if refusals:
                self.statustext("PreArm: " + refusals[0], mavlink.MAV_SEVERITY_CRITICAL)

    def _capture_msg(self, obs: Observation) -> MAVMessage:
        alt_m = self.airframe.kin.alt_m
        return reading_message(obs, self.config.sensor, self.home.alt_m + alt_m, alt_m)

    def _check_failsafe(self) -> None:
        if self.ardupilot and not self.armed:
            return  # ArduPilot's battery failsafes act only while armed (flight §5)
        reached = failsafe_level(self.airframe.battery.remaining_pct, self.config.battery)
        trigger = failsafe_to_trigger(self.failsafe, reached)
        if trigger is None:
            return
        self.failsafe = trigger
        if not self.armed or self.landed:
            return
        pct = self.airframe.battery.remaining_pct
        can_land = Mode.LAND in mode_table(self.config.profile, self.config.vehicle_type)
        action = Mode.RTL if trigger == FailsafeLevel.LOW or not can_land else Mode.LAND
        if self.ardupilot:
            level = "low" if trigger == FailsafeLevel.LOW else "critical"
            self.statustext(f"Battery 1 is {level} {self.battery_voltage_v:.2f}V used "
                            f"{self.airframe.battery.consumed_mah:.0f} mAh", mavlink.MAV_SEVERITY_WARNING)
            self.statustext("Battery Failsafe", mavlink.MAV_SEVERITY_WARNING)
        elif trigger == FailsafeLevel.LOW:
            self.statustext(f"Battery failsafe: low {pct:.0f}%, RTL", mavlink.MAV_SEVERITY_CRITICAL)
        else:
            self.statustext(f"Battery failsafe: critical {pct:.0f}%, {action.name}", mavlink.MAV_SEVERITY_EMERGENCY)
        self._set_mode(action)

    def _touchdown(self) -> None:
        descent = self.airframe.touch_down()
        was_flying = not self.landed
        self.landed = True
        self.landing = self.ardupilot and self.copter  # reported LANDING until it disarms
        self._land_from = None
        if not self.ardupilot:
            if was_flying:
                self.statustext("Land complete")
            if self.mode == Mode.AUTO and self.mission_seq < len(self.mission.items()):
                self._reach(self.mission_seq)
            self._disarm()
            return
        # ArduPilot sends no MISSION_ITEM_REACHED for NAV_LAND (a mission's RTL item is reached
        # on the ground); a copter disarms 2 s after touching down, a plane LAND_DISARMDELAY
        # (20 s) after (flight §2, §3)
        if was_flying:
            self.statustext(f"SIM Hit ground at {descent:.2f} m/s")
        items = self.mission.items()
        if self.mode == Mode.AUTO and self.mission_seq < len(items) \
                and items[self.mission_seq].command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            self._reach(self.mission_seq)
        delay = 2.0 if self.copter else self.params["LAND_DISARMDELAY"]
        self._disarm_at_s = self.time_s + delay


def param_name(raw: bytes | str) -> str:
    """A PARAM_* message's name field as text."""
    if isinstance(raw, bytes):
        raw = raw.decode(errors="replace")
    return raw.rstrip("\x00")
