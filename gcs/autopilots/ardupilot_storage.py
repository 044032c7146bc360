"""What ArduPilot keeps of a mission, fence or rally item, measured on ArduCopter and ArduPlane
4.7 SITL (docs/autopilots.md has the full table and the measuring scripts' results).

ArduPilot does not store MAVLink items; it packs each into its own `Mission_Command` (a location
with altitude in whole centimetres, and per command a few small integer fields) and unpacks it
again when asked. `stored_item(item, fixed_wing)` predicts what a read-back returns for an item
sent, so a verify can compare exactly and still catch a real corruption:

- frames come back without `_INT` (5 -> 0, 6 -> 3, 11 -> 10); commands without a location come
  back in frame 0 with x, y, z zero;
- x, y (degE7) come back exactly; z is cut (towards zero) to whole centimetres (rally points: to
  whole metres); |z| must stay under 83,000 m (else MAV_MISSION_INVALID_PARAM7);
- `autocontinue` comes back 1 (fence and rally items: 0) and `current` 0 whatever was sent;
- a location sent in frame 2 (MAV_FRAME_MISSION) is kept as absolute and comes back in frame 0;
- params per command: NAV_WAYPOINT keeps the hold time (param1, whole seconds, as uint16) on
  Copter, but on Plane param1 is dropped and param2/param3 (acceptance and pass radius) are kept
  as whole metres up to 255 (out of range: 255); NAV_TAKEOFF keeps param1 (pitch) as uint16;
  NAV_LAND keeps param1 (abort altitude) as uint16 and turns param4 into the yaw direction +1 or
  -1 (0 and NaN read back as +1); DO_CHANGE_SPEED keeps param1..3 and drops the location;
  NAV_RETURN_TO_LAUNCH and DO_LAND_START keep no params; fence vertices and circles keep param1
  (vertex count, radius) in frame 0 with z 0, a fence return point no params; rally points keep
  no params.

Item 0 of the mission list is home: what is uploaded there is ignored and the vehicle's own home
comes back (frame 0, altitude above mean sea level)."""

from __future__ import annotations

import math
import struct
from dataclasses import replace

from gcs.autopilots.wire_item import WireItem
from gcs.links import mavlink

__all__ = ["MAX_ABS_ALT_M", "known_command", "stored_item"]

MAX_ABS_ALT_M = 83000.0
_NON_INT_FRAME = {mavlink.MAV_FRAME_GLOBAL_INT: mavlink.MAV_FRAME_GLOBAL,
                  mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                  mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT: mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT}
_WAYPOINT, _TAKEOFF, _LAND = mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LAND
_RTL, _LAND_START = mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, mavlink.MAV_CMD_DO_LAND_START
_CHANGE_SPEED = mavlink.MAV_CMD_DO_CHANGE_SPEED
_FENCE_VERTICES = frozenset({mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                             mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION})
_FENCE_CIRCLES = frozenset({mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION})
_FENCE_COMMANDS = _FENCE_VERTICES | _FENCE_CIRCLES | {mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT}
_MISSION_COMMANDS = frozenset({_WAYPOINT, _TAKEOFF, _LAND, _RTL, _LAND_START, _CHANGE_SPEED})


def known_command(command: int, mission_type: int) -> bool:
    """Whether `stored_item` models this command exactly."""
    if mission_type == mavlink.MAV_MISSION_TYPE_FENCE:
        return command in _FENCE_COMMANDS
    if mission_type == mavlink.MAV_MISSION_TYPE_RALLY:
        return command == mavlink.MAV_CMD_NAV_RALLY_POINT
    return command in _MISSION_COMMANDS


def _f32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", value))[0]


def _uint16(value: float) -> float:
    """C's float -> uint16_t cast as ArduPilot does it: cut towards zero, wrap modulo 65536."""
    if math.isnan(value):
        return 0.0
    return float(int(value) % 65536)


def _byte_metres(value: float) -> float:
    """Plane's acceptance / pass radius: whole metres up to 255, out of range -> 255."""
    if math.isnan(value) or value < 0 or value >= 256:
        return 255.0
    return float(int(value))


def _altitude_cm(z: float) -> float:
    """ArduPilot keeps whole centimetres (cut towards zero) and gives them back as cm * 0.01f."""
    return _f32(math.trunc(_f32(_f32(z) * 100.0)) * _f32(0.01))


def stored_item(item: WireItem, *, fixed_wing: bool) -> WireItem:
    """The item ArduPilot returns on read-back after `item` was uploaded (see the module doc);
    items of commands `known_command` does not cover come back as sent, params as float32."""
    kind = item.mission_type
    frame = _NON_INT_FRAME.get(item.frame, item.frame)
    if frame == mavlink.MAV_FRAME_MISSION:
        frame = mavlink.MAV_FRAME_GLOBAL  # a location in frame 2 is kept as absolute (above sea level)
    p = [_f32(v) for v in (item.param1, item.param2, item.param3, item.param4)]
    x, y, z = item.x, item.y, _altitude_cm(item.z)
    if kind == mavlink.MAV_MISSION_TYPE_FENCE and item.command in _FENCE_COMMANDS:
        keep = 0.0 if item.command == mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT else p[0]  # vertex count / radius
        return replace(item, frame=mavlink.MAV_FRAME_GLOBAL, param1=keep, param2=0.0, param3=0.0, param4=0.0, z=0.0,
                       current=0, autocontinue=0)
    if kind == mavlink.MAV_MISSION_TYPE_RALLY and item.command == mavlink.MAV_CMD_NAV_RALLY_POINT:
        return replace(item, frame=frame, param1=0.0, param2=0.0, param3=0.0, param4=0.0,
                       z=float(math.trunc(_f32(item.z))), current=0, autocontinue=0)
    if kind != mavlink.MAV_MISSION_TYPE_MISSION or item.command not in _MISSION_COMMANDS:
        return replace(item, frame=frame, param1=p[0], param2=p[1], param3=p[2], param4=p[3], z=_f32(item.z))
    cmd = item.command
    if cmd == _WAYPOINT:
        p = [0.0, _byte_metres(p[1]), _byte_metres(p[2]), 0.0] if fixed_wing else [_uint16(p[0]), 0.0, 0.0, 0.0]
    elif cmd == _TAKEOFF:
        p = [_uint16(p[0]), 0.0, 0.0, 0.0]
    elif cmd == _LAND:
        p = [_uint16(p[0]), 0.0, 0.0, -1.0 if p[3] < 0 else 1.0]
    elif cmd == _CHANGE_SPEED:
        p = [p[0], p[1], p[2], 0.0]
        frame, x, y, z = mavlink.MAV_FRAME_GLOBAL, 0, 0, 0.0
    elif cmd == _RTL:
        p = [0.0] * 4
        frame, x, y, z = mavlink.MAV_FRAME_GLOBAL, 0, 0, 0.0
    else:  # DO_LAND_START: a location, no params
        p = [0.0] * 4
    return replace(item, frame=frame, param1=p[0], param2=p[1], param3=p[2], param4=p[3], x=x, y=y, z=z, current=0,
                   autocontinue=1)
