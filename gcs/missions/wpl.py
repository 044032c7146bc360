"""QGC WPL 110 plain-text missions (mavlink.io "Mission Plain-Text File Format").

First line `QGC WPL 110`; then one tab-separated line per item:
INDEX CURRENT_WP COORD_FRAME COMMAND PARAM1 PARAM2 PARAM3 PARAM4 LAT LON ALT AUTOCONTINUE.
Item 0 is the home position (ArduPilot and QGroundControl read it as home)."""

from __future__ import annotations

from gcs.missions.items import MavCmd, MavFrame, MissionItem, UavMission, mission_items

HEADER = "QGC WPL 110"


def _line(index: int, item: MissionItem, current: bool) -> str:
    fields = [str(index), "1" if current else "0", str(int(item.frame.in_files)), str(int(item.command))]
    fields += [f"{p:.8g}" for p in item.params]
    fields += [f"{item.lat_deg:.9f}", f"{item.lon_deg:.9f}", f"{item.alt_m:.6g}", "1" if item.autocontinue else "0"]
    return "\t".join(fields)


def wpl_text(mission: UavMission) -> str:
    lines = [HEADER, _line(0, mission.home, True)]
    lines += [_line(i, item, False) for i, item in enumerate(mission_items(mission), start=1)]
    return "\n".join(lines) + "\n"


def parse_wpl(text: str) -> list[MissionItem]:
    """Read QGC WPL 110 text back (home first); ValueError on anything else."""
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines or lines[0].strip() != HEADER:
        raise ValueError(f"not a {HEADER} file")
    items = []
    for n, line in enumerate(lines[1:]):
        f = line.split("\t")
        if len(f) != 12:
            raise ValueError(f"line {n + 2}: expected 12 tab-separated fields, got {len(f)}")
        if int(f[0]) != n:
            raise ValueError(f"line {n + 2}: index {f[0]}, expected {n}")
        items.append(MissionItem(MavCmd(int(f[3])), MavFrame(int(f[2])), float(f[8]), float(f[9]), float(f[10]),
                                 tuple(float(v) for v in f[4:8]), f[11] == "1"))
    return items
