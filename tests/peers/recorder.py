"""An independent recorder on a vehicle's spare MAVLink port: what a crew judges a flight by, read
from the vehicle itself, not from the station's log. Where it flew (GLOBAL_POSITION_INT), its
battery (BATTERY_STATUS), whether it is down (HEARTBEAT armed bit, EXTENDED_SYS_STATE); from that,
how many of its planned waypoints it passed and the battery it touched down with.

ArduPilot SITL's spare port is SERIAL2 (TCP 5763 + 10 I); PX4 SITL's the onboard API port
(14580 + I, which sends to 14540 + I). The recorder asks for its own streams on its own link
(SET_MESSAGE_INTERVAL is per link on both autopilots), so the station's settings do not matter."""

from __future__ import annotations

import math
import os
import threading
import time
from dataclasses import dataclass, field

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

#: GLOBAL_POSITION_INT, BATTERY_STATUS, EXTENDED_SYS_STATE, SYS_STATUS
STREAMS_HZ = {33: 4.0, 147: 1.0, 245: 1.0, 1: 1.0}


@dataclass
class Flown:
    """What a recorder saw: positions (lat, lon, relative altitude), battery readings (vehicle
    time, %) and when it was down after flying."""

    positions: list[tuple[float, float, float]] = field(default_factory=list)
    battery: list[tuple[float, float]] = field(default_factory=list)
    armed_seen: bool = False
    airborne_seen: bool = False
    touchdown_pct: float | None = None
    landed: bool = False


class SpareRecorder:
    """Reads one vehicle on `connection` in a thread until `stop()`."""

    def __init__(self, connection: str, sysid: int) -> None:
        self.connection = connection
        self.sysid = sysid
        self.flown = Flown()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name=f"recorder-{sysid}")

    def start(self) -> SpareRecorder:
        self._thread.start()
        return self

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def stop(self) -> Flown:
        self._stop.set()
        self._thread.join(10)
        return self.flown

    def __enter__(self) -> SpareRecorder:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _ask_streams(self, conn) -> None:
        for msg_id, hz in STREAMS_HZ.items():
            conn.mav.command_long_send(self.sysid, 1, 511, 0, msg_id, 1e6 / hz, 0, 0, 0, 0, 0)

    def _run(self) -> None:
        conn = None
        while conn is None and not self._stop.is_set():
            try:
                conn = mavutil.mavlink_connection(self.connection, source_system=254, source_component=191,
                                                  dialect="ardupilotmega", autoreconnect=True)
            except OSError:
                time.sleep(0.5)
        if conn is None:
            return
        asked = 0.0
        battery_pct: float | None = None
        f = self.flown
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                if now - asked > 5.0:  # until the vehicle hears us (PX4 answers a link once it has one)
                    conn.mav.heartbeat_send(6, 8, 0, 0, 0)
                    self._ask_streams(conn)
                    asked = now
                msg = conn.recv_match(blocking=True, timeout=0.2)
                if msg is None or msg.get_srcSystem() != self.sysid or msg.get_srcComponent() != 1:
                    continue
                kind = msg.get_type()
                if kind == "GLOBAL_POSITION_INT" and (msg.lat or msg.lon):
                    f.positions.append((msg.lat / 1e7, msg.lon / 1e7, msg.relative_alt / 1000.0))
                    if msg.relative_alt > 5000:
                        f.airborne_seen = True
                elif kind == "BATTERY_STATUS" and msg.id == 0 and msg.battery_remaining >= 0:
                    battery_pct = float(msg.battery_remaining)
                    f.battery.append((time.monotonic(), battery_pct))
                elif kind == "HEARTBEAT" and msg.type != 6:
                    armed = bool(msg.base_mode & 128)
                    if armed:
                        f.armed_seen = True
                    elif f.armed_seen and f.airborne_seen and not f.landed:
                        f.landed, f.touchdown_pct = True, battery_pct
        finally:
            conn.close()


def waypoints_passed(positions: list[tuple[float, float, float]], waypoints: list[tuple[float, float]],
                     within_m: float) -> int:
    """How many of `waypoints` the track came within `within_m` of, in their order (a waypoint
    never approached is skipped, and the next is looked for from where the last one was): the
    planned search the vehicle really flew."""
    k = math.pi / 180.0 * 6_371_008.8
    passed = start = 0
    for wlat, wlon in waypoints:
        for i in range(start, len(positions)):
            lat, lon, _alt = positions[i]
            if math.hypot((lat - wlat) * k, (lon - wlon) * k * math.cos(math.radians(lat))) <= within_m:
                passed, start = passed + 1, i
                break
    return passed
