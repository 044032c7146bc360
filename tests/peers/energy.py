"""Scripted flights that measure what a vehicle's battery reports, phase by phase, on any MAVLink
vehicle (ArduPilot or PX4 SITL, or the simulator): `benchmarks/measure_energy.py` flies them on
SITL, `tests/gcs/autopilots/test_sim_energy.py` on SITL and on the simulator side by side.

A flight is one mission (`Course`): take-off, a hover or loiter, straight legs at set speeds,
a zig-zag of 90-degree turns and a straight line of the same length, a landing. `fly` arms the
vehicle, waits on the ground armed, starts the mission and records, at every BATTERY_STATUS,
the battery (`current_consumed`, `energy_consumed`, `current_battery`, voltage, remaining),
SYS_STATUS, VFR_HUD, the reported wind (ArduPilot's WIND, PX4's WIND_COV), the position and the
mission item flown, in vehicle time. `analyse` cuts the record into the phases by mission item
and altitude and returns per phase charge, time, distance and means."""

from __future__ import annotations

import math
import os
import struct
import time
from dataclasses import asdict, dataclass, field

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import WireItem
from planner.georef import LocalFrame
from tests.sim.mission_client import MissionClient, MissionTransferError

REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
STREAMS_HZ = {mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 5.0, mavlink.MAVLINK_MSG_ID_SYS_STATUS: 5.0,
              mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0, mavlink.MAVLINK_MSG_ID_VFR_HUD: 5.0,
              mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 2.0, mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 2.0,
              mavlink.MAVLINK_MSG_ID_WIND: 2.0, mavlink.MAVLINK_MSG_ID_WIND_COV: 2.0,
              mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.5}
INT_PARAMS = frozenset({"BAT1_N_CELLS", "BAT1_SOURCE", "SIM_BAT_ENABLE"})  # PX4's INT32 ones
#: legs are measured where the vehicle is between these fractions of the way along them
STEADY = (0.25, 0.8)


@dataclass(frozen=True, slots=True)
class Step:
    """One mission item and what it measures: `kind` takeoff, hover, leg, zigzag, straight, stop,
    land or speed (DO_CHANGE_SPEED); legs carry their start and end (metres east, north)."""

    kind: str
    label: str = ""
    end_en: tuple[float, float] = (0.0, 0.0)
    start_en: tuple[float, float] = (0.0, 0.0)
    value: float = 0.0  # hover seconds, take-off altitude, speed


@dataclass(frozen=True, slots=True)
class Course:
    """A mission as steps, flown at `alt_m` above home."""

    steps: tuple[Step, ...]
    alt_m: float
    plane: bool = False


def _legs(start: tuple[float, float], ends: list[tuple[float, float]], label: str) -> list[Step]:
    out, here = [], start
    for i, end in enumerate(ends):
        heading = round(math.degrees(math.atan2(end[0] - here[0], end[1] - here[1]))) % 360
        out.append(Step("leg", f"{label} hdg {heading:03d}" + (f" #{i + 1}" if len(ends) > 2 else ""), end, here))
        here = end
    return out


