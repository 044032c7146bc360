"""PX4 v1.15.3's mission manager (`mavlink_mission.cpp`), vehicle side, as measured (research
report `px4` §1, §2, §12) and read from its source where not measured: a pure state machine
over the base class's three lists.

- one transfer at a time (IDLE, receiving, sending), with one partner: an upload asks for
  each item, the first after boot with MISSION_REQUEST and after PX4 has seen an _INT message
  with MISSION_REQUEST_INT (`int_mode`); it re-asks every 0.25 s and gives up 5 s after the
  last message with "Operation timeout" (no ACK); times are vehicle seconds (SITL's lockstep).
  PX4 checks 20 times in those 5 s; the simulator, whose steps can be longer than 0.25 s at a
  high speed-up, also waits for 20 checks (polls), so a busy test machine stalling the station
  for a moment is not taken for a lost link;
- items are parsed as they arrive (`sim.autopilot.px4.item_result`, `list_result`): a refusal ACKs at
  that item and ends the upload; the list is written to the inactive slot and replaces the
  stored one only when complete (atomic, any refusal or timeout keeps the old list);
- capacity is checked at the COUNT (NO_SPACE, no text, the old list kept);
- what is kept of an item is the station's model, `gcs.autopilots.px4_storage.stored_item`
  (with `sim.autopilot.px4.stored`'s correction);
  a read-back marks `current` on the item whose seq is the mission's current one, in every
  list, and answers a MISSION_REQUEST in the legacy frames (0 / 3) and float degrees;
- an upload identical to the stored list (PX4's CRC) changes nothing.

`uploaded_current[mission_type]` is the seq an accepted upload flagged `current` (-1: none);
`sent_frames` keeps each stored item's frame as sent (PX4 keeps it; its RTL reads a rally
point's). Texts end with a tab, as PX4's do."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from enum import Enum

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.autopilots.wire_item import MissionType, WireItem
from sim.autopilot.mission_protocol import MAVMessage, MissionProtocol, ProtocolConfig
from sim.autopilot.px4 import (
    LEGACY_FRAME,
    MISSION_RETRY_S,
    MISSION_TIMEOUT_S,
    item_result,
    list_result,
    same_items,
    stored,
)

_TIMEOUT_POLLS = round(MISSION_TIMEOUT_S / MISSION_RETRY_S)


class _State(Enum):
    IDLE = 0
    RECEIVING = 1
    SENDING = 2


def px4_texts(text: str, severity: int, text_id: int) -> list[MAVMessage]:
    """A PX4 text as STATUSTEXTs: with its tab, in chunks of 50 characters, every text with the
    next `id` of the link (PX4 numbers all of them, one chunk or more)."""
    raw = (text + "\t").encode()
    return [mavlink.MAVLink_statustext_message(severity, raw[i:i + 50], text_id, k)
            for k, i in enumerate(range(0, len(raw), 50))]


class Px4MissionProtocol(MissionProtocol):
    """PX4's mission manager; `current_seq()` is the mission's current item (-1: none yet),
    `text_id()` the next STATUSTEXT id of the vehicle."""

    def __init__(self, config: ProtocolConfig, current_seq: Callable[[], int], text_id: Callable[[], int]) -> None:
        super().__init__(replace(config, home_item=False, store=None))
        self.current_seq = current_seq
        self._text_id = text_id
        self.int_mode = False
        self.uploaded_current: dict[int, int] = dict.fromkeys(self._stores, -1)
        self.sent_frames: dict[int, list[int]] = {t: [] for t in self._stores}
        self._sent: dict[int, list[WireItem]] = {t: [] for t in self._stores}
        self._state = _State.IDLE
        self._partner = (0, 0)
        self._mtype = int(MissionType.MISSION)
        self._seq = 0
        self._count = 0
        self._staged: list[WireItem] = []
        self._staged_current = -1
        self._last_sent_s: float | None = None
        self._last_recv_s: float | None = None
        self._polls = 0  # since the last message of the transfer

    @property
    def busy(self) -> bool:
        return self._state is not _State.IDLE

    def replace(self, items: list[WireItem], mission_type: int = MissionType.MISSION) -> None:
        items = [replace(it, seq=i, mission_type=mission_type) for i, it in enumerate(items)]
        self._store(mission_type, items, -1)

    def handle(self, msg: MAVMessage, now_s: float) -> list[MAVMessage]:
        kind = msg.get_type()
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind in ("MISSION_ITEM_INT", "MISSION_REQUEST_INT"):
            self.int_mode = True
        elif kind in ("MISSION_ITEM", "MISSION_REQUEST"):
            self.int_mode = False
        if kind == "MISSION_COUNT":
            return self._on_count(msg, sender, now_s)
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            return self._on_item(msg, sender, now_s)
        if kind == "MISSION_REQUEST_LIST":
            return self._on_request_list(msg, sender, now_s)
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            return self._on_request(msg, sender, now_s)
        if kind == "MISSION_CLEAR_ALL":
            return self._on_clear(msg, sender)
        if kind == "MISSION_ACK":
            return self._on_ack(msg, sender, now_s)
        return []

    def poll(self, now_s: float) -> list[MAVMessage]:
        if self._state is _State.IDLE:
            self._last_sent_s = self._last_recv_s = None
            return []
        self._polls += 1
        if self._last_recv_s is not None and now_s - self._last_recv_s > MISSION_TIMEOUT_S \
                and self._polls >= _TIMEOUT_POLLS:
            self._state = _State.IDLE
            return self._say("Operation timeout")
        if self._state is _State.RECEIVING and self._last_sent_s is not None \
                and now_s - self._last_sent_s > MISSION_RETRY_S:
            return [self._request(now_s)]
        return []

    # ---- messages -----------------------------------------------------------------------

    def _say(self, text: str, severity: int = mavlink.MAV_SEVERITY_CRITICAL) -> list[MAVMessage]:
        return px4_texts(text, severity, self._text_id())

    def _received(self, now_s: float) -> None:
        self._last_recv_s = now_s
        self._polls = 0

    def _ack(self, target: tuple[int, int], result: int) -> MAVMessage:
        return mavlink.MAVLink_mission_ack_message(target[0], target[1], result, self._mtype)

    def _request(self, now_s: float) -> MAVMessage:
        self._last_sent_s = now_s
        make = mavlink.MAVLink_mission_request_int_message if self.int_mode else mavlink.MAVLink_mission_request_message
        return make(self._partner[0], self._partner[1], self._seq, self._mtype)

    def _on_count(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        if self._state is _State.SENDING:
            return [*self._say("WPM: IGN MISSION_COUNT: Busy"), self._ack(sender, mavlink.MAV_MISSION_ERROR)]
        self._received(now_s)
        if self._state is _State.RECEIVING:
            if sender != self._partner:
                return [self._ack(sender, mavlink.MAV_MISSION_ERROR)]
            if self._seq == 0:
                return [self._request(now_s)]  # our request was lost
            return [*self._say("WPM: REJ. CMD: Busy"), self._ack(sender, mavlink.MAV_MISSION_ERROR)]
        self._partner = sender
        self._mtype = mtype = msg.mission_type
        if mtype not in self._stores:
            return [self._ack(sender, mavlink.MAV_MISSION_INVALID)]
        if msg.count > self.config.capacity[mtype]:
            return [self._ack(sender, mavlink.MAV_MISSION_NO_SPACE)]
        if msg.count == 0:
            self._store(mtype, [], 0)
            return [self._ack(sender, mavlink.MAV_MISSION_ACCEPTED)]
        self._state = _State.RECEIVING
        self._seq, self._count = 0, msg.count
        self._staged, self._staged_current = [], -1
        return [self._request(now_s)]

    def _on_item(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        if sender != self._partner:
            return self._say("REJ. MIS ITEM: partner id mismatch")
        if msg.mission_type != self._mtype:
            return [self._ack(sender, mavlink.MAV_MISSION_ERROR)]
        if self._state is _State.IDLE:
            if self._seq == msg.seq + 1:
                return [self._ack(sender, mavlink.MAV_MISSION_ACCEPTED)]  # the last item again: our ACK was lost
            return [*self._say("IGN MISSION_ITEM: No transfer"), self._ack(sender, mavlink.MAV_MISSION_ERROR)]
        if self._state is _State.SENDING:
            return [*self._say("IGN MISSION_ITEM: Busy"), self._ack(sender, mavlink.MAV_MISSION_ERROR)]
        self._received(now_s)
        if msg.seq != self._seq:
            return []  # not the awaited item: ignored
        item = _parsed(msg)
        result = item_result(item, int_mode=self.int_mode)
        if result != mavlink.MAV_MISSION_ACCEPTED:
            self._state = _State.IDLE
            return [*self._say("IGN MISSION_ITEM: Invalid item"), self._ack(sender, result)]
        if list_result(item) != mavlink.MAV_MISSION_ACCEPTED:
            self._state = _State.IDLE
            return [self._ack(sender, mavlink.MAV_MISSION_ERROR)]
        self._staged.append(item)
        if msg.current:
            self._staged_current = msg.seq
        self._seq = msg.seq + 1
        if self._seq < self._count:
            return [self._request(now_s)]
        self._state = _State.IDLE
        if not same_items(self._staged, self._sent[self._mtype]):
            self._store(self._mtype, self._staged, self._staged_current)
        return [self._ack(sender, mavlink.MAV_MISSION_ACCEPTED)]

    def _on_request_list(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        if self._seq == len(self._stores.get(self._mtype, ())):
            self._state = _State.IDLE  # the last download finished without its ACK
        same = msg.mission_type == self._mtype and sender == self._partner
        if self._state is _State.RECEIVING or (self._state is _State.SENDING and not same):
            return self._say("Mission download request ignored, already active", mavlink.MAV_SEVERITY_INFO)
        if msg.mission_type not in self._stores:
            return []
        self._received(now_s)
        self._state = _State.SENDING
        self._mtype = msg.mission_type
        self._seq, self._count = 0, len(self._stores[self._mtype])
        self._partner = sender
        return [mavlink.MAVLink_mission_count_message(sender[0], sender[1], self._count, self._mtype)]

    def _on_request(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        if sender != self._partner:
            return self._say("WPM: REJ. CMD: partner id mismatch")
        if self._state is _State.IDLE:
            return []
        if self._state is _State.RECEIVING:
            return self._say("WPM: REJ. CMD: Busy")
        if msg.mission_type != self._mtype:
            return []
        self._received(now_s)
        if msg.seq == self._seq and self._seq < self._count:
            self._seq += 1
        elif msg.seq != self._seq - 1 or msg.seq >= len(self._stores[self._mtype]):
            self._state = _State.IDLE
            return [self._ack(sender, mavlink.MAV_MISSION_ERROR), *self._say("WPM: REJ. CMD: Req. WP was unexpected")]
        return [self._readback(msg.seq, sender)]

    def _on_clear(self, msg: MAVMessage, sender: tuple[int, int]) -> list[MAVMessage]:
        if self._state is not _State.IDLE:
            return self._say("WPM: IGN CLEAR CMD: Busy")
        self._mtype = msg.mission_type
        types = list(self._stores) if msg.mission_type == MissionType.ALL else [msg.mission_type]
        for t in types:
            if t in self._stores:
                self._store(t, [], 0)
        return [self._ack(sender, mavlink.MAV_MISSION_ACCEPTED)]

    def _on_ack(self, msg: MAVMessage, sender: tuple[int, int], now_s: float) -> list[MAVMessage]:
        if sender != self._partner:
            return self._say("REJ. WP CMD: partner id mismatch")
        if self._state is _State.SENDING and msg.mission_type == self._mtype:
            self._state = _State.IDLE
        elif self._state is _State.RECEIVING:
            if msg.type == mavlink.MAV_MISSION_UNSUPPORTED:
                self.int_mode = not self.int_mode
                return [self._request(now_s)]
            if msg.type == mavlink.MAV_MISSION_OPERATION_CANCELLED:
                self._state = _State.IDLE
        return []

    # ---- storage ------------------------------------------------------------------------

    def _store(self, mission_type: int, items: list[WireItem], current: int) -> None:
        self._sent[mission_type] = list(items)
        self.sent_frames[mission_type] = [it.frame for it in items]
        self._stores[mission_type] = [stored(it) for it in items]
        self.uploaded_current[mission_type] = current
        self.versions[mission_type] += 1

    def _readback(self, seq: int, target: tuple[int, int]) -> MAVMessage:
        item = self._stores[self._mtype][seq]
        current = int(seq == self.current_seq())
        if self.int_mode:
            return replace(item, current=current).to_msg(target)
        if item.frame == mavlink.MAV_FRAME_MISSION:
            x, y = float(item.x), float(item.y)
        else:
            x, y = item.x * 1e-7, item.y * 1e-7
        return mavlink.MAVLink_mission_item_message(
            target[0], target[1], seq, LEGACY_FRAME.get(item.frame, item.frame), item.command, current,
            item.autocontinue, item.param1, item.param2, item.param3, item.param4, x, y, item.z, item.mission_type)


def _parsed(msg: MAVMessage) -> WireItem:
    """The item as PX4 reads it: MISSION_ITEM's float degrees become degE7 through a double
    (a frame-2 item's x, y are plain numbers)."""
    x, y = msg.x, msg.y
    if msg.get_type() == "MISSION_ITEM":
        scale = 1.0 if msg.frame == mavlink.MAV_FRAME_MISSION else 1e7
        x, y = round(x * scale), round(y * scale)
    return WireItem(seq=msg.seq, frame=msg.frame, command=msg.command, current=msg.current,
                    autocontinue=msg.autocontinue, param1=msg.param1, param2=msg.param2, param3=msg.param3,
                    param4=msg.param4, x=int(x), y=int(y), z=msg.z, mission_type=msg.mission_type)
