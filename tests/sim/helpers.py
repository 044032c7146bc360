"""Helpers for the simulator tests: a pymavlink ground station and mission-building shortcuts."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim import HomePose, SimVehicle, VehicleConfig, WireItem

HOME = HomePose(-35.363261, 149.165230, 584.0, 0.0)
# ArduPilot's start-up (GPS fix, home, EKF position) at 5 % of the measured times: a copter is
# ready to arm 2.1 s of vehicle time after boot instead of 42 s. Tests about start-up use 1.
FAST_BOOT = 0.05
# what a ground station asks ArduPilot for (gcs.autopilots.Autopilot.streams_hz), Hz
STREAMS_HZ = {
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 4.0, mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0, mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0, mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
    mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT: 1.0, mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
}


def fast(**config) -> VehicleConfig:
    """A vehicle config with `FAST_BOOT` unless the test says otherwise."""
    config.setdefault("boot_scale", FAST_BOOT)
    return VehicleConfig(**config)


class Gcs:
    """A minimal pymavlink ground station talking to one simulated vehicle."""

    def __init__(self, address: tuple[str, int], target_system: int = 1, **kwargs) -> None:
        host, port = address
        self.conn = mavutil.mavlink_connection(
            f"udpout:{host}:{port}", source_system=255, source_component=190, dialect="ardupilotmega", **kwargs
        )
        self.target = (target_system, 1)
        self.mav = self.conn.mav

    def hello(self, timeout_s: float = 5.0) -> mavlink.MAVLink_message:
        """Announce ourselves (the vehicle answers whoever spoke last) and wait for a heartbeat."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            msg = self.wait("HEARTBEAT", timeout_s=0.3, check=False)
            if msg is not None:
                return msg
        raise AssertionError("no HEARTBEAT from the simulator")

    def wait(self, types: str | list[str], pred: Callable | None = None, timeout_s: float = 10.0,
             check: bool = True):
        end = time.monotonic() + timeout_s
        while True:
            left = end - time.monotonic()
            if left <= 0:
                if check:
                    raise AssertionError(f"no {types} matching within {timeout_s} s")
                return None
            msg = self.conn.recv_match(type=types, blocking=True, timeout=left)
            if msg is None or msg.get_srcSystem() != self.target[0]:
                continue
            if pred is None or pred(msg):
                return msg

    def command(self, command: int, *params: float, timeout_s: float = 5.0) -> int:
        p = list(params) + [0.0] * (7 - len(params))
        self.mav.command_long_send(*self.target, command, 0, *p)
        ack = self.wait("COMMAND_ACK", lambda m: m.command == command, timeout_s)
        return ack.result

    def command_int(self, command: int, frame: int, p: tuple[float, float, float, float],
                    x: int, y: int, z: float) -> int:
        self.mav.command_int_send(*self.target, frame, command, 0, 0, *p, x, y, z)
        return self.wait("COMMAND_ACK", lambda m: m.command == command).result

    def set_mode(self, custom_mode: int) -> int:
        return self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, custom_mode)

    def request_streams(self, streams_hz: dict[int, float] | None = None) -> None:
        """Ask for telemetry as a ground station must (ArduCopter streams nothing unasked)."""
        for msg_id, hz in (streams_hz or STREAMS_HZ).items():
            assert self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz) == mavlink.MAV_RESULT_ACCEPTED

    def wait_ready(self, timeout_s: float = 20.0) -> mavlink.MAVLink_message:
        """Streams asked for, then until ArduPilot would arm in GUIDED: the EKF uses an absolute
        position (POS_HORIZ_ABS, not CONST_POS_MODE) and a home is set; the HOME_POSITION."""
        self.request_streams()
        self.wait("EKF_STATUS_REPORT", lambda m: m.flags & mavlink.EKF_POS_HORIZ_ABS
                  and not m.flags & mavlink.EKF_CONST_POS_MODE, timeout_s)
        return self.wait("HOME_POSITION", timeout_s=timeout_s)

    def close(self) -> None:
        self.conn.close()


def offset(home: HomePose, east_m: float, north_m: float) -> tuple[float, float]:
    lat = home.lat_deg + north_m / 111_319.49
    lon = home.lon_deg + east_m / (111_319.49 * math.cos(math.radians(home.lat_deg)))
    return lat, lon


def waypoint(seq: int, lat: float, lon: float, alt_m: float, **params: float) -> WireItem:
    return WireItem(seq=seq, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command=mavlink.MAV_CMD_NAV_WAYPOINT,
                    x=round(lat * 1e7), y=round(lon * 1e7), z=alt_m, **params)


def home_placeholder() -> WireItem:
    return WireItem(seq=0, frame=mavlink.MAV_FRAME_GLOBAL, command=mavlink.MAV_CMD_NAV_WAYPOINT)


def distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    dn = (lat2 - lat1) * 111_319.49
    de = (lon2 - lon1) * 111_319.49 * math.cos(math.radians(lat1))
    return math.hypot(de, dn)


STATION = (255, 190)  # the system and component id a stepped vehicle hears its station as


@dataclass
class SteppedVehicle:
    """One vehicle stepped by hand (no sockets), a clock and everything it sent, as (vehicle
    seconds, message); each profile's tests add the station's commands in that profile's words."""

    v: SimVehicle
    sent: list = field(default_factory=list)

    def run(self, seconds: float, until=None, dt: float = 0.05, station: bool = False) -> None:
        """Step for `seconds` (or until `until(vehicle)`); `station`: a ground station's HEARTBEAT
        every second, as over a real link."""
        end = self.v.time_s + seconds
        while self.v.time_s < end - 1e-9:
            if station and math.floor(self.v.time_s + dt) > math.floor(self.v.time_s):
                self.handle(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID,
                                                              0, 0, 0, 3))
            self.v.step(dt)
            self.sent += [(self.v.time_s, m) for m in self.v.emit() + self.v.poll(0.0)]
            if until is not None and until(self.v):
                return
        assert until is None, f"not reached within {seconds} s"

    def handle(self, msg) -> list:
        msg._header = mavlink.MAVLink_header(msg.id, srcSystem=STATION[0], srcComponent=STATION[1])
        out = self.v.handle(msg, 0.0) + self.v.emit()
        self.sent += [(self.v.time_s, m) for m in out]
        return out

    def command(self, command: int, *params: float) -> int:
        p = list(params) + [0.0] * (7 - len(params))
        out = self.handle(mavlink.MAVLink_command_long_message(1, 1, command, 0, *p))
        return next(m.result for m in out if m.get_type() == "COMMAND_ACK")

    def mark(self) -> int:
        """A place in what was sent, for `texts(since=...)`."""
        return len(self.sent)

    def texts(self, since: int = 0) -> list[str]:
        return [m.text for _, m in self.sent[since:] if m.get_type() == "STATUSTEXT"]

    def said(self, action, *args) -> tuple:
        """`action(*args)`'s result and the texts the vehicle sent meanwhile."""
        mark = self.mark()
        return action(*args), self.texts(mark)

    def of(self, kind: str, since: float = -1.0) -> list:
        return [(t, m) for t, m in self.sent if m.get_type() == kind and t >= since]

    def first(self, kind: str, pred=lambda m: True) -> float:
        return next(t for t, m in self.sent if m.get_type() == kind and pred(m))