def copter_course(*, alt_m: float = 60.0, leg_m: float = 600.0, speeds: tuple[float | None, ...] = (None, 5, 10, 15),
                  hover_s: float = 20.0, directions: str = "NS", turns: bool = True,
                  default_speed_m_s: float = 10.0) -> Course:
    """Take-off to `alt_m`, hover, for each speed (None: the autopilot's default) legs of `leg_m`
    north and back south (`directions` "NSEW": also east and back west), a stop, a zig-zag of eight
    50 m legs turning 90 degrees and the same 400 m straight, stops around both, back home and
    landing there (ArduCopter's home moves to where it arms)."""
    steps = [Step("takeoff", "take-off", value=alt_m), Step("hover", "hover", value=hover_s)]
    origin = (0.0, 0.0)
    for speed in speeds:
        name = f"{default_speed_m_s if speed is None else speed:g} m/s" + (" (default)" if speed is None else "")
        steps.append(Step("speed", value=default_speed_m_s if speed is None else float(speed)))
        ends = [(0.0, leg_m), origin] + ([(leg_m, 0.0), origin] if "E" in directions else [])
        steps += _legs(origin, ends, f"cruise {name}")
    if turns:
        steps.append(Step("speed", value=default_speed_m_s))
        steps.append(Step("stop", "stop", origin, value=3.0))
        zig = [(50.0 * ((i + 1) // 2), 50.0 * ((i + 2) // 2)) for i in range(8)]  # N, E, N, E ...
        steps += [Step("zigzag", "zig-zag 8 x 50 m", end) for end in zig]
        steps.append(Step("stop", "stop", zig[-1], value=3.0))
        straight = (zig[-1][0], zig[-1][1] + 400.0)
        steps.append(Step("straight", "straight 400 m", straight, zig[-1]))
        steps.append(Step("stop", "stop", straight, value=3.0))
        steps.append(Step("leg", "back to home", origin, straight))  # the next flight's home is here
    steps.append(Step("land", "landing", origin))
    return Course(tuple(steps), alt_m)


def plane_course(*, alt_m: float = 60.0, leg_m: float = 2000.0, loiter_s: float = 60.0, directions: str = "EW",
                 turns: bool = True) -> Course:
    """ArduPlane from a runway heading east at home: auto take-off to `alt_m`, out 1200 m east, a
    loiter, legs of `leg_m` east and back west (`directions` "EWNS": also north and back south),
    a zig-zag of six 300 m legs turning 90 degrees and an 1800 m straight, and a landing from the
    west on the runway (DO_LAND_START, an approach 1400 m out at `alt_m`, NAV_LAND at home)."""
    steps = [Step("takeoff", "take-off", value=alt_m), Step("leg", "climb-out", (1200.0, 0.0)),
             Step("hover", "loiter", (1200.0, 800.0), value=loiter_s)]
    a = (500.0, 1500.0)
    ends = [(a[0] + leg_m, a[1]), a] + ([(a[0], a[1] + leg_m), a] if "N" in directions else [])
    steps += [Step("leg", "approach to legs", a)] + _legs(a, ends, "cruise")
    if turns:
        zig = [(a[0] - 300.0 * ((i + 2) // 2), a[1] - 300.0 * ((i + 1) // 2)) for i in range(6)]  # W, S, W ...
        steps += [Step("zigzag", "zig-zag 6 x 300 m", end) for end in zig]
        straight = (zig[-1][0], zig[-1][1] + 1800.0)
        steps.append(Step("straight", "straight 1800 m", straight, zig[-1]))
    steps += [Step("landstart", "land start"), Step("leg", "approach", (-1400.0, 0.0)),
              Step("land", "landing", (0.0, 0.0))]
    return Course(tuple(steps), alt_m, plane=True)


@dataclass(slots=True)
class Sample:
    """What the vehicle reported at one BATTERY_STATUS (vehicle time `t_s`)."""

    t_s: float
    seq: int
    armed: bool
    landed_state: int
    east_m: float
    north_m: float
    alt_m: float
    path_m: float
    groundspeed: float
    airspeed: float
    climb: float
    throttle: int
    voltage_v: float
    current_a: float
    consumed_mah: int
    energy_hj: int
    remaining: int
    time_remaining_s: int
    sys_voltage_v: float
    sys_current_a: float
    sys_remaining: int
    wind_from_deg: float
    wind_m_s: float


@dataclass
class Record:
    """A flight's samples, the parameters read, the mission's steps (index = mission seq of the
    first real item) and when it started."""

    vehicle: str
    autopilot: str
    params: dict[str, float]
    steps: list[Step]
    seq_offset: int
    samples: list[Sample] = field(default_factory=list)
    start_t_s: float = math.nan
    armed_t_s: float = math.nan
    texts: list[tuple[float, str]] = field(default_factory=list)

    def step_of(self, seq: int) -> Step | None:
        i = seq - self.seq_offset
        return self.steps[i] if 0 <= i < len(self.steps) else None


class Station:
    """A pymavlink ground station on one vehicle that keeps the latest of every message it needs
    and a vehicle clock (GLOBAL_POSITION_INT's time_boot_ms)."""

    def __init__(self, conn, sysid: int, px4: bool, speedup: float) -> None:
        self.conn, self.sysid, self.px4, self.speedup = conn, sysid, px4, speedup
        self.latest: dict[str, object] = {}
        self.t_s = 0.0
        self.path_m = 0.0
        self.frame: LocalFrame | None = None
        self._last_en: tuple[float, float] | None = None
        self.on_battery = None
        self.texts: list[tuple[float, str]] = []

    def recv(self, timeout_s: float = 0.05):
        msg = self.conn.recv_match(blocking=True, timeout=timeout_s)
        if msg is None or msg.get_srcSystem() != self.sysid or msg.get_type() == "BAD_DATA":
            return msg
        kind = msg.get_type()
        if kind == "HEARTBEAT" and msg.get_srcComponent() != 1:
            return msg  # a camera's, not the autopilot's
        self.latest[kind] = msg
        if kind == "GLOBAL_POSITION_INT":
            self.t_s = msg.time_boot_ms / 1000.0
            if self.frame is not None:
                en = self.frame.geodetic2en(msg.lat / 1e7, msg.lon / 1e7)
                if self._last_en is not None:
                    self.path_m += math.dist(en, self._last_en)
                self._last_en = en
        elif kind == "STATUSTEXT":
            self.texts.append((self.t_s, msg.text))
        elif kind == "BATTERY_STATUS" and self.on_battery is not None:
            self.on_battery(msg)
        return msg

    def wall_s(self, vehicle_s: float) -> float:
        return vehicle_s / self.speedup + 5.0

    def wait(self, kind: str, pred=lambda m: True, timeout_s: float = 30.0):
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            msg = self.recv()
            if msg is not None and msg.get_type() == kind and msg.get_srcSystem() == self.sysid and pred(msg):
                return msg
        return None

    def run_for(self, vehicle_s: float) -> None:
        end = self.t_s + vehicle_s
        deadline = time.monotonic() + self.wall_s(vehicle_s)
        while self.t_s < end and time.monotonic() < deadline:
            self.recv()

    def command(self, command: int, *params: float, timeout_s: float = 3.0) -> int | None:
        p = list(params) + [0.0] * (7 - len(params))
        self.conn.mav.command_long_send(self.sysid, 1, command, 0, *p)
        ack = self.wait("COMMAND_ACK", lambda m: m.command == command, timeout_s)
        return None if ack is None else ack.result

    def set_param(self, name: str, value: float, *, integer: bool = False) -> None:
        wire = struct.unpack("<f", struct.pack("<i", int(value)))[0] if integer and self.px4 else float(value)
        ptype = mavlink.MAV_PARAM_TYPE_INT32 if integer else mavlink.MAV_PARAM_TYPE_REAL32
        for _ in range(20):
            self.conn.mav.param_set_send(self.sysid, 1, name.encode(), wire, ptype)
            if self.wait("PARAM_VALUE", lambda m: m.param_id.rstrip("\x00") == name, 1.0) is not None:
                return
        raise RuntimeError(f"{name} not confirmed")

    def get_param(self, name: str, *, integer: bool = False) -> float:
        for _ in range(20):
            self.conn.mav.param_request_read_send(self.sysid, 1, name.encode(), -1)
            msg = self.wait("PARAM_VALUE", lambda m: m.param_id.rstrip("\x00") == name, 1.0)
            if msg is not None:
                if integer and self.px4:
                    return float(struct.unpack("<i", struct.pack("<f", msg.param_value))[0])
                return float(msg.param_value)
        return math.nan

    def streams(self) -> None:
        for msg_id, hz in STREAMS_HZ.items():
            self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, timeout_s=1.0)

    def set_mode(self, ardupilot_mode: int, px4_main_sub: tuple[int, int]) -> int | None:
        if self.px4:
            return self.command(mavlink.MAV_CMD_DO_SET_MODE, 1, *px4_main_sub)
        return self.command(mavlink.MAV_CMD_DO_SET_MODE, 1, ardupilot_mode)

    @property
    def armed(self) -> bool:
        hb = self.latest.get("HEARTBEAT")
        return bool(hb is not None and hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)


def _item(seq: int, frame: int, command: int, lat: float = 0.0, lon: float = 0.0, z: float = 0.0,
          *params: float) -> WireItem:
    p = list(params) + [0.0] * (4 - len(params))
    return WireItem(seq=seq, frame=frame, command=command, x=round(lat * 1e7), y=round(lon * 1e7), z=z,
                    param1=p[0], param2=p[1], param3=p[2], param4=p[3])


def mission_items(course: Course, frame: LocalFrame, *, ardupilot: bool) -> list[WireItem]:
    """The course as MAVLink items (ArduPilot: a home placeholder at seq 0)."""
    items = [_item(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT)] if ardupilot else []
    alt = course.alt_m
    for step in course.steps:
        seq = len(items)
        lat, lon = frame.en2geodetic(*step.end_en)
        if step.kind == "takeoff":
            lat0, lon0 = frame.en2geodetic(0.0, 0.0)
            pitch = 15.0 if course.plane else 0.0
            items.append(_item(seq, REL, mavlink.MAV_CMD_NAV_TAKEOFF, lat0 if not ardupilot else 0.0,
                               lon0 if not ardupilot else 0.0, step.value, pitch, 0, 0, math.nan))
        elif step.kind in ("hover", "stop"):
            items.append(_item(seq, REL, mavlink.MAV_CMD_NAV_LOITER_TIME, lat, lon, alt, step.value))
        elif step.kind == "speed":
            kind = 0 if course.plane else 1  # airspeed / ground speed
            items.append(_item(seq, mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 0, 0,
                               kind, step.value, -1, 0))
        elif step.kind == "landstart":
            items.append(_item(seq, REL, mavlink.MAV_CMD_DO_LAND_START, lat, lon, 0.0))
        elif step.kind == "land":
            items.append(_item(seq, REL, mavlink.MAV_CMD_NAV_LAND, lat, lon, 0.0, 0, 0, 0, math.nan))
        else:
            items.append(_item(seq, REL, mavlink.MAV_CMD_NAV_WAYPOINT, lat, lon, alt, 0, 0, 0, math.nan))
    return items


def connect(station: Station, *, vehicle: str, timeout_s: float = 120.0) -> tuple[float, float, float]:
    """Streams asked for; home (lat, lon, AMSL) once the vehicle can arm."""
    conn = station.conn
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        if station.wait("HEARTBEAT", timeout_s=1.0) is not None:
            break
    station.streams()
    while time.monotonic() < deadline:
        station.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION, timeout_s=0.5)
        home = station.wait("HOME_POSITION", timeout_s=1.0)
        if home is not None:
            return home.latitude / 1e7, home.longitude / 1e7, home.altitude / 1000.0
    raise RuntimeError("no HOME_POSITION")


def _sample(st: Station, bs) -> Sample:
    g = st.latest.get
    gpi, hud, sysst, ext, cur = g("GLOBAL_POSITION_INT"), g("VFR_HUD"), g("SYS_STATUS"), g("EXTENDED_SYS_STATE"), \
        g("MISSION_CURRENT")
    en = st._last_en or (math.nan, math.nan)
    wind_from, wind_speed = math.nan, math.nan
    if (w := g("WIND")) is not None:
        wind_from, wind_speed = w.direction % 360, w.speed
    elif (w := g("WIND_COV")) is not None and not math.isnan(w.wind_x):
        # WIND_COV: the wind's velocity north (x) and east (y), where it blows to
        wind_speed = math.hypot(w.wind_x, w.wind_y)
        wind_from = (math.degrees(math.atan2(w.wind_y, w.wind_x)) + 180.0) % 360
    return Sample(
        t_s=st.t_s, seq=cur.seq if cur is not None else -1, armed=st.armed,
        landed_state=ext.landed_state if ext is not None else 0, east_m=en[0], north_m=en[1],
        alt_m=gpi.relative_alt / 1000.0 if gpi is not None else math.nan, path_m=st.path_m,
        groundspeed=hud.groundspeed if hud is not None else math.nan,
        airspeed=hud.airspeed if hud is not None else math.nan,
        climb=hud.climb if hud is not None else math.nan, throttle=hud.throttle if hud is not None else -1,
        voltage_v=bs.voltages[0] / 1000.0 if bs.voltages[0] != 0xFFFF else math.nan,
        current_a=bs.current_battery / 100.0, consumed_mah=bs.current_consumed, energy_hj=bs.energy_consumed,
        remaining=bs.battery_remaining, time_remaining_s=getattr(bs, "time_remaining", 0),
        sys_voltage_v=sysst.voltage_battery / 1000.0 if sysst is not None else math.nan,
        sys_current_a=sysst.current_battery / 100.0 if sysst is not None else math.nan,
        sys_remaining=sysst.battery_remaining if sysst is not None else -1,
        wind_from_deg=wind_from, wind_m_s=wind_speed)


#: how long a course is recorded after the disarm (its "disarmed" phase). PX4 filters the voltage
#: it reads with a 1 s time constant: 3 s after the disarm its estimate reads 97.5 %, and the
#: heartbeat that says "disarmed" comes up to a second after the disarm, so 3 s read 96-99 %
#: (ci44, ci60, the real CI of 7288668); at 5 s it reads 99 % or more
AFTER_DISARM_S = 5.0


def fly(station: Station, course: Course, *, vehicle: str, idle_s: float = 6.0, params: tuple[str, ...] = (),
        setup: dict[str, float] | None = None, arm_timeout_s: float = 120.0) -> Record:
    """Set the `setup` parameters, upload the course, arm, stay `idle_s` on the ground armed, fly
    it, and record until the vehicle has been disarmed `AFTER_DISARM_S` and reported its battery once more;
    `params` are read first."""
    lat, lon, _ = connect(station, vehicle=vehicle)
    for name, value in (setup or {}).items():
        station.set_param(name, value)
    frame = LocalFrame(lat, lon)
    station.frame = frame
    ardupilot = not station.px4
    items = mission_items(course, frame, ardupilot=ardupilot)
    for attempt in range(3):  # PX4 SITL now and then answers an upload with MAV_MISSION_ERROR
        try:
            MissionClient(station.conn, station.sysid, timeout_s=0.5, deadline_s=60.0).upload(items)
            break
        except MissionTransferError:
            if attempt == 2:
                raise
            station.run_for(2.0)
    read = {name: station.get_param(name, integer=name in INT_PARAMS) for name in params}
    record = Record(vehicle, "px4" if station.px4 else "ardupilot", read, list(course.steps), int(ardupilot))
    station.on_battery = lambda bs: record.samples.append(_sample(station, bs))
    if ardupilot:  # ArduPlane refuses to arm while its last flight's landing sequence is current
        station.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 1, 1)
    # arm where the vehicle waits on the ground: GUIDED (copter), MANUAL (plane), Hold (PX4)
    deadline = time.monotonic() + arm_timeout_s
    while not station.armed:
        if time.monotonic() > deadline:
            raise RuntimeError(f"the vehicle would not arm: {[t for _, t in station.texts[-5:]]}")
        station.set_mode(0 if course.plane else 4, (4, 3))
        if station.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mavlink.MAV_RESULT_ACCEPTED:
            station.wait("HEARTBEAT", lambda m: m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 5.0)
            break
        station.run_for(1.0)
    record.armed_t_s = station.t_s
    station.run_for(idle_s)
    record.start_t_s = station.t_s
    if course.plane:
        station.set_mode(10, (4, 4))
    else:
        if ardupilot:
            station.set_mode(3, (4, 4))
        station.command(mavlink.MAV_CMD_MISSION_START, 0, 0)
    # an hour of vehicle time at most; a loaded machine runs SITL slower than its speed-up
    deadline = time.monotonic() + 4 * station.wall_s(3600.0)
    while station.armed and station.t_s < record.start_t_s + 3600.0 and time.monotonic() < deadline:
        station.recv()
    station.run_for(AFTER_DISARM_S)
    # and the first battery report at or after those seconds: the vehicle's clock can pass them between
    # two reports, the last one then older than 3 s (a recovering reading lower than it should be)
    station.wait("BATTERY_STATUS", timeout_s=station.wall_s(3.0))
    station.on_battery = None
    record.texts = station.texts
    return record


# ---- analysis -------------------------------------------------------------------------------


@dataclass
class Phase:
    """Charge, time, distance and means over a stretch of a flight. `mah` is the autopilot's
    `current_consumed` difference, `mah_from_current` the current integrated over the samples."""

    name: str
    kind: str
    seconds: float
    metres: float
    mah: float
    mah_from_current: float
    energy_j: float
    mean_current_a: float
    mean_voltage_v: float
    min_voltage_v: float
    remaining_from: float
    remaining_to: float
    groundspeed: float
    airspeed: float
    throttle: float
    wind_from_deg: float
    wind_m_s: float

    @property
    def mah_per_s(self) -> float:
        return self.mah / self.seconds if self.seconds > 0 else math.nan

    @property
    def mah_per_m(self) -> float:
        """Per metre over the ground; none for a phase that goes (almost) nowhere."""
        return self.mah / self.metres if self.metres >= 10.0 else math.nan

    def as_dict(self) -> dict:
        return asdict(self) | {"mah_per_s": self.mah_per_s, "mah_per_m": self.mah_per_m}


def _mean(values: list[float]) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return sum(finite) / len(finite) if finite else math.nan


def _circular_mean_deg(values: list[float]) -> float:
    finite = [math.radians(v) for v in values if not math.isnan(v)]
    if not finite:
        return math.nan
    return math.degrees(math.atan2(sum(map(math.sin, finite)), sum(map(math.cos, finite)))) % 360


def phase(name: str, kind: str, samples: list[Sample]) -> Phase | None:
    if len(samples) < 2:
        return None
    a, b = samples[0], samples[-1]
    integrated = sum(max(p.current_a, 0.0) * (q.t_s - p.t_s) for p, q in zip(samples, samples[1:])) / 3.6
    return Phase(
        name, kind, b.t_s - a.t_s, b.path_m - a.path_m, float(b.consumed_mah - a.consumed_mah), integrated,
        100.0 * (b.energy_hj - a.energy_hj), _mean([s.current_a for s in samples]),
        _mean([s.voltage_v for s in samples]), min(s.voltage_v for s in samples), a.remaining, b.remaining,
        _mean([s.groundspeed for s in samples]), _mean([s.airspeed for s in samples]),
        _mean([float(s.throttle) for s in samples]), _circular_mean_deg([s.wind_from_deg for s in samples]),
        _mean([s.wind_m_s for s in samples]))


def _along(s: Sample, step: Step) -> float:
    (x0, y0), (x1, y1) = step.start_en, step.end_en
    dx, dy = x1 - x0, y1 - y0
    return ((s.east_m - x0) * dx + (s.north_m - y0) * dy) / (dx * dx + dy * dy)


def analyse(record: Record) -> list[Phase]:
    """The phases of a flight: armed idle on the ground; take-off to 30 m and to the course's
    altitude; hover or loiter (its time but the first 3 s); each leg's steady middle; zig-zag and
    straight; the landing from the course's altitude and from 30 m, to the disarm; after it."""
    out: list[Phase] = []
    s = record.samples
    steps = record.steps

    def add(p: Phase | None) -> None:
        if p is not None:
            out.append(p)

    idle = [x for x in s if record.armed_t_s + 1.0 <= x.t_s <= record.start_t_s - 0.5]
    add(phase("armed idle on the ground", "idle", idle))
    flight = [x for x in s if x.t_s >= record.start_t_s]
    top = next((st.value for st in steps if st.kind == "takeoff"), 0.0)
    for height in sorted({30.0, top}):
        upto = next((i for i, x in enumerate(flight) if x.alt_m >= height - 0.5), None)
        if upto is not None:
            add(phase(f"take-off to {height:g} m", "takeoff", flight[:upto + 1]))
    for i, st in enumerate(steps):
        seq = i + record.seq_offset
        during = [x for x in flight if x.seq == seq]
        if not during:
            continue
        if st.kind == "hover":  # the last seconds of it: a plane flies to its loiter first
            add(phase(st.label, "hover", [x for x in during if x.t_s >= during[-1].t_s - st.value + 3.0]))
        elif st.kind == "leg" and st.label.startswith("cruise"):
            add(phase(st.label, "leg", [x for x in during if STEADY[0] <= _along(x, st) <= STEADY[1]]))
    for kind in ("zigzag", "straight"):
        seqs = [i + record.seq_offset for i, st in enumerate(steps) if st.kind == kind]
        if seqs:
            label = next(st.label for st in steps if st.kind == kind)
            add(phase(label, kind, [x for x in flight if x.seq in seqs]))
    land_seq = next((i + record.seq_offset for i, st in enumerate(steps) if st.kind == "land"), None)
    begin = next((i for i, x in enumerate(flight) if x.seq == land_seq), None)
    if begin is not None:
        landing = flight[begin:]
        end = next((i for i, x in enumerate(landing) if not x.armed), len(landing))
        landing = landing[:end + 1]
        for height in sorted({top, 30.0}, reverse=True):
            first = next((i for i, x in enumerate(landing) if x.alt_m <= height - 0.5), None)
            if first is not None:
                add(phase(f"landing from {height:g} m", "land", landing[max(first - 1, 0):]))
    disarmed = next((i for i, x in enumerate(flight) if not x.armed), None)
    if disarmed is not None:
        add(phase("disarmed", "disarmed", flight[max(disarmed - 1, 0):]))
    return out
