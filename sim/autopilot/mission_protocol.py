"""The MAVLink mission protocol, vehicle side, as a pure state machine.

Messages in, messages out, time passed in: `handle(msg, now_s)` and `poll(now_s)` return the
messages to send; nothing here touches a socket or a clock. Three stores (mission, geofence,
rally) are kept, each replaced atomically when an upload completes.

Profiles: with `home_item=True` (ArduPilot) mission item 0 is home. A GCS uploads a placeholder
as item 0, the vehicle keeps it, and a download returns the current home position as item 0;
execution starts at item 1. With `home_item=False` (PX4) every item is part of the mission.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import GLOBAL_FRAMES, MissionType, WireItem, renumber

MAVMessage = mavlink.MAVLink_message
SUPPORTED_FRAMES = GLOBAL_FRAMES | {mavlink.MAV_FRAME_MISSION}


@dataclass(frozen=True, slots=True, kw_only=True)
class ProtocolConfig:
    """`store` turns an item as received into the item as the autopilot keeps it (ArduPilot
    packs items into its own format, `gcs.autopilots.ardupilot_storage`); None keeps it as sent."""

    home_item: bool = True
    store: Callable[[WireItem], WireItem] | None = None
    capacity: dict[int, int] = field(
        default_factory=lambda: {MissionType.MISSION: 1000, MissionType.FENCE: 100, MissionType.RALLY: 20}
    )
    timeout_s: float = 1.0
    max_retries: int = 5


@dataclass(slots=True)
class _Upload:
    partner: tuple[int, int]
    mission_type: int
    count: int
    items: list[WireItem]
    last_request_s: float
    retries: int = 0


@dataclass(slots=True)
class _Done:
    partner: tuple[int, int]
    mission_type: int
    last_seq: int


class MissionProtocol:
    """Vehicle-side mission transfer: upload, download, clear, for each mission type."""

    def __init__(self, config: ProtocolConfig | None = None) -> None:
        self.config = config or ProtocolConfig()
        self._stores: dict[int, list[WireItem]] = {int(t): [] for t in MissionType if t != MissionType.ALL}
        self.versions: dict[int, int] = dict.fromkeys(self._stores, 0)
        self.home = WireItem(seq=0, frame=mavlink.MAV_FRAME_GLOBAL, command=mavlink.MAV_CMD_NAV_WAYPOINT)
        self._upload: _Upload | None = None
        self._done: _Done | None = None

    @property
    def busy(self) -> bool:
        return self._upload is not None

    def items(self, mission_type: int = MissionType.MISSION) -> list[WireItem]:
        """The stored items; with a home item, index 0 is the current home."""
        items = self._stores[mission_type]
        if self._has_home(mission_type):
            return [self.home, *items[1:]]
        return list(items)

    def set_home(self, lat_deg: float, lon_deg: float, alt_m: float) -> None:
        self.home = WireItem.at(0, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, lat_deg, lon_deg, alt_m)

    def replace(self, items: list[WireItem], mission_type: int = MissionType.MISSION) -> None:
        """Store items directly (the Python API's upload)."""
        self._commit(mission_type, renumber(items, mission_type))

    def handle(self, msg: MAVMessage, now_s: float) -> list[MAVMessage]:
        kind = msg.get_type()
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "MISSION_COUNT":
            return self._on_count(msg, sender, now_s)
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            return self._on_item(msg, sender, now_s)
        if kind == "MISSION_REQUEST_LIST":
            return self._on_request_list(msg, sender)
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            return self._on_request(msg, sender, legacy=kind == "MISSION_REQUEST")
        if kind == "MISSION_CLEAR_ALL":
            return self._on_clear(msg, sender)
        if kind == "MISSION_ACK":
            up = self._upload
            if up is not None and up.partner == sender and msg.type != mavlink.MAV_MISSION_ACCEPTED:
                self._upload = None  # the GCS cancelled its upload
        return []

    def poll(self, now_s: float) -> list[MAVMessage]:
        """Re-request the awaited item after a timeout; give up after max_retries."""
        up = self._upload
        if up is None or now_s - up.last_request_s < self.config.timeout_s:
            return []
        if up.retries >= self.config.max_retries:
            self._upload = None
            return [_ack(up.partner, mavlink.MAV_MISSION_OPERATION_CANCELLED, up.mission_type)]
        up.retries += 1
        return [self._request_next(up, now_s)]

    def _has_home(self, mission_type: int) -> bool:
        return self.config.home_item and mission_type == MissionType.MISSION

    def _count(self, mission_type: int) -> int:
        n = len(self._stores[mission_type])
        return max(n, 1) if self._has_home(mission_type) else n

    def _request_next(self, up: _Upload, now_s: float) -> MAVMessage:
        up.last_request_s = now_s
        return mavlink.MAVLink_mission_request_int_message(
            up.partner[0], up.partner[1], len(up.items), up.mission_type
        )

    def _on_count(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        mtype = msg.mission_type
        if mtype not in self._stores:
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mtype)]
        up = self._upload
        if up is not None and (up.partner != sender or up.mission_type != mtype):
            return [_ack(sender, mavlink.MAV_MISSION_DENIED, mtype)]
        if up is not None and up.items and up.count == msg.count:
            return [self._request_next(up, now_s)]  # a late duplicate of the COUNT
        if msg.count > self.config.capacity[mtype]:
            self._upload = None
            return [_ack(sender, mavlink.MAV_MISSION_NO_SPACE, mtype)]
        if msg.count == 0:
            self._upload = None
            self._commit(mtype, [])
            return [_ack(sender, mavlink.MAV_MISSION_ACCEPTED, mtype)]
        self._done = None
        self._upload = _Upload(sender, mtype, msg.count, [], now_s)
        return [self._request_next(self._upload, now_s)]

    def _on_item(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        up = self._upload
        if up is None or up.partner != sender or up.mission_type != msg.mission_type:
            done = self._done
            if done and done.partner == sender and done.mission_type == msg.mission_type and done.last_seq == msg.seq:
                return [_ack(sender, mavlink.MAV_MISSION_ACCEPTED, msg.mission_type)]  # our ACK was lost
            if up is not None:
                return [_ack(sender, mavlink.MAV_MISSION_DENIED, msg.mission_type)]
            return []
        expected = len(up.items)
        if msg.seq < expected:
            return [self._request_next(up, now_s)]  # a late duplicate: ask again for the one we need
        if msg.seq != expected:
            return [_ack(sender, mavlink.MAV_MISSION_INVALID_SEQUENCE, up.mission_type)]
        item = WireItem.from_msg(msg)
        if item.frame not in SUPPORTED_FRAMES:
            self._upload = None
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED_FRAME, up.mission_type)]
        up.items.append(item)
        up.retries = 0
        if len(up.items) < up.count:
            return [self._request_next(up, now_s)]
        self._upload = None
        self._commit(up.mission_type, up.items)
        self._done = _Done(sender, up.mission_type, up.count - 1)
        return [_ack(sender, mavlink.MAV_MISSION_ACCEPTED, up.mission_type)]

    def _on_request_list(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if msg.mission_type not in self._stores:
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)]
        if self._upload is not None:
            return [_ack(sender, mavlink.MAV_MISSION_DENIED, msg.mission_type)]
        return [mavlink.MAVLink_mission_count_message(sender[0], sender[1], self._count(msg.mission_type),
                                                      msg.mission_type)]

    def _on_request(self, msg: MAVMessage, sender: tuple[int, int], *, legacy: bool) -> list[MAVMessage]:
        mtype = msg.mission_type
        up = self._upload
        if up is not None and up.partner == sender and up.mission_type == mtype:
            return []
        if mtype not in self._stores:
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mtype)]
        if not 0 <= msg.seq < self._count(mtype):
            return [_ack(sender, mavlink.MAV_MISSION_INVALID_SEQUENCE, mtype)]
        if self._has_home(mtype) and msg.seq == 0:
            return [self.home.to_msg(sender, legacy=legacy)]
        return [self._stores[mtype][msg.seq].to_msg(sender, legacy=legacy)]

    def _on_clear(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if self._upload is not None:
            return [_ack(sender, mavlink.MAV_MISSION_DENIED, msg.mission_type)]
        types = list(self._stores) if msg.mission_type == MissionType.ALL else [msg.mission_type]
        if any(t not in self._stores for t in types):
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)]
        for t in types:
            self._commit(t, [])
        return [_ack(sender, mavlink.MAV_MISSION_ACCEPTED, msg.mission_type)]

    def _commit(self, mission_type: int, items: list[WireItem]) -> None:
        store = self.config.store
        self._stores[mission_type] = [store(it) for it in items] if store else list(items)
        self.versions[mission_type] += 1


def _ack(target: tuple[int, int], result: int, mission_type: int) -> MAVMessage:
    return mavlink.MAVLink_mission_ack_message(target[0], target[1], result, mission_type)

