"""Flight modes and their HEARTBEAT custom_mode numbers, per autopilot profile.

ArduPilot numbers are ArduCopter's and ArduPlane's `mode` enums (Copter: GUIDED=4, AUTO=3,
RTL=6, LAND=9; Plane: AUTO=10, RTL=11, GUIDED=15). PX4 packs main mode and sub mode into
custom_mode as `main << 16 | sub << 24` (px4_custom_mode.h).
"""

from __future__ import annotations

from enum import Enum


class Mode(Enum):
    """The behaviours the simulator implements, whatever the autopilot calls them."""

    MANUAL = "MANUAL"
    GUIDED = "GUIDED"
    AUTO = "AUTO"
    RTL = "RTL"
    LAND = "LAND"
    LOITER = "LOITER"
    TAKEOFF = "TAKEOFF"
    POSCTL = "POSCTL"  # PX4's position mode: without RC it sinks (px4 §9)


_ARDUCOPTER = {
    Mode.MANUAL: 0,  # STABILIZE
    Mode.AUTO: 3,
    Mode.GUIDED: 4,
    Mode.LOITER: 5,
    Mode.RTL: 6,
    Mode.LAND: 9,
}
_ARDUPLANE = {
    Mode.MANUAL: 0,
    Mode.AUTO: 10,
    Mode.RTL: 11,
    Mode.LOITER: 12,
    Mode.TAKEOFF: 13,
    Mode.GUIDED: 15,
}


def _px4(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


_PX4 = {
    Mode.MANUAL: _px4(1),
    Mode.POSCTL: _px4(3),
    Mode.GUIDED: _px4(6),  # OFFBOARD
    Mode.TAKEOFF: _px4(4, 2),
    Mode.LOITER: _px4(4, 3),  # Hold
    Mode.AUTO: _px4(4, 4),  # Mission
    Mode.RTL: _px4(4, 5),
    Mode.LAND: _px4(4, 6),
}


def mode_table(profile: str, vehicle_type: str) -> dict[Mode, int]:
    """custom_mode number of each mode this profile and vehicle type support."""
    if profile == "px4":
        return _PX4
    return _ARDUPLANE if vehicle_type == "plane" else _ARDUCOPTER


def custom_mode_of(mode: Mode, profile: str, vehicle_type: str) -> int:
    return mode_table(profile, vehicle_type)[mode]


def mode_from_custom(custom_mode: int, profile: str, vehicle_type: str) -> Mode | None:
    """The mode a custom_mode number selects, or None if unsupported."""
    for mode, number in mode_table(profile, vehicle_type).items():
        if number == custom_mode:
            return mode
    return None
