"""What PX4 (v1.15.3, measured on its SIH SITL, copter and plane) keeps of a mission, fence or
rally item; docs/autopilots.md has the table. The single model the station's verify and our
simulator's `px4` profile use, as `ardupilot_storage` is for ArduPilot.

PX4 parses each item into its own `mission_item_s` (latitude and longitude as doubles, altitude
float32, a few named fields per command) and formats it again on a read-back:

- frames: only "relative or not" is kept, and a MISSION_REQUEST_INT read-back answers in the
  _INT frames: 3 -> 6, 0 -> 5 (6 and 5 stay); fence items always come back in frame 5;
- x, y (degE7) come back exactly, z as float32 (no rounding to centimetres);
- NAV_WAYPOINT keeps param1 (hold) and param2 (acceptance radius), drops param3; param4 (yaw) is
  wrapped into [0, 360) through float32 radians (-90 -> 270), NaN stays NaN;
- NAV_TAKEOFF keeps only the yaw (param1, the pitch, is dropped); NAV_LAND keeps param2
  (precision landing mode, as uint16) and the yaw;
- commands without a location (DO_*, NAV_RETURN_TO_LAUNCH) are accepted only in frame 2
  (MAV_FRAME_MISSION) and kept whole; frames 10 and 11 (terrain) are refused
  (`refusal`, MAV_MISSION_UNSUPPORTED_FRAME / UNSUPPORTED);
- autocontinue is kept for mission and rally items, 0 for fence items; fence polygon vertices
  keep the vertex count rounded, circles their radius; rally points keep no params.
- `current` marks the mission's current item (the last item uploaded with current = 1) in every
  list; the station uploads none, so read-backs have current 0.

Unlike ArduPilot, PX4 replaces a list only when its upload completed: a refused or abandoned
upload leaves the old list whole."""

from __future__ import annotations

import math
import struct
from dataclasses import replace

from gcs.autopilots.wire_item import WireItem
from gcs.links import mavlink

__all__ = ["MISSION_FRAME_COMMANDS", "refusal", "stored_item"]

_LOCATION_COMMANDS = frozenset({
    mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME, mavlink.MAV_CMD_NAV_LAND,
    mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_RALLY_POINT,
    mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION})
#: Commands PX4 accepts only in MAV_FRAME_MISSION (2): the station sends them so.
MISSION_FRAME_COMMANDS = frozenset({mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, mavlink.MAV_CMD_DO_CHANGE_SPEED,
                                    mavlink.MAV_CMD_DO_LAND_START})
_POLYGON = frozenset({mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                      mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION})
_CIRCLES = frozenset({mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION})
_FENCE_AND_RALLY = _POLYGON | _CIRCLES | {mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT, mavlink.MAV_CMD_NAV_RALLY_POINT}
_RELATIVE = frozenset({mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
_GLOBAL_FRAMES = frozenset({mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT}) | _RELATIVE


def _f32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", value))[0]


def _yaw(deg: float) -> float:
    """Degrees -> float32 radians wrapped into [0, 2 pi) -> degrees, as PX4 stores and formats a yaw."""
    if math.isnan(deg):
        return math.nan
    two_pi = _f32(2.0 * math.pi)
    rad = _f32(_f32(deg) * _f32(_f32(math.pi) / _f32(180.0)))
    if not 0.0 <= rad < two_pi:
        rad = _f32(rad - _f32(two_pi * math.floor(_f32(rad * _f32(1.0 / two_pi)))))
    return _f32(rad * _f32(_f32(180.0) / _f32(math.pi)))


def _uint16(value: float, *, rounded: bool = False) -> float:
    if math.isnan(value):
        return 0.0
    return float(int(math.trunc(_f32(value + 0.5 if rounded else value))) & 0xFFFF)


def refusal(item: WireItem) -> int | None:
    """The MAV_MISSION_RESULT PX4 answers this item with, or None when it accepts it."""
    if item.frame not in _GLOBAL_FRAMES | {mavlink.MAV_FRAME_MISSION}:
        return mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    in_mission_frame = item.frame == mavlink.MAV_FRAME_MISSION
    if item.command in MISSION_FRAME_COMMANDS:
        return None if in_mission_frame else mavlink.MAV_MISSION_UNSUPPORTED
    if item.command in _LOCATION_COMMANDS and in_mission_frame:
        return mavlink.MAV_MISSION_UNSUPPORTED
    if item.mission_type == mavlink.MAV_MISSION_TYPE_MISSION and item.command in _FENCE_AND_RALLY:
        return mavlink.MAV_MISSION_ERROR
    if item.mission_type == mavlink.MAV_MISSION_TYPE_FENCE and item.command in _POLYGON \
            and _uint16(item.param1, rounded=True) < 3:
        return mavlink.MAV_MISSION_ERROR
    return None


def stored_item(item: WireItem) -> WireItem:
    """The item PX4 returns on a MISSION_REQUEST_INT read-back after `item` was accepted."""
    p = [item.param1, item.param2, item.param3, item.param4]
    base = replace(item, z=_f32(item.z), current=0)
    if item.frame == mavlink.MAV_FRAME_MISSION:  # x, y too are kept in float32 (472761189 reads back 472761184)
        return replace(base, param1=_f32(p[0]), param2=_f32(p[1]), param3=_f32(p[2]), param4=_f32(p[3]),
                       x=int(_f32(item.x)), y=int(_f32(item.y)))
    frame = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT if item.frame in _RELATIVE else mavlink.MAV_FRAME_GLOBAL_INT
    cmd = item.command
    q = [0.0, 0.0, 0.0, 0.0]
    if item.mission_type == mavlink.MAV_MISSION_TYPE_FENCE:
        if cmd in _POLYGON:
            q[0] = _uint16(p[0], rounded=True)
        elif cmd in _CIRCLES:
            q[0] = _f32(p[0])
        return replace(base, frame=mavlink.MAV_FRAME_GLOBAL_INT, param1=q[0], param2=0.0, param3=0.0, param4=0.0,
                       autocontinue=0)
    if item.mission_type == mavlink.MAV_MISSION_TYPE_MISSION:
        if cmd == mavlink.MAV_CMD_NAV_WAYPOINT:
            q = [_f32(p[0]), _f32(p[1]), 0.0, _yaw(p[3])]
        elif cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            q = [0.0, 0.0, 0.0, _yaw(p[3])]
        elif cmd == mavlink.MAV_CMD_NAV_LAND:
            q = [0.0, _uint16(p[1]), 0.0, _yaw(p[3])]
        elif cmd == mavlink.MAV_CMD_NAV_LOITER_TIME:
            q = [_f32(p[0]), 1.0 if p[1] > 0 else 0.0, _f32(p[2]), 1.0 if p[3] > 0 else 0.0]
        elif cmd == mavlink.MAV_CMD_NAV_LOITER_UNLIM:
            q = [0.0, 0.0, _f32(p[2]), _yaw(p[3])]
    return replace(base, frame=frame, param1=q[0], param2=q[1], param3=q[2], param4=q[3])
