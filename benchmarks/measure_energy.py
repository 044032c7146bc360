"""What SITL vehicles consume: ArduCopter (quad, copter.parm), ArduPlane (plane.parm) and PX4 SIH
quad (10040) with stock parameters fly scripted phases (`tests/peers/energy.py`) and the battery
each reports is cut into phases: armed idle on the ground, take-off to 30 m and 60 m, hover or
loiter, straight legs at the speeds a mission flies, a zig-zag of 90-degree turns against a
straight line of the same length, the landing from 60 m and 30 m, and the same legs in a steady
wind (ArduPilot SIM_WIND_SPD 8, SIM_WIND_TURB 2; PX4 v1.15 SIH has no wind). PX4's simulated
battery is flown three times: stock (SIM_BAT_DRAIN 60), slow (3600 s, so that the load's effect
on voltage and remaining shows), and slow with BAT1_R_INTERNAL -1.

    .venv/bin/python benchmarks/measure_energy.py [--speedup 10] [--px4-speedup 5]
        [--only arducopter,arduplane,px4] [--out benchmarks/energy_sitl.json]
    .venv/bin/python benchmarks/measure_energy.py --markdown benchmarks/energy_sitl.json

Prints a table per flight and writes every phase (and the flights' raw samples with `--samples`)
as JSON; `--markdown` prints a results file's tables as docs/energy.md shows them. Needs the peers
folder's SITL (../shared/peers or $GCS_PEERS_DIR)."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

from tests.peers.ardupilot import ArduPilotSitl  # noqa: E402
from tests.peers.energy import Record, Station, analyse, copter_course, fly, plane_course  # noqa: E402
from tests.peers.px4 import Px4Sitl  # noqa: E402
from tests.peers.site import CENTRE, GROUND_AMSL_M  # noqa: E402

HOME = (*CENTRE, GROUND_AMSL_M)
WIND = {"SIM_WIND_SPD": 8.0, "SIM_WIND_TURB": 2.0}
# ArduPlane refuses to arm with a DO_LAND_START in the mission unless RTL_AUTOLAND allows it
AUTOLAND = {"RTL_AUTOLAND": 2.0}
COPTER_PARAMS = ("BATT_CAPACITY", "BATT_MONITOR", "WPNAV_SPEED", "WPNAV_SPEED_UP", "WPNAV_SPEED_DN", "LAND_SPEED",
                 "LAND_SPEED_HIGH", "SIM_BATT_VOLTAGE", "SIM_BATT_CAP_AH")
PLANE_PARAMS = ("BATT_CAPACITY", "BATT_MONITOR", "AIRSPEED_CRUISE", "THR_MAX", "TRIM_THROTTLE", "TKOFF_THR_MAX",
                "SIM_BATT_VOLTAGE", "SIM_BATT_CAP_AH")
PX4_PARAMS = ("BAT1_CAPACITY", "BAT1_N_CELLS", "BAT1_V_EMPTY", "BAT1_V_CHARGED", "BAT1_V_LOAD_DROP", "BAT1_R_INTERNAL",
              "BAT_AVRG_CURRENT", "SIM_BAT_DRAIN", "SIM_BAT_MIN_PCT", "MPC_XY_CRUISE", "MPC_XY_VEL_MAX")


def _flight(name: str, record: Record, wall_s: float, speedup: float) -> dict:
    phases = analyse(record)
    return {"flight": name, "vehicle": record.vehicle, "autopilot": record.autopilot, "speedup": speedup,
            "wall_s": round(wall_s, 1), "params": record.params, "phases": [p.as_dict() for p in phases],
            "samples": [asdict(s) for s in record.samples]}


def _fly(station: Station, name: str, course, *, vehicle: str, params: tuple[str, ...], speedup: float,
         setup: dict[str, float] | None = None) -> dict:
    start = time.monotonic()
    record = fly(station, course, vehicle=vehicle, params=params, setup=setup)
    out = _flight(name, record, time.monotonic() - start, speedup)
    print(table(out), flush=True)
    return out


def _station(connection: str, *, px4: bool, speedup: float) -> Station:
    conn = mavutil.mavlink_connection(connection, source_system=255, source_component=190, dialect="ardupilotmega")
    return Station(conn, 1, px4, speedup)


def arducopter(speedup: float) -> list[dict]:
    with ArduPilotSitl("copter", home=(*HOME, 0.0), speedup=speedup) as sitl:
        st = _station(sitl.udp_connection, px4=False, speedup=speedup)
        calm = _fly(st, "ArduCopter", copter_course(), vehicle="copter", params=COPTER_PARAMS, speedup=speedup)
        windy = _fly(st, "ArduCopter, wind 8 m/s from the north (SIM_WIND_TURB 2)",
                     copter_course(speeds=(5, 10, 15), directions="NSEW", turns=False), vehicle="copter",
                     params=COPTER_PARAMS + ("SIM_WIND_SPD", "SIM_WIND_DIR", "SIM_WIND_TURB"), speedup=speedup,
                     setup=WIND | {"SIM_WIND_DIR": 0.0})
        st.conn.close()
    return [calm, windy]


def arduplane(speedup: float) -> list[dict]:
    with ArduPilotSitl("plane", home=(*HOME, 90.0), speedup=speedup) as sitl:
        st = _station(sitl.udp_connection, px4=False, speedup=speedup)
        calm = _fly(st, "ArduPlane", plane_course(), vehicle="plane", params=PLANE_PARAMS, speedup=speedup,
                    setup=AUTOLAND)
        windy = _fly(st, "ArduPlane, wind 8 m/s from the east (SIM_WIND_TURB 2)",
                     plane_course(directions="EWNS", turns=False), vehicle="plane",
                     params=PLANE_PARAMS + ("SIM_WIND_SPD", "SIM_WIND_DIR", "SIM_WIND_TURB"), speedup=speedup,
                     setup=AUTOLAND | WIND | {"SIM_WIND_DIR": 90.0})
        st.conn.close()
    return [calm, windy]


def px4(speedup: float) -> list[dict]:
    out = []
    for name, params, course in (
            ("PX4 SIH quad, stock battery (SIM_BAT_DRAIN 60)", {}, copter_course(default_speed_m_s=5.0)),
            ("PX4 SIH quad, SIM_BAT_DRAIN 3600", {"SIM_BAT_DRAIN": 3600.0},
             copter_course(default_speed_m_s=5.0, turns=False)),
            ("PX4 SIH quad, SIM_BAT_DRAIN 3600, BAT1_R_INTERNAL -1", {"SIM_BAT_DRAIN": 3600.0, "BAT1_R_INTERNAL": -1.0},
             copter_course(default_speed_m_s=5.0, speeds=(None, 12), turns=False))):
        with Px4Sitl(home=HOME, speedup=speedup, params=params) as sitl:
            st = _station(sitl.gcs_connection, px4=True, speedup=speedup)
            out.append(_fly(st, name, course, vehicle="copter", params=PX4_PARAMS, speedup=speedup))
            st.conn.close()
    return out


def _f(value: float, digits: int = 1) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def table(flight: dict) -> str:
    lines = [f"\n{flight['flight']} (speed-up {flight['speedup']:g}, {flight['wall_s']:.0f} s wall)",
             "  " + ", ".join(f"{k} {v:g}" for k, v in flight["params"].items() if not math.isnan(v)),
             f"  {'phase':<34} {'s':>6} {'m':>6} {'mAh':>6} {'mAh/s':>6} {'mAh/m':>6} {'A':>5} {'V':>6} "
             f"{'Vmin':>6} {'rem %':>7} {'gs':>5} {'as':>5} {'thr':>4} {'wind':>9}"]
    for p in flight["phases"]:
        wind = f"{_f(p['wind_m_s'])}@{_f(p['wind_from_deg'], 0)}" if not math.isnan(p["wind_m_s"]) else "-"
        lines.append(f"  {p['name']:<34} {_f(p['seconds']):>6} {_f(p['metres'], 0):>6} {_f(p['mah'], 0):>6} "
                     f"{_f(p['mah_per_s'], 2):>6} {_f(p['mah_per_m'], 3):>6} {_f(p['mean_current_a']):>5} "
                     f"{_f(p['mean_voltage_v'], 2):>6} {_f(p['min_voltage_v'], 2):>6} "
                     f"{p['remaining_from']:>3}>{p['remaining_to']:<3} {_f(p['groundspeed']):>5} "
                     f"{_f(p['airspeed']):>5} {_f(p['throttle'], 0):>4} {wind:>9}")
    return "\n".join(lines)


def markdown(flight: dict) -> str:
    """A flight's phases as a Markdown table (docs/energy.md)."""
    lines = [f"**{flight['flight']}** (SPEEDUP {flight['speedup']:g})", "",
             "| phase | s | m | mAh | mAh/s | mAh/m | A | V (min) | remaining % | ground / air m/s | throttle % "
             "| wind reported |", "|" + " --- |" * 12]
    for p in flight["phases"]:
        wind = f"{_f(p['wind_m_s'])} m/s from {_f(p['wind_from_deg'], 0)}°" if not math.isnan(p["wind_m_s"]) else "-"
        lines.append(f"| {p['name']} | {_f(p['seconds'])} | {_f(p['metres'], 0)} | {_f(p['mah'], 0)} | "
                     f"{_f(p['mah_per_s'], 2)} | {_f(p['mah_per_m'] if p['metres'] >= 10 else math.nan, 3)} | "
                     f"{_f(p['mean_current_a'])} | "
                     f"{_f(p['mean_voltage_v'], 2)} ({_f(p['min_voltage_v'], 2)}) | "
                     f"{p['remaining_from']} → {p['remaining_to']} | {_f(p['groundspeed'])} / {_f(p['airspeed'])} | "
                     f"{_f(p['throttle'], 0)} | {wind} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--speedup", type=float, default=10.0, help="ArduPilot SITL's SPEEDUP")
    parser.add_argument("--px4-speedup", type=float, default=5.0, help="PX4 SITL's SPEEDUP")
    parser.add_argument("--only", default="arducopter,arduplane,px4")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "energy_sitl.json")
    parser.add_argument("--samples", action="store_true", help="keep every flight's raw samples in the JSON")
    parser.add_argument("--markdown", type=Path, metavar="JSON", help="print the tables of a results file; no flight")
    args = parser.parse_args()
    if args.markdown is not None:
        results = json.loads(args.markdown.read_text())
        commands = results["command"] if isinstance(results["command"], list) else [results["command"]]
        print("\n".join(f"`{command}`" for command in commands) + "\n")
        print("\n\n".join(markdown(flight) for flight in results["flights"]))
        return 0
    runs = {"arducopter": lambda: arducopter(args.speedup), "arduplane": lambda: arduplane(args.speedup),
            "px4": lambda: px4(args.px4_speedup)}
    command = "benchmarks/measure_energy.py " + " ".join(sys.argv[1:])
    flights: list[dict] = []
    for name in args.only.split(","):
        for flight in runs[name]():
            if not args.samples:
                del flight["samples"]
            flights.append(flight)
        # written after every vehicle, so that a later failure keeps what was measured
        args.out.write_text(json.dumps({"command": command.strip(), "flights": flights}, indent=1) + "\n")
    print(f"\nwritten: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
