"""How far ArduCopter SITL's quad leans into a steady wind while it climbs and hovers: the
figures behind `gcs.flight.lean_wind` (the wind a station reads from a copter whose autopilot
reports none) and the stock profile's `lean_tan_at_10_m_s`.

    .venv/bin/python benchmarks/lean_wind.py [WIND_M_S ...]     # default: 8 4 0, about 3 min

For each wind (from 250 degrees, no turbulence) it starts ArduCopter SITL at speed-up 10, takes
off in GUIDED to 40 m and hovers, and prints the mean lean of the thrust (the tangent of its tilt,
`gcs.flight.lean_wind.thrust_lean` of ATTITUDE) climbing and hovering, and where it points."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pymavlink import mavutil  # noqa: E402

from gcs.flight.lean_wind import thrust_lean  # noqa: E402
from tests.peers.ardupilot import ArduPilotSitl, require_ardupilot  # noqa: E402


def _take_off(conn, altitude_m: float) -> None:
    start = time.monotonic()
    while time.monotonic() - start < 60:
        gps = conn.recv_match(type="GPS_RAW_INT", blocking=True, timeout=1)
        if gps is not None and gps.fix_type >= 3 and time.monotonic() - start > 8:
            break
    conn.mav.set_mode_send(1, mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)  # GUIDED
    time.sleep(0.5)
    for _ in range(30):
        conn.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=1)
        if ack is not None and ack.command == mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM and ack.result == 0:
            break
        time.sleep(0.5)
    conn.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, altitude_m)


def lean_in(wind_m_s: float, source_deg: float = 250.0, altitude_m: float = 40.0, wall_s: float = 25.0) -> None:
    params = {"SIM_WIND_SPD": wind_m_s, "SIM_WIND_DIR": source_deg, "SIM_WIND_TURB": 0.0}
    with ArduPilotSitl("copter", speedup=10, params=params) as sitl:
        conn = mavutil.mavlink_connection(sitl.tcp_connection, source_system=255)
        conn.wait_heartbeat(timeout=60)
        mav = mavutil.mavlink
        for msg_id, hz in ((mav.MAVLINK_MSG_ID_ATTITUDE, 10), (mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 5),
                           (mav.MAVLINK_MSG_ID_GPS_RAW_INT, 2)):
            conn.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, 1e6 / hz,
                                       0, 0, 0, 0, 0)
        _take_off(conn, altitude_m)
        samples: list[tuple[float, float, float]] = []
        altitude = 0.0
        start = time.monotonic()
        while time.monotonic() - start < wall_s:
            msg = conn.recv_match(type=["ATTITUDE", "GLOBAL_POSITION_INT"], blocking=True, timeout=1)
            if msg is None:
                continue
            if msg.get_type() == "GLOBAL_POSITION_INT":
                altitude = msg.relative_alt / 1000.0
            else:
                samples.append((altitude, *thrust_lean(msg.roll, msg.pitch, msg.yaw)))
    for name, part in (("climb", [s for s in samples if 5 < s[0] < altitude_m - 2]),
                       ("hover", [s for s in samples if s[0] >= altitude_m - 2])):
        if part:
            east = sum(s[1] for s in part) / len(part)
            north = sum(s[2] for s in part) / len(part)
            print(f"wind {wind_m_s:g} m/s from {source_deg:g} deg, {name}: {len(part)} samples, lean "
                  f"{math.hypot(east, north):.4f} towards {math.degrees(math.atan2(east, north)) % 360:.0f} deg",
                  flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("winds", nargs="*", type=float, default=[8.0, 4.0, 0.0], metavar="WIND_M_S",
                        help="steady winds to hover in, m/s from 250 degrees (default: 8 4 0)")
    args = parser.parse_args()
    require_ardupilot()
    for wind in args.winds:
        lean_in(wind)
    return 0


if __name__ == "__main__":
    sys.exit(main())
