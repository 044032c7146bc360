"""Record a short telemetry log of ArduCopter SITL flying a star of legs in a gusty wind, at the
rates `gcs fly` asks for (GLOBAL_POSITION_INT 4 Hz, ATTITUDE 2 Hz, BATTERY_STATUS, VFR_HUD,
WIND, EXTENDED_SYS_STATE 1 Hz, the autopilot's HEARTBEAT): what the wind estimators' unit tests
replay (`tests/gcs/flight/test_wind_estimate.py`).

    .venv/bin/python -m tests.peers.wind_log tests/data/arducopter-wind-8-from-250.tlog [SPEED FROM]

The log is a tlog (a big-endian microsecond stamp before each message), as QGroundControl and
Mission Planner write it, with only those messages, gzipped. The course: take-off to 40 m, a 10 s
hover, 200 m legs out and back along four axes (N-S, E-W, NE-SW, NW-SE), landing at home."""

from __future__ import annotations

import gzip
import struct
import sys
import time
from pathlib import Path

from tests.peers.ardupilot import ArduPilotSitl
from tests.peers.energy import Course, Station, Step, fly

#: the streams `gcs fly` asks an ArduPilot vehicle for that a wind estimate reads, and their rates
LOGGED_HZ = {"GLOBAL_POSITION_INT": 4.0, "ATTITUDE": 2.0, "BATTERY_STATUS": 1.0, "VFR_HUD": 1.0, "WIND": 1.0,
             "MISSION_CURRENT": 1.0, "EXTENDED_SYS_STATE": 1.0, "HEARTBEAT": 1.0}


def star_course(leg_m: float = 200.0, alt_m: float = 40.0) -> Course:
    steps = [Step("takeoff", "take-off", value=alt_m), Step("hover", "hover", value=10.0)]
    for east, north in ((0.0, 1.0), (1.0, 0.0), (0.7071, 0.7071), (-0.7071, 0.7071)):
        out = (east * leg_m, north * leg_m)
        steps += [Step("leg", "out", out, (0.0, 0.0)), Step("leg", "back", (0.0, 0.0), out)]
    steps.append(Step("land", "landing", (0.0, 0.0)))
    return Course(tuple(steps), alt_m)


def record(out: Path, wind_m_s: float = 8.0, from_deg: float = 250.0, turbulence: float = 2.0) -> None:
    params = {"SIM_WIND_SPD": wind_m_s, "SIM_WIND_DIR": from_deg, "SIM_WIND_TURB": turbulence}
    from pymavlink import mavutil

    with ArduPilotSitl("copter", speedup=10, params=params) as sitl:
        conn = mavutil.mavlink_connection(sitl.tcp_connection, source_system=255, dialect="ardupilotmega")
        station = Station(conn, 1, False, 10.0)
        frames: list[bytes] = []
        receive = station.recv

        def recv(timeout_s: float = 0.05):
            msg = receive(timeout_s)
            if msg is not None and msg.get_type() in LOGGED_HZ and msg.get_srcSystem() == 1 \
                    and msg.get_srcComponent() == 1:
                frames.append(struct.pack(">Q", int(time.time() * 1e6)) + msg.get_msgbuf())
            return msg

        station.recv = recv  # type: ignore[method-assign]
        rates = {getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{k}"): hz for k, hz in LOGGED_HZ.items()}
        streams = station.streams

        def station_rates() -> None:
            streams()
            for msg_id, hz in rates.items():
                if msg_id == mavutil.mavlink.MAVLINK_MSG_ID_HEARTBEAT:
                    continue
                station.command(mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz, timeout_s=1.0)

        station.streams = station_rates  # type: ignore[method-assign]
        fly(station, star_course(), vehicle="copter", idle_s=2.0)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(gzip.compress(b"".join(frames), mtime=0))
    print(f"{out}: {len(frames)} messages, {out.stat().st_size} bytes")


if __name__ == "__main__":
    args = sys.argv[1:]
    record(Path(args[0]), *(float(a) for a in args[1:3]))
