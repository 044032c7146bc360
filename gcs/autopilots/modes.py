"""Flight modes by name, as each autopilot numbers them in HEARTBEAT.custom_mode.

ArduPilot numbers modes per vehicle type (ArduCopter and ArduPlane differ); PX4 packs a main
and a sub mode into custom_mode (main << 16 | sub << 24, px4_custom_mode.h), and names AUTO
"MISSION" and LOITER "HOLD"."""

from __future__ import annotations

from gcs.links import mavlink

COPTER = {"STABILIZE": 0, "AUTO": 3, "GUIDED": 4, "LOITER": 5, "RTL": 6, "LAND": 9, "BRAKE": 17}
PLANE = {"MANUAL": 0, "AUTO": 10, "RTL": 11, "LOITER": 12, "TAKEOFF": 13, "GUIDED": 15}
PX4 = {"MANUAL": (1, 0), "OFFBOARD": (6, 0), "TAKEOFF": (4, 2), "HOLD": (4, 3), "MISSION": (4, 4), "RTL": (4, 5),
       "LAND": (4, 6)}
PX4_ALIASES = {"AUTO": "MISSION", "LOITER": "HOLD", "GUIDED": "HOLD"}
MISSION_MODES = frozenset({"AUTO", "MISSION", "TAKEOFF"})  # a vehicle flying its mission list, by either name
#: a vehicle held or steered by its station (`Autopilot.hold_mode`, the online search's GUIDED and
#: DO_REPOSITION targets): where it stays if the station goes away
STATION_HELD_MODES = frozenset({"GUIDED", "LOITER", "HOLD"})


def ardupilot_table(mav_type: int | None) -> dict[str, int]:
    return PLANE if mav_type == mavlink.MAV_TYPE_FIXED_WING else COPTER


def px4_mode_name(custom_mode: int) -> str:
    main, sub = (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
    for name, (m, s) in PX4.items():
        if (m, s) == (main, sub) or (m == main and s == 0 and main != 4):
            return name
    return f"px4 {main}.{sub}"


def ardupilot_mode_name(mav_type: int | None, custom_mode: int) -> str:
    for name, number in ardupilot_table(mav_type).items():
        if number == custom_mode:
            return name
    return f"mode {custom_mode}"
