"""ArduPilot's side of the mission protocol, as measured on ArduCopter and ArduPlane 4.7 SITL
(research report `ardupilot_protocol`, sections named below). A pure state machine like its
base class: messages and the vehicle's time in, messages out (STATUSTEXT included).

How it differs from the generic `MissionProtocol`:

- items are asked for with MISSION_REQUEST (id 40) only; MISSION_ITEM_INT and the float
  MISSION_ITEM are both accepted, the latter with a warning and float32 arithmetic (Q1);
- mission and rally items are written as they arrive: an accepted COUNT truncates the stored
  list to at most COUNT items, and an upload refused at item k leaves new items before k and old
  ones after it (Q4); the fence is staged and validated when complete, all or nothing (Q2);
- each item is checked as it arrives (`sim.autopilot.ardupilot.item_result`) and a refusal ends the upload
  at that item (Q4);
- capacities per vehicle type, refused at the COUNT with MAV_MISSION_NO_SPACE and the text
  "Only N items are supported" (Q3);
- a COUNT from the uploading station restarts its upload; a stale or early item gets
  INVALID_SEQUENCE and the upload goes on; an item of a list not being uploaded gets
  MAV_MISSION_ERROR; reading or clearing a list while it is uploaded is refused; a station's
  cancelling MISSION_ACK is ignored (Q3, Q4);
- re-request after 1 s without an item, give up 8 s after the last one with
  OPERATION_CANCELLED and "Mission upload timeout" (Q3), in vehicle time (the give-up in real
  time when the fleet is sped up: `sim.autopilot.vehicle.SimVehicle.started_at_speedup`);
- a fence of fewer than 3 vertices and circles replacing a larger one is wiped right after its
  ACK, unless the previous fence was already that small or cleared over 2 s before (Q2).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import MissionType, WireItem
from sim.autopilot.ardupilot import (
    fence_leaves_no_end_marker,
    fence_problems,
    fence_total,
    from_legacy_item,
    item_result,
    to_legacy_item,
)
from sim.autopilot.mission_protocol import MAVMessage, MissionProtocol, ProtocolConfig, _ack

#: Seconds after the last item an upload is given up (ArduPilot's MissionItemProtocol, 8000 ms).
UPLOAD_GIVE_UP_S = 8.0

_UPLOAD_NAME = {MissionType.MISSION: "Mission", MissionType.FENCE: "Fence", MissionType.RALLY: "Rally"}
_WARNING_INTERVAL_S = 30.0
_FENCE_CLEAR_SETTLE_S = 2.0


def _text(text: str, severity: int = mavlink.MAV_SEVERITY_INFO) -> MAVMessage:
    return mavlink.MAVLink_statustext_message(severity, text.encode()[:50])


@dataclass(slots=True)
class _Receiving:
    partner: tuple[int, int]
    mission_type: int
    count: int
    next_seq: int
    last_request_s: float
    last_receive_s: float
    staged: list[WireItem] = field(default_factory=list)


class ArduPilotMissionProtocol(MissionProtocol):
    """`handle(msg, now_s)` / `poll(now_s)` with now in the vehicle's seconds. `writes` lists
    (mission_type, seq) of every item written in place since the vehicle last emptied it."""

    def __init__(self, config: ProtocolConfig, *, give_up_s: float = UPLOAD_GIVE_UP_S) -> None:
        super().__init__(config)
        self.give_up_s = give_up_s
        self.writes: list[tuple[int, int]] = []
        self._receiving: _Receiving | None = None
        self._warned: dict[str, float] = {}
        self._fence_total = 0
        self._fence_cleared_s: float | None = None
        self._now_s = 0.0

    @property
    def busy(self) -> bool:
        return self._receiving is not None

    def handle(self, msg: MAVMessage, now_s: float) -> list[MAVMessage]:
        """As the base class dispatches; a station's MISSION_ACK, even a cancel, is ignored (Q3):
        the base class's upload, which it would end, is never used here."""
        self._now_s = now_s
        return super().handle(msg, now_s)

    def poll(self, now_s: float) -> list[MAVMessage]:
        up = self._receiving
        if up is None:
            return []
        if now_s - up.last_receive_s > self.give_up_s:
            self._receiving = None
            return [_ack(up.partner, mavlink.MAV_MISSION_OPERATION_CANCELLED, up.mission_type),
                    _text(f"{_UPLOAD_NAME[up.mission_type]} upload timeout", mavlink.MAV_SEVERITY_WARNING)]
        if now_s - up.last_request_s > self.config.timeout_s:
            return [self._request(up, now_s)]
        return []

    # ---- upload --------------------------------------------------------------------------

    def _uploading(self, mission_type: int) -> bool:
        return self._receiving is not None and self._receiving.mission_type == mission_type

    def _request(self, up: _Receiving, now_s: float) -> MAVMessage:
        up.last_request_s = now_s
        return mavlink.MAVLink_mission_request_message(up.partner[0], up.partner[1], up.next_seq, up.mission_type)

    def _on_count(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        mtype = msg.mission_type
        if mtype not in self._stores:
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mtype)]
        if self._uploading(mtype):
            if self._receiving.partner != sender:
                return [_ack(sender, mavlink.MAV_MISSION_DENIED, mtype)]
            self._receiving = None  # the same station starts over
        capacity = self.config.capacity[mtype]
        if msg.count > capacity:
            return [_ack(sender, mavlink.MAV_MISSION_NO_SPACE, mtype),
                    _text(f"Only {capacity} items are supported", mavlink.MAV_SEVERITY_WARNING)]
        if mtype != MissionType.FENCE:
            self._truncate(mtype, msg.count)
        if msg.count == 0:
            return self._complete(_Receiving(sender, mtype, 0, 0, now_s, now_s), now_s)
        self._receiving = up = _Receiving(sender, mtype, msg.count, 0, now_s, now_s)
        return [self._request(up, now_s)]

    def _on_item(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        mtype = msg.mission_type
        out: list[MAVMessage] = []
        if msg.get_type() == "MISSION_ITEM":
            item, converted = from_legacy_item(msg)
            if converted != mavlink.MAV_MISSION_ACCEPTED:
                return [_ack(sender, converted, mtype)]
            out += self._warn("got MISSION_ITEM; GCS should send MISSION_ITEM_INT")
        else:
            item = WireItem.from_msg(msg)
        if mtype not in self._stores:
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mtype)]
        up = self._receiving
        if up is None or up.mission_type != mtype:
            return [_ack(sender, mavlink.MAV_MISSION_ERROR, mtype)]
        if msg.seq != up.next_seq:
            return [_ack(sender, mavlink.MAV_MISSION_INVALID_SEQUENCE, mtype)]
        if sender != up.partner:
            return [_ack(sender, mavlink.MAV_MISSION_DENIED, mtype)]
        result = item_result(item)
        if result != mavlink.MAV_MISSION_ACCEPTED:
            self._receiving = None  # what was written so far stays (Q4)
            return [_ack(sender, result, mtype)]
        if mtype == MissionType.FENCE:
            up.staged.append(item)
        else:
            self._write(mtype, msg.seq, item)
        up.next_seq += 1
        up.last_receive_s = now_s
        if up.next_seq < up.count:
            return [self._request(up, now_s), *out]
        self._receiving = None
        return self._complete(up, now_s) + out

    def _complete(self, up: _Receiving, now_s: float) -> list[MAVMessage]:
        ack = _ack(up.partner, mavlink.MAV_MISSION_ACCEPTED, up.mission_type)
        if up.mission_type == MissionType.MISSION:
            return [ack, _text("Flight plan received")]
        if up.mission_type == MissionType.RALLY:
            return [ack]
        problems = fence_problems(up.staged, self.config.capacity[MissionType.FENCE])
        if problems:
            return [_ack(up.partner, mavlink.MAV_MISSION_ERROR, MissionType.FENCE),
                    *(_text(p, mavlink.MAV_SEVERITY_WARNING) for p in problems)]
        if fence_leaves_no_end_marker(up.staged, self.config.capacity[MissionType.FENCE]):
            return []
        old_total = self._fence_total
        if self._fence_cleared_s is not None and now_s - self._fence_cleared_s >= _FENCE_CLEAR_SETTLE_S:
            old_total = 0
        self._fence_total = fence_total(up.staged)
        self._fence_cleared_s = None
        # FENCE_TOTAL going from non-zero to 0 reads to ArduPilot's loader as an old GCS clearing
        # the fence: it formats the storage, and the fence just accepted is gone (Q2)
        wiped = old_total != 0 and self._fence_total == 0
        self._commit(MissionType.FENCE, [] if wiped else up.staged)
        return [ack, _text("Fence Indexed OK")]

    def _write(self, mission_type: int, seq: int, item: WireItem) -> None:
        store = self._stores[mission_type]
        kept = self.config.store(item) if self.config.store else item
        if seq < len(store):
            store[seq] = kept
        else:
            store.append(kept)
        self.versions[mission_type] += 1
        self.writes.append((mission_type, seq))

    def _truncate(self, mission_type: int, count: int) -> None:
        store = self._stores[mission_type]
        if len(store) > count:
            del store[count:]
            self.versions[mission_type] += 1
            self.writes.append((mission_type, count))

    # ---- download and clear --------------------------------------------------------------

    def _on_request_list(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if self._uploading(msg.mission_type):
            return [_ack(sender, mavlink.MAV_MISSION_DENIED, msg.mission_type)]
        return super()._on_request_list(msg, sender)

    def _on_request(self, msg: MAVMessage, sender: tuple[int, int], *, legacy: bool) -> list[MAVMessage]:
        mtype = msg.mission_type
        if mtype not in self._stores:
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mtype)]
        if self._uploading(mtype):
            return [_ack(sender, mavlink.MAV_MISSION_DENIED, mtype)]
        if not 0 <= msg.seq < self._count(mtype):
            return [_ack(sender, mavlink.MAV_MISSION_INVALID_SEQUENCE, mtype)]
        item = self.items(mtype)[msg.seq]
        if not legacy:
            return [item.to_msg(sender)]
        return [to_legacy_item(item, sender), *self._warn("got MISSION_REQUEST; use MISSION_REQUEST_INT!")]

    def _on_clear(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        types = list(self._stores) if msg.mission_type == MissionType.ALL else [msg.mission_type]
        if any(t not in self._stores for t in types):
            return [_ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)]
        if any(self._uploading(t) for t in types):
            return [_ack(sender, mavlink.MAV_MISSION_ERROR, msg.mission_type)]
        for t in types:
            self._commit(t, [])
            if t == MissionType.FENCE:
                self._fence_cleared_s = self._now_s
        return [_ack(sender, mavlink.MAV_MISSION_ACCEPTED, msg.mission_type)]

    def _warn(self, text: str) -> list[MAVMessage]:
        """A deprecation warning, at most once per 30 s each."""
        last = self._warned.get(text)
        if last is not None and self._now_s - last < _WARNING_INTERVAL_S:
            return []
        self._warned[text] = self._now_s
        return [_text(text, mavlink.MAV_SEVERITY_WARNING)]
