"""A mission, fence or rally item as MAVLink carries it (MISSION_ITEM_INT's fields), and the list it
belongs to. One type for both ends of the mission protocol: the station's (`mission_transfer`),
the storage models that say what an autopilot keeps of an item, and the simulated vehicles'."""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import IntEnum

from gcs.links import MAVMessage, mavlink

__all__ = ["GLOBAL_FRAMES", "MissionType", "WireItem", "renumber"]

GLOBAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_INT,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
})


class MissionType(IntEnum):
    """MAV_MISSION_TYPE: the list an item belongs to; ALL only names every list at once
    (MISSION_CLEAR_ALL)."""

    MISSION = mavlink.MAV_MISSION_TYPE_MISSION
    FENCE = mavlink.MAV_MISSION_TYPE_FENCE
    RALLY = mavlink.MAV_MISSION_TYPE_RALLY
    ALL = mavlink.MAV_MISSION_TYPE_ALL


@dataclass(frozen=True, slots=True, kw_only=True)
class WireItem:
    """One item with MISSION_ITEM_INT's fields, in its order; x, y in degE7 for global frames."""

    seq: int
    frame: int
    command: int
    current: int = 0
    autocontinue: int = 1
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    mission_type: int = MissionType.MISSION

    @classmethod
    def at(cls, seq: int, frame: int, command: int, lat_deg: float, lon_deg: float, alt_m: float,
           params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0), mission_type: int = MissionType.MISSION
           ) -> WireItem:
        """An item at a place in degrees and metres."""
        p1, p2, p3, p4 = (float(p) for p in params)
        return cls(seq=seq, frame=int(frame), command=int(command), param1=p1, param2=p2, param3=p3, param4=p4,
                   x=round(lat_deg * 1e7), y=round(lon_deg * 1e7), z=float(alt_m), mission_type=int(mission_type))

    @classmethod
    def from_msg(cls, msg: MAVMessage) -> WireItem:
        """From MISSION_ITEM_INT, or legacy MISSION_ITEM (float degrees, or metres * 1e4)."""
        x, y = msg.x, msg.y
        if msg.get_type() == "MISSION_ITEM":
            scale = 1e7 if msg.frame in GLOBAL_FRAMES else 1e4
            x, y = round(x * scale), round(y * scale)
        return cls(seq=msg.seq, frame=msg.frame, command=msg.command, current=msg.current,
                   autocontinue=msg.autocontinue, param1=msg.param1, param2=msg.param2, param3=msg.param3,
                   param4=msg.param4, x=int(x), y=int(y), z=msg.z, mission_type=msg.mission_type)

    def to_msg(self, target: tuple[int, int], *, legacy: bool = False) -> MAVMessage:
        """As MISSION_ITEM_INT, or with `legacy` as MISSION_ITEM (float degrees, or metres * 1e4)."""
        head = (target[0], target[1], self.seq, self.frame, self.command, self.current, self.autocontinue,
                self.param1, self.param2, self.param3, self.param4)
        if legacy:
            scale = 1e7 if self.frame in GLOBAL_FRAMES else 1e4
            return mavlink.MAVLink_mission_item_message(*head, self.x / scale, self.y / scale, self.z,
                                                        self.mission_type)
        return mavlink.MAVLink_mission_item_int_message(*head, self.x, self.y, self.z, self.mission_type)


def renumber(items: list[WireItem], mission_type: int) -> list[WireItem]:
    """The items numbered from 0, all in the list `mission_type`."""
    return [replace(it, seq=i, mission_type=int(mission_type)) for i, it in enumerate(items)]
